#!/usr/bin/env bash
# GMB's aging threshold (Sec. 4.3) under the saturating ray stream: throughput and how long
# E-jobs wait in the queue, for each horizon k and aging setting, mean over seeds. Prints a
# Markdown table. Usage: scripts/experiments/aging_study.sh [DURATION=60s] [SEEDS=3]
#   [PLATFORM=paper-cluster]
set -euo pipefail
if [[ "${1:-}" == "--help" || "${1:-}" == "-h" ]]; then sed -n '2,5p' "$0" | sed 's/^# \{0,1\}//'; exit 0; fi
cd "$(dirname "$0")/../.."
DURATION="${1:-60s}"
SEEDS="${2:-3}"
PLATFORM="${3:-paper-cluster}"
BIN=build/apps/rayline
[ -x "$BIN" ] || { echo "aging_study: build first (scripts/setup.sh)" >&2; exit 2; }
[[ "$SEEDS" =~ ^[1-9][0-9]*$ ]] || { echo "aging_study: SEEDS must be a positive integer, not '$SEEDS'" >&2; exit 2; }
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
echo "| k | aging | rays/s | queue wait p50 | p95 | oldest queued at end | CPU time fetching |"
echo "|---|---|---|---|---|---|---|"
for k in 2s 10s; do
  for aging in auto off 30s 5s adaptive; do
    for seed in $(seq "$SEEDS"); do
      "$BIN" simulate --platform "$PLATFORM" --duration "$DURATION" -k "$k" --aging "$aging" --seed "$seed" \
        --no-progress --out "$OUT/$k-$aging-$seed" > /dev/null
    done
    /usr/bin/python3 - "$OUT" "$k" "$aging" "$SEEDS" <<'PY'
import json, statistics, sys
out, k, aging, n = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
ms = [json.load(open(f"{out}/{k}-{aging}-{s}/metrics.json")) for s in range(1, n + 1)]
mean = lambda f: statistics.mean(f(m) for m in ms)
label = aging if aging != "auto" else "auto (" + ms[0]["scheduler_parameters"].split("aging=")[1].split(";")[0].replace("0000s", " s") + ")"
print(f"| {k} | {label} | {mean(lambda m: m['rays_per_second']) / 1e6:.2f} M | "
      f"{mean(lambda m: m['queue_wait_s']['p50']):.1f} s | {mean(lambda m: m['queue_wait_s']['p95']):.1f} s | "
      f"{mean(lambda m: m['queue_wait_s']['oldest_queued_at_end']):.1f} s | "
      f"{mean(lambda m: m['device_summary']['cpu']['fetching']) * 100:.0f} % |")
PY
  done
done
