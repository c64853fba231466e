#!/usr/bin/env bash
# End-to-end renderer benchmark: a generated museum-like scene of TRIANGLES
# triangles rendered in core and at 25 % and 10 % memory budgets; budget runs against in
# core by the whole wall time of each run (loads included). In-core speed against Embree's
# own tutorial: scripts/bench_embree.sh.
# Usage: scripts/bench_render.sh [TRIANGLES=10000000] [RES=256] [SPP=16] [DEPTH=5]
# Environment: RAYLINE_BIN (another rayline binary), RENDER_FLAGS (extra render flags, e.g.
# "--paths 131072 --read-ahead off"), BENCH_DIR (work folder, default out/bench-render),
# OOC_BLOCKS (blocks of the budget runs, default 63: what `rayline render` picks for 10 M
# triangles at these budgets), REPS (default 1): REPS > 1 then renders in core (1 block) and at 25 % REPS more times, in
# turn, and prints the medians of the whole-run times and of the ratios of each pair.
set -euo pipefail
cd "$(dirname "$0")/.."
TRIS="${1:-10000000}"; RES="${2:-256}"; SPP="${3:-16}"; DEPTH="${4:-5}"
BIN="${RAYLINE_BIN:-build/apps/rayline}"  # RAYLINE_BIN=/path/to/other/rayline for an A/B
[ -x "$BIN" ] || { echo "build first: scripts/setup.sh" >&2; exit 2; }
WORK="${BENCH_DIR:-out/bench-render}"
mkdir -p "$WORK"
PLY="$WORK/museum-$TRIS.ply"
SCENE="$WORK/museum-$TRIS.json"  # written by the generator next to the PLY: camera, lights, materials
[ -f "$PLY" ] || "$BIN" generate museum-like --triangles "$TRIS" --out "$PLY" > /dev/null
CAM=$(/usr/bin/python3 -c "
import json; c = next(iter(json.load(open('$SCENE'))['cameras'].values()))
print(*c['position'], *c['look_at'], *c['up'], c['fov_deg'])")
read -r PX PY PZ LX LY LZ UX UY UZ FOV <<< "$CAM"
part() { [ -f "$WORK/blocks-$1/blocks.json" ] || "$BIN" partition -q --scene "$SCENE" --blocks "$1" --out "$WORK/blocks-$1" > /dev/null; }
run() {  # label blocks budget
  local label="$1" blocks="$2" budget="$3" extra=()
  [ -n "$budget" ] && extra=(--memory-budget "$budget")
  part "$blocks"
  "$BIN" render -q --scene "$SCENE" --blocks-dir "$WORK/blocks-$blocks" --resolution "${RES}x${RES}" --spp "$SPP" \
    --max-depth "$DEPTH" "${extra[@]}" ${RENDER_FLAGS:-} --out "$WORK/$label.exr"
  /usr/bin/python3 - "$WORK/$label.metrics.json" "$label" <<'PY'
import json, sys
m = json.load(open(sys.argv[1])); io = m["io"]
print(f"| {sys.argv[2]} | {m['blocks']} | {m['memory']['budget_bytes']/2**20:.0f} MiB | {m['bvh_quality']} | {m['seconds']:.2f} s | "
      f"{m['rays_per_second']/1e6:.2f} M | {m['samples_per_second']/1e3:.1f} k | {io['loads']} | "
      f"{io['bytes_read']/1e6:.0f} MB | {io['bvh_build_seconds']:.1f} s | {io['disk_busy_fraction']*100:.0f} % | "
      f"{io.get('disk_read_fraction', 0)*100:.0f} % | {io.get('disk_busy_when_io_bound', 0)*100:.0f} % of {io.get('io_bound_seconds', 0):.1f} s | {m['memory']['paths_in_flight_cap']} | {m['memory']['peak_rss_bytes']/2**20:.0f} MiB | {io['mode']} |")
PY
}
OOC="${OOC_BLOCKS:-63}"
part 16
part "$OOC"
# The budgets are shares of the block bytes of the partition the budget runs use.
"$BIN" render -q --scene "$SCENE" --blocks-dir "$WORK/blocks-$OOC" --resolution 8x8 --spp 1 --bvh-quality low --out "$WORK/probe.exr"
SCENE_BYTES=$(/usr/bin/python3 -c "import json;print(json.load(open('$WORK/probe.metrics.json'))['memory']['scene_block_bytes'])")
echo "scene: $TRIS triangles, $((SCENE_BYTES / 1048576)) MiB of blocks in RAM (low-quality BVH); ${RES}x${RES}, $SPP spp, max depth $DEPTH, $(nproc) threads"
echo "| run | blocks | budget | BVH | wall | rays/s | samples/s | loads | read | BVH builds | channel busy | disk reading | channel busy when I/O-bound | paths | peak RSS | I/O |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
run in-core-1 1 ""
run in-core-16 16 ""
run budget-25 "$OOC" "$((SCENE_BYTES / 4))B"
run budget-10 "$OOC" "$((SCENE_BYTES / 10))B"
/usr/bin/python3 - "$WORK" <<'PY'
import json, sys
w = sys.argv[1]
m = {k: json.load(open(f"{w}/{k}.metrics.json")) for k in ("in-core-1", "in-core-16", "budget-25", "budget-10")}
base = m["in-core-1"]["samples_per_second"]
for k in ("in-core-16", "budget-25", "budget-10"):
    print(f"{k}: {m[k]['samples_per_second']/base:.2f}x in core (1 block), whole runs")
PY
REPS="${REPS:-1}"
if [ "$REPS" -gt 1 ]; then
  for i in $(seq 1 "$REPS"); do
    for r in in-core-1 budget-25; do
      if [ $r = in-core-1 ]; then b=1; extra=(); else b=$OOC; extra=(--memory-budget "$((SCENE_BYTES / 4))B"); fi
      "$BIN" render -q --scene "$SCENE" --blocks-dir "$WORK/blocks-$b" --resolution "${RES}x${RES}" --spp "$SPP" \
        --max-depth "$DEPTH" "${extra[@]}" ${RENDER_FLAGS:-} --out "$WORK/rep-$r-$i.exr"
    done
  done
  /usr/bin/python3 - "$WORK" "$REPS" <<'PY'
import json, statistics, sys
w, n = sys.argv[1], int(sys.argv[2])
t = {r: [json.load(open(f"{w}/rep-{r}-{i}.metrics.json"))["seconds"] for i in range(1, n + 1)] for r in ("in-core-1", "budget-25")}
ratios = [a / b for a, b in zip(t["in-core-1"], t["budget-25"])]
print(f"\n{n} alternating pairs: in core {statistics.median(t['in-core-1']):.2f} s (" + ", ".join(f"{x:.2f}" for x in t["in-core-1"]) +
      f"), 25 % {statistics.median(t['budget-25']):.2f} s (" + ", ".join(f"{x:.2f}" for x in t["budget-25"]) +
      f"); 25 % / in core, median of pairs: {statistics.median(ratios):.2f}x (" + ", ".join(f"{x:.2f}" for x in ratios) + ")")
PY
fi
