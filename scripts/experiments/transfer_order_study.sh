#!/usr/bin/env bash
# The runtime's policy for T-jobs on shared media (`--transfer-order`: channel, resource,
# exclusive) under each scheduler: throughput, how far T-job durations depart from the plan,
# and LAN utilisation, mean over seeds. Prints a Markdown table.
# Usage: scripts/experiments/transfer_order_study.sh [SEEDS=2]
set -euo pipefail
if [[ "${1:-}" == "--help" || "${1:-}" == "-h" ]]; then sed -n '2,5p' "$0" | sed 's/^# \{0,1\}//'; exit 0; fi
cd "$(dirname "$0")/../.."
SEEDS="${1:-2}"
BIN=build/apps/rayline
[ -x "$BIN" ] || { echo "transfer_order_study: build first (scripts/setup.sh)" >&2; exit 2; }
[[ "$SEEDS" =~ ^[1-9][0-9]*$ ]] || { echo "transfer_order_study: SEEDS must be a positive integer, not '$SEEDS'" >&2; exit 2; }
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
# label | simulate flags | schedulers
CASES=(
  "8 nodes, ray stream, 60 s|--platform paper-cluster --duration 60s|gmb gmb-ca budge loadanyonce"
  "8 nodes, museum, 8 clients, 20 s|--platform paper-cluster --workload museum --clients 8 --duration 20s|gmb gmb-ca budge"
  "8 nodes, Boeing, 8 clients, 20 s|--platform paper-cluster --workload boeing --clients 8 --duration 20s|gmb gmb-ca budge"
  "workstation, museum, 8 clients, 10 s|--platform workstation-4gpu --workload museum --clients 8 --duration 10s|gmb gmb-ca"
)
echo "| run | scheduler | rays/s: channel | resource | exclusive | T-job duration error: channel | resource | exclusive | LAN: channel | resource | exclusive |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
i=0
for c in "${CASES[@]}"; do
  IFS='|' read -r label flags schedulers <<< "$c"
  for s in $schedulers; do
    i=$((i + 1))
    for order in channel resource exclusive; do
      for seed in $(seq "$SEEDS"); do
        # shellcheck disable=SC2086
        "$BIN" simulate $flags --scheduler "$s" --transfer-order "$order" --seed "$seed" --no-timeline \
          --no-progress --out "$OUT/$i-$order-$seed" > /dev/null
      done
    done
    /usr/bin/python3 - "$OUT" "$i" "$SEEDS" "$label" "$s" <<'PY'
import json, statistics, sys
out, i, n, label, s = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4], sys.argv[5]
orders = ["channel", "resource", "exclusive"]
ms = {o: [json.load(open(f"{out}/{i}-{o}-{k}/metrics.json")) for k in range(1, n + 1)] for o in orders}
# Path tracing: steady rays/s after the warm-up; the ray stream: rays/s over the run.
rays = lambda m: m["path_trace"]["steady_rays_per_second"] if "path_trace" in m else m["rays_per_second"]
mean = lambda o, f: statistics.mean(f(m) for m in ms[o])
best = max(orders, key=lambda o: mean(o, rays))
cell = lambda o: (f"**{mean(o, rays) / 1e6:.2f} M**" if o == best else f"{mean(o, rays) / 1e6:.2f} M")
err = lambda o: f"{mean(o, lambda m: m['prediction_error']['transfer_mean_rel']) * 100:.1f} %"
lan = lambda o: f"{mean(o, lambda m: m.get('lan_utilisation_mean') or 0) * 100:.0f} %"
print(f"| {label} | {s} | " + " | ".join(cell(o) for o in orders) + " | " + " | ".join(err(o) for o in orders)
      + " | " + " | ".join(lan(o) for o in orders) + " |")
PY
  done
done
