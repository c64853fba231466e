#!/usr/bin/env bash
# Whole-render benchmark of issue 7: CPU threads alone against CPU threads + the Vulkan GPU,
# in core and out of core (25 % RAM budget), on a generated museum-like scene of TRIANGLES
# triangles. Same scene, partition, resolution, spp and seed in every run: the images must
# match (compared through the PNG previews' checksums; the tests compare film sums bit for
# bit). Meant for a machine with a real GPU (the `device` tool); on lavapipe it runs too.
# Usage: scripts/bench_render_gpu.sh [TRIANGLES=4000000] [RES=512] [SPP=16] [DEPTH=5] [GPU=auto]
# Env: RAYLINE_BIN (default build/apps/rayline), BENCH_DIR (default out/bench-render-gpu).
set -euo pipefail
cd "$(dirname "$0")/.."
TRIS="${1:-4000000}"; RES="${2:-512}"; SPP="${3:-16}"; DEPTH="${4:-5}"; GPU="${5:-auto}"
BIN="${RAYLINE_BIN:-build/apps/rayline}"
[ -x "$BIN" ] || { echo "build first: scripts/setup.sh" >&2; exit 2; }
WORK="${BENCH_DIR:-out/bench-render-gpu}"
mkdir -p "$WORK"
PLY="$WORK/museum-$TRIS.ply"; SCENE="$WORK/museum-$TRIS.json"
[ -f "$PLY" ] || "$BIN" generate museum-like --triangles "$TRIS" --out "$PLY" > /dev/null
[ -f "$WORK/blocks-16/blocks.json" ] || "$BIN" partition -q --scene "$SCENE" --blocks 16 --out "$WORK/blocks-16" > /dev/null
"$BIN" render -q --gpu none --scene "$SCENE" --blocks-dir "$WORK/blocks-16" --resolution 8x8 --spp 1 --bvh-quality low --out "$WORK/probe.exr"
SCENE_BYTES=$(python3 -c "import json;print(json.load(open('$WORK/probe.metrics.json'))['memory']['scene_block_bytes'])")
echo "scene: $TRIS triangles in 16 blocks, $((SCENE_BYTES / 1048576)) MiB in RAM; ${RES}x${RES}, $SPP spp, max depth $DEPTH, $(nproc) hw threads"
"$BIN" devices --gpu "$GPU" | sed -n '1,/^Workstation/p' | sed '$d'
echo "| run | budget | GPU | wall | rays/s | samples/s | GPU rays | GPU jobs | GPU kernel s | block uploads | loads | image md5 |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
run() {  # label gpu budget
  local label="$1" gpu="$2" budget="$3" extra=()
  [ -n "$budget" ] && extra=(--memory-budget "$budget")
  "$BIN" render -q --gpu "$gpu" --scene "$SCENE" --blocks-dir "$WORK/blocks-16" --resolution "${RES}x${RES}" \
    --spp "$SPP" --max-depth "$DEPTH" "${extra[@]}" --out "$WORK/$label.exr"
  python3 - "$WORK/$label.metrics.json" "$label" "$(md5sum < "$WORK/$label.png" | cut -c1-8)" <<'PY'
import json, sys
m = json.load(open(sys.argv[1])); g = m["gpu"]; b = m["memory"]["budget_bytes"]
print(f"| {sys.argv[2]} | {b/2**20:.0f} MiB | {g['device'] or 'none'} | {m['seconds']:.2f} s | {m['rays_per_second']/1e6:.2f} M | "
      f"{m['samples_per_second']/1e3:.1f} k | {g['rays']/max(1,m['rays']['cell_visits'])*100:.0f} % | {g['jobs']} | "
      f"{g['kernel_seconds']:.2f} | {g['block_uploads']} | {m['io']['loads']} | {sys.argv[3]} |" if b else
      f"| {sys.argv[2]} | in core | {g['device'] or 'none'} | {m['seconds']:.2f} s | {m['rays_per_second']/1e6:.2f} M | "
      f"{m['samples_per_second']/1e3:.1f} k | {g['rays']/max(1,m['rays']['cell_visits'])*100:.0f} % | {g['jobs']} | "
      f"{g['kernel_seconds']:.2f} | {g['block_uploads']} | {m['io']['loads']} | {sys.argv[3]} |")
PY
}
run cpu-in-core none ""
run gpu-in-core "$GPU" ""
run cpu-budget-25 none "$((SCENE_BYTES / 4))"
run gpu-budget-25 "$GPU" "$((SCENE_BYTES / 4))"
