#!/usr/bin/env bash
# End-to-end simulation benchmark: wall time to simulate DURATION of a platform
# under the saturating ray stream, for a few settings; prints a Markdown table built from
# each run's metrics.json. Usage: scripts/bench_simulate.sh [DURATION=60s] [REPEATS=3]
# The last two rows are a path-tracing run at 14 and 18 simulated seconds (fixed): it turns
# compute-bound after ~13 s and makes ~10^5 activities per simulated second from then on;
# the activities per wall second of the two rows show whether the cost per event grows.
set -euo pipefail
cd "$(dirname "$0")/.."
DURATION="${1:-60s}"
REPEATS="${2:-3}"
BIN=build/apps/rayline
[ -x "$BIN" ] || { echo "build first: scripts/setup.sh" >&2; exit 2; }
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
echo "| setting | simulated | wall (median of $REPEATS) | speed-up | activities/s | SimGrid s | scheduler s | rays/s | LAN util | transfer pred. err |"
echo "|---|---|---|---|---|---|---|---|---|---|"
run() {
  local label="$1"; shift
  for i in $(seq "$REPEATS"); do
    "$BIN" simulate --duration "${RUN_DURATION:-$DURATION}" --no-progress --out "$OUT/r$i" "$@" > /dev/null
  done
  /usr/bin/python3 - "$OUT" "$REPEATS" "$label" <<'PY'
import json, statistics, sys
out, n, label = sys.argv[1], int(sys.argv[2]), sys.argv[3]
ms = [json.load(open(f"{out}/r{i}/metrics.json")) for i in range(1, n + 1)]
ms.sort(key=lambda m: m["simulator"]["wall_s"])
m = ms[len(ms) // 2]
s = m["simulator"]
print(f"| {label} | {m['simulated_s']:.0f} s | {s['wall_s']:.3f} s | {s['speedup_vs_simulated']:.0f}x | "
      f"{s['activities_per_wall_s']:.0f} | {s['simgrid_s']:.3f} | {s['scheduler_s']:.3f} | {m['rays_per_second']:.3g} | "
      f"{m['lan_utilisation_mean']:.3f} | {m['prediction_error']['transfer_mean_rel']:.2f} |")
PY
}
run "paper cluster, GMB, k=2s"
run "paper cluster, completion-aware GMB" --scheduler gmb-ca
run "paper cluster, 512 smaller blocks" --blocks 512
run "paper cluster, k=10s" --horizon 10s
run "paper cluster, exec noise 20%" --exec-noise 0.2
run "single node A" --platform paper-A
RUN_DURATION=14s run "workstation, Boeing, 8 clients, 14 s" --platform workstation-4gpu --workload boeing --clients 8 --no-timeline
RUN_DURATION=18s run "workstation, Boeing, 8 clients, 18 s" --platform workstation-4gpu --workload boeing --clients 8 --no-timeline
