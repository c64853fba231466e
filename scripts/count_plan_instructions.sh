#!/bin/bash
# Instructions per warm GMB plan of the bench_sched_gmb instance, counted by
# valgrind's callgrind around plan() alone: deterministic, unlike wall time on a shared
# machine. Usage: scripts/count_plan_instructions.sh [--cold] [PLATFORM.json] [HORIZON_S] [PLANS]
#   defaults: platforms/paper-cluster.json 2 10.  BUILD_DIR (default build) holds the binary.
#   --cold: a new scheduler for every plan (its construction counted, its teardown not).
set -euo pipefail
if [[ "${1:-}" == "--help" || "${1:-}" == "-h" ]]; then sed -n '2,6p' "$0" | sed 's/^# \{0,1\}//'; exit 0; fi
COLD=()
if [[ "${1:-}" == "--cold" ]]; then COLD=(--cold); shift; fi
cd "$(dirname "$0")/.."
BIN="${BUILD_DIR:-build}/bench/plan_instructions"
command -v valgrind >/dev/null || { echo "count_plan_instructions: valgrind is not installed (apt-get install valgrind)" >&2; exit 2; }
[[ -x "$BIN" ]] || { echo "count_plan_instructions: $BIN not built (needs valgrind/callgrind.h at configure time)" >&2; exit 2; }
PLANS="${3:-10}"
OUT="$(mktemp -d)"
trap 'rm -rf "$OUT"' EXIT
valgrind --tool=callgrind --collect-atstart=no --callgrind-out-file="$OUT/cg.out" \
  "$BIN" "${COLD[@]}" "${1:-platforms/paper-cluster.json}" "${2:-2}" "$PLANS" > "$OUT/stdout" 2> "$OUT/stderr" ||
  { grep -v '^==' "$OUT/stderr" >&2; exit 2; }
cat "$OUT/stdout"
total=$(callgrind_annotate "$OUT/cg.out" 2>/dev/null | awk '/PROGRAM TOTALS/ {gsub(",", "", $1); print $1}')
echo "instructions/plan $((total / PLANS))"
