#!/usr/bin/env bash
# Runs the fuzz targets of tests/fuzz/ under libFuzzer with ASan + UBSan (LeakSanitizer on),
# one after the other, and reports per target. docs/fuzzing.md explains the targets.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD

usage() {
  cat <<'USAGE'
usage: scripts/fuzz.sh [--minutes N] [--build-dir DIR] [--work DIR] [--jobs N] [TARGET...]
       scripts/fuzz.sh --replay-sanitized [--build-dir DIR] [--jobs N]
       scripts/fuzz.sh --list | --help

Fuzzing (the default): configures and builds a clang libFuzzer build of tests/fuzz/
(-DRAYLINE_FUZZ=ON: -fsanitize=fuzzer,address,undefined; default build dir build-fuzz/),
then runs each TARGET (default: all) for N minutes (default 10), one at a time, with
-timeout=10 -rss_limit_mb=4096. Each target works on a copy of its committed seeds
(tests/fuzz/corpus/<target>/) in WORK/<target>/corpus (default WORK:
${TMPDIR:-/tmp}/rayline-fuzz-work; it is kept between runs, so runs add up); findings are
saved in WORK/<target>/findings/ and its log in WORK/<target>/fuzz.log.
Prints per target: minutes, runs, new corpus entries, corpus size, findings (with paths).
A target stops at its first finding (crash, sanitizer report, leak, uncaught exception,
timeout or out-of-memory). Exit status 1 when any target found something.

--replay-sanitized: builds the fuzz targets without libFuzzer under -DRAYLINE_SANITIZE=ON
(ASan + UBSan with g++, -O0 -g; default build dir build-fuzz-asan/) and replays the committed corpus
with ctest -L fuzz. This is the check CI can run besides the normal test suite.

--jobs N: parallel compile jobs (default 2). The compiler cache is used when ccache is
installed (CCACHE_DIR as set in the environment).

Targets: platform job_set scene_profile scene ply obj stl off gltf assimp block block_index run_metrics jobs_csv
USAGE
}

ALL_TARGETS=(platform job_set scene_profile scene ply obj stl off gltf assimp block block_index run_metrics jobs_csv)
MINUTES=10
BUILD_DIR=""
WORK="${TMPDIR:-/tmp}/rayline-fuzz-work"
JOBS=2
MODE=fuzz
TARGETS=()
while (($#)); do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --list) printf '%s\n' "${ALL_TARGETS[@]}"; exit 0 ;;
    --minutes) MINUTES="${2:?--minutes needs a number}"; shift 2 ;;
    --build-dir) BUILD_DIR="${2:?--build-dir needs a folder}"; shift 2 ;;
    --work) WORK="${2:?--work needs a folder}"; shift 2 ;;
    --jobs) JOBS="${2:?--jobs needs a number}"; shift 2 ;;
    --replay-sanitized) MODE=replay; shift ;;
    -*) echo "fuzz.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
    *)
      if [[ " ${ALL_TARGETS[*]} " != *" $1 "* ]]; then
        echo "fuzz.sh: unknown target '$1' (targets: ${ALL_TARGETS[*]})" >&2; exit 2
      fi
      TARGETS+=("$1"); shift ;;
  esac
done
if ! [[ "$MINUTES" =~ ^[0-9]+([.][0-9]+)?$ ]] || [[ "$MINUTES" =~ ^0+([.]0*)?$ ]]; then
  echo "fuzz.sh: --minutes must be a positive number, not '$MINUTES'" >&2; exit 2
fi
((${#TARGETS[@]})) || TARGETS=("${ALL_TARGETS[@]}")

LAUNCHER=()
if command -v ccache >/dev/null; then
  LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi

configure_and_build() {  # build-dir, build type, cmake args...
  local dir=$1 type=$2; shift 2
  if [ ! -f "$dir/build.ninja" ]; then
    echo "fuzz.sh: configuring $dir"
    cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE="$type" -DRAYLINE_SKIP_SUBDIRS=sim \
      -DRAYLINE_BUILD_BENCH=OFF "${LAUNCHER[@]}" "$@" > "$dir.cmake.log" 2>&1 || { cat "$dir.cmake.log"; exit 1; }
  fi
  echo "fuzz.sh: building the fuzz targets in $dir (-j$JOBS)"
  cmake --build "$dir" --target fuzz_targets --parallel "$JOBS"
}

if [ "$MODE" = replay ]; then
  BUILD_DIR="${BUILD_DIR:-build-fuzz-asan}"
  # Debug (-O0 -g): a third of RelWithDebInfo's compile time, and the corpus still replays in seconds.
  configure_and_build "$BUILD_DIR" Debug -DRAYLINE_SANITIZE=ON
  exec ctest --test-dir "$BUILD_DIR" -L fuzz --output-on-failure -j"$JOBS"
fi

CXX_CLANG="${CXX_CLANG:-$(command -v clang++-14 || command -v clang++ || true)}"
if [ -z "$CXX_CLANG" ]; then
  echo "fuzz.sh: needs clang (libFuzzer): apt-get install clang-14 libclang-rt-14-dev" >&2; exit 2
fi
BUILD_DIR="${BUILD_DIR:-build-fuzz}"
configure_and_build "$BUILD_DIR" RelWithDebInfo -DRAYLINE_FUZZ=ON -DCMAKE_CXX_COMPILER="$CXX_CLANG"

mkdir -p "$WORK"
WORK=$(cd "$WORK" && pwd)
case "$WORK/" in "$ROOT"/*) echo "fuzz.sh: --work must lie outside the repository" >&2; exit 2 ;; esac
SECONDS_PER_TARGET=$(awk -v m="$MINUTES" 'BEGIN { s = int(m * 60 + 0.5); print (s < 1 ? 1 : s) }')
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
# Assimp runs in a child process with a CPU-time limit (render/scene/isolated_import.hpp):
# below -timeout, so that a file assimp loops on is the InputError it is in rayline.
export RAYLINE_ASSIMP_CPU_SECONDS="${RAYLINE_ASSIMP_CPU_SECONDS:-3}"
# The targets write each input to a scratch file: in memory where /dev/shm is available.
SCRATCH_BASE="$WORK"
if [ -d /dev/shm ] && [ -w /dev/shm ]; then SCRATCH_BASE=/dev/shm; fi

declare -a ROWS
found=0
for t in "${TARGETS[@]}"; do
  exe="$BUILD_DIR/tests/fuzz/fuzz_$t"
  dir="$WORK/$t"
  scratch="$SCRATCH_BASE/rayline-fuzz-scratch-$t.$$"
  rm -rf "$scratch"
  mkdir -p "$dir/corpus" "$dir/findings" "$scratch"
  cp -n "tests/fuzz/corpus/$t/"* "$dir/corpus/" 2>/dev/null || true
  before=$(find "$dir/corpus" -type f | wc -l)
  findings_before=$(find "$dir/findings" -type f | wc -l)
  dict=()
  [ -f "tests/fuzz/dict/$t.dict" ] && dict=(-dict="tests/fuzz/dict/$t.dict")
  echo "fuzz.sh: $t for $MINUTES min (corpus $before files, log $dir/fuzz.log)"
  set +e
  # The target's scratch files go to its own TMPDIR; a hang past -timeout is a finding,
  # and the outer timeout only guards against libFuzzer itself not stopping.
  TMPDIR="$scratch" timeout --kill-after=30 $((SECONDS_PER_TARGET + 120)) "$exe" \
    -max_total_time="$SECONDS_PER_TARGET" -timeout=10 -rss_limit_mb=4096 -print_final_stats=1 \
    -artifact_prefix="$dir/findings/" "${dict[@]}" "$dir/corpus" > "$dir/fuzz.log" 2>&1
  rc=$?
  set -e
  rm -rf "$scratch"
  runs=$(awk '/stat::number_of_executed_units:/ {n = $2} END {print n}' "$dir/fuzz.log")
  added=$(awk '/stat::new_units_added:/ {n = $2} END {print n}' "$dir/fuzz.log")
  after=$(find "$dir/corpus" -type f | wc -l)
  new_findings=$(( $(find "$dir/findings" -type f | wc -l) - findings_before ))
  what="none"
  if ((rc != 0 || new_findings > 0)); then
    found=1
    what="exit $rc"
    while IFS= read -r f; do what+=", $f"; done < <(find "$dir/findings" -type f -printf '%T@ %p\n' | sort -n | tail -n "$new_findings" | cut -d' ' -f2-)
    # The last report is the finding (an assimp child's own crash report is printed, and not one).
    grep -E 'ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)|runtime error:|FINDING:' "$dir/fuzz.log" | tail -2 | sed 's/^/    /' || true
  fi
  ROWS+=("$(printf '%-14s %7s %12s %8s %8s  %s' "$t" "$MINUTES" "${runs:-?}" "${added:-?}" "$after" "$what")")
done

echo
printf '%-14s %7s %12s %8s %8s  %s\n' target minutes runs new corpus findings
printf '%s\n' "${ROWS[@]}"
echo "(working corpora and findings under $WORK)"
exit "$found"
