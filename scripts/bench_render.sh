#!/usr/bin/env bash
# End-to-end renderer benchmark (issue 6): a generated museum-like scene of TRIANGLES
# triangles rendered in core and at 25 % and 10 % memory budgets, and the same PLY through
# Embree's own `pathtracer` tutorial (Debian embree-tools) at the same resolution, spp and
# path length as the in-core anchor. Per-sample throughput excludes loading and BVH
# building: each renderer runs at SPP and 4·SPP and the difference is timed.
# Usage: scripts/bench_render.sh [TRIANGLES=10000000] [RES=256] [SPP=4] [DEPTH=5]
set -euo pipefail
cd "$(dirname "$0")/.."
TRIS="${1:-10000000}"; RES="${2:-256}"; SPP="${3:-4}"; DEPTH="${4:-5}"
BIN=build/apps/rayline
[ -x "$BIN" ] || { echo "build first: scripts/setup.sh" >&2; exit 2; }
WORK="${BENCH_DIR:-out/bench-render}"
mkdir -p "$WORK"
PLY="$WORK/museum-$TRIS.ply"
SCENE="$WORK/museum-$TRIS.json"  # written by the generator next to the PLY: camera, lights, materials
[ -f "$PLY" ] || "$BIN" generate museum-like --triangles "$TRIS" --out "$PLY" > /dev/null
# Embree's tutorial gets the same camera (the scene's first one) through its flags.
CAM=$(/usr/bin/python3 -c "
import json; c = next(iter(json.load(open('$SCENE'))['cameras'].values()))
print(*c['position'], *c['look_at'], *c['up'], c['fov_deg'])")
read -r PX PY PZ LX LY LZ UX UY UZ FOV <<< "$CAM"
SPP4=$((SPP * 4))
run() {  # label blocks budget
  local label="$1" blocks="$2" budget="$3" extra=()
  [ -n "$budget" ] && extra=(--memory-budget "$budget")
  local dir="$WORK/blocks-$blocks"
  [ -f "$dir/blocks.json" ] || "$BIN" partition -q --scene "$SCENE" --blocks "$blocks" --out "$dir" > /dev/null
  for s in "$SPP" "$SPP4"; do
    "$BIN" render -q --scene "$SCENE" --blocks-dir "$dir" --resolution "${RES}x${RES}" --spp "$s" --max-depth "$DEPTH" \
      "${extra[@]}" --out "$WORK/$label-$s.exr"
  done
  /usr/bin/python3 - "$WORK" "$label" "$SPP" "$SPP4" <<'PY'
import json, sys
w, label, a, b = sys.argv[1:]
m1, m2 = (json.load(open(f"{w}/{label}-{s}.metrics.json")) for s in (a, b))
dt = m2["seconds"] - m1["seconds"]
rays = m2["rays"]["created"] - m1["rays"]["created"]
samples = m2["rays"]["camera"] - m1["rays"]["camera"]
io = m2["io"]
print(f"| {label} | {m2['blocks']} | {m2['memory']['budget_bytes']/2**20:.0f} MiB | {m2['seconds']:.2f} s | "
      f"{rays/dt/1e6:.2f} M | {samples/dt/1e3:.1f} k | {rays/samples:.2f} | {io['loads']} | "
      f"{io['bytes_read']/1e6:.0f} MB | {io['disk_busy_fraction']*100:.0f} % | {io['mode']} |")
print(f"{label} {samples/dt:.6g} {rays/dt:.6g}", file=open(f"{w}/{label}.rate", "w"))
PY
}
[ -f "$WORK/blocks-16/blocks.json" ] || "$BIN" partition -q --scene "$SCENE" --blocks 16 --out "$WORK/blocks-16" > /dev/null
"$BIN" render -q --scene "$SCENE" --blocks-dir "$WORK/blocks-16" --resolution 8x8 --spp 1 --out "$WORK/probe.exr"
SCENE_BYTES=$(/usr/bin/python3 -c "import json;print(json.load(open('$WORK/probe.metrics.json'))['memory']['scene_block_bytes'])")
echo "scene: $TRIS triangles, $((SCENE_BYTES / 1048576)) MiB of blocks in RAM; ${RES}x${RES}, spp $SPP vs $SPP4, max depth $DEPTH, $(nproc) threads"
echo "| run | blocks | budget | wall ($SPP4 spp) | rays/s | samples/s | rays/sample | loads | read | disk busy | I/O |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
run in-core-1 1 ""
run in-core-16 16 ""
run budget-25 16 "$((SCENE_BYTES / 4))"
run budget-10 32 "$((SCENE_BYTES / 10))"
# Embree's tutorial: same PLY, resolution, spp, path length; timestamps from --verbose.
emb() {
  local s="$1" t0 t1
  t0=$(date +%s.%N)
  pathtracer -i "$PLY" --vp "$PX" "$PY" "$PZ" --vi "$LX" "$LY" "$LZ" --vu "$UX" "$UY" "$UZ" --fov "$FOV" --size "$RES" "$RES" --spp "$s" --max-path-length "$DEPTH" --threads "$(nproc)" -o "$WORK/embree-$s.ppm" > /dev/null 2>&1
  t1=$(date +%s.%N)
  /usr/bin/python3 -c "print($t1 - $t0)"
}
E1=$(emb "$SPP"); E2=$(emb "$SPP4")
/usr/bin/python3 - "$WORK" "$E1" "$E2" "$RES" "$SPP" "$SPP4" <<'PY'
import sys
w, e1, e2, res, a, b = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]), int(sys.argv[6])
samples = res * res * (b - a)
emb = samples / (e2 - e1)
ours = {l.split()[0]: (float(l.split()[1]), float(l.split()[2])) for l in (open(f"{w}/{n}.rate").read() for n in ("in-core-1", "in-core-16", "budget-25", "budget-10"))}
print(f"\nEmbree pathtracer tutorial: {e2:.2f} s at {b} spp, {emb/1e3:.1f} k samples/s (per-sample, load and build excluded)")
base = ours["in-core-1"][0]
for k, (sps, rps) in ours.items():
    print(f"  {k}: {sps/emb:.2f}x Embree's samples/s, {sps/base:.2f}x our in-core (1 block)")
PY
