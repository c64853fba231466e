#!/usr/bin/env bash
# GPU ray-traversal benchmark, for a machine with a real GPU (it also runs on
# lavapipe, slowly). Configures BUILD_DIR once, builds only bench_gpu_trace, runs it with
# the defaults below and writes its JSON to OUT_JSON; further arguments go to
# bench_gpu_trace and override the defaults (e.g. --device H100 --repeat 20).
#
#   scripts/bench_gpu.sh [BUILD_DIR] [OUT_JSON] [bench_gpu_trace options...]
#   defaults: build-bench-gpu  bench_gpu.json
#             --device auto --triangles 1000000 --rays 4194304 --repeat 10
#
# Measures kernel-only rays/s (GPU timestamps) for coherent primary rays (a 2048x2048
# pinhole image in 8x8 tiles) and incoherent rays on the 1 M-triangle museum-like block,
# plus the CPU BVH build time, upload / download bandwidth and the share of rays the kernels
# flag doubtful (handed to the CPU in a render; render/vulkan/README.md).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR="${1:-build-bench-gpu}"
OUT="${2:-bench_gpu.json}"
if (($# >= 2)); then shift 2; else shift $#; fi

if [ ! -f "$BUILD_DIR/build.ninja" ]; then
  mkdir -p "$BUILD_DIR"
  cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release -DRAYLINE_BUILD_TESTS=OFF \
    > "$BUILD_DIR/cmake.log" 2>&1 || { cat "$BUILD_DIR/cmake.log"; exit 1; }
fi
cmake --build "$BUILD_DIR" --target bench_gpu_trace --parallel "$(nproc)"
"$BUILD_DIR/bench/bench_gpu_trace" --device auto --triangles 1000000 --rays 4194304 --repeat 10 \
  --json "$OUT" "$@"
