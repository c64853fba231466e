#!/usr/bin/env bash
# Whole-render benchmark of CPU threads alone against CPU threads + the Vulkan GPU,
# in core and out of core (25 % RAM budget), on a generated museum-like scene of TRIANGLES
# triangles. Same scene, partition, resolution, spp and seed in every run: the images must
# match (each GPU run's EXR pixel data against the CPU run's at the same budget; the tests
# compare film sums bit for bit). "doubtful": the share of the GPU's rays its kernels
# flagged and handed to the CPU devices (render/vulkan/README.md). Meant for a machine with a
# real GPU (the `device` tool); on lavapipe it runs too.
# Usage: scripts/bench_render_gpu.sh [TRIANGLES=4000000] [RES=512] [SPP=16] [DEPTH=5] [GPU=auto]
# Env: RAYLINE_BIN (default build/apps/rayline), BENCH_DIR (default out/bench-render-gpu),
#      PLATFORM (default auto; a file from `rayline calibrate --gpu ...` plans with measured timing).
set -euo pipefail
cd "$(dirname "$0")/.."
TRIS="${1:-4000000}"; RES="${2:-512}"; SPP="${3:-16}"; DEPTH="${4:-5}"; GPU="${5:-auto}"
BIN="${RAYLINE_BIN:-build/apps/rayline}"
PLATFORM="${PLATFORM:-auto}"
[ -x "$BIN" ] || { echo "build first: scripts/setup.sh" >&2; exit 2; }
WORK="${BENCH_DIR:-out/bench-render-gpu}"
mkdir -p "$WORK"
PLY="$WORK/museum-$TRIS.ply"; SCENE="$WORK/museum-$TRIS.json"
[ -f "$PLY" ] || "$BIN" generate museum-like --triangles "$TRIS" --out "$PLY" > /dev/null
[ -f "$WORK/blocks-16/blocks.json" ] || "$BIN" partition -q --scene "$SCENE" --blocks 16 --out "$WORK/blocks-16" > /dev/null
"$BIN" render -q --gpu none --scene "$SCENE" --blocks-dir "$WORK/blocks-16" --resolution 8x8 --spp 1 --bvh-quality low --out "$WORK/probe.exr"
SCENE_BYTES=$(python3 -c "import json;print(json.load(open('$WORK/probe.metrics.json'))['memory']['scene_block_bytes'])")
echo "platform: $PLATFORM"
echo "scene: $TRIS triangles in 16 blocks, $((SCENE_BYTES / 1048576)) MiB in RAM; ${RES}x${RES}, $SPP spp, max depth $DEPTH, $(nproc) hw threads"
"$BIN" devices --gpu "$GPU" | sed -n '1,/^Workstation/p' | sed '$d'
echo "| run | budget | GPU | wall | rays/s | samples/s | GPU rays | GPU jobs | GPU kernel s | doubtful | block uploads | loads | unplanned | image vs CPU |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
# run LABEL GPU BUDGET [REFERENCE]: one render, one table row; the image is compared with
# REFERENCE's (the CPU-only run at the same budget) pixel by pixel: the EXR's pixel data
# (float, after its header, which holds the render time) and, if it differs, the PNG's.
run() {
  local label="$1" gpu="$2" budget="$3" ref="${4:-}" extra=()
  [ -n "$budget" ] && extra=(--memory-budget "$budget")
  "$BIN" render -q --gpu "$gpu" --platform "$PLATFORM" --scene "$SCENE" --blocks-dir "$WORK/blocks-16" --resolution "${RES}x${RES}" \
    --spp "$SPP" --max-depth "$DEPTH" "${extra[@]}" --out "$WORK/$label.exr"
  python3 - "$WORK/$label.metrics.json" "$label" "$WORK" "$ref" <<'PY'
import json, struct, sys, zlib
m = json.load(open(sys.argv[1])); g = m["gpu"]; b = m["memory"]["budget_bytes"]; work, ref = sys.argv[3], sys.argv[4]
def exr_pixels(path):  # the bytes after the header (attributes: name\0 type\0 int32 size, value; then \0)
    d = open(path, "rb").read(); i = 8
    while d[i] != 0:
        i = d.index(b"\0", d.index(b"\0", i) + 1) + 1; n = struct.unpack_from("<i", d, i)[0]; i += 4 + n
    return d[i + 1:]
def png_pixels(path):  # 8-bit RGB/RGBA, not interlaced
    d = open(path, "rb").read(); i = 8; idat = b""
    while i < len(d):
        n, t = struct.unpack_from(">I4s", d, i); c = d[i + 8:i + 8 + n]; i += 12 + n
        if t == b"IHDR": w, h, bits, ct = struct.unpack_from(">IIBB", c)
        if t == b"IDAT": idat += c
    bpp = 4 if ct == 6 else 3; raw = zlib.decompress(idat); stride = w * bpp; out = []; prev = bytearray(stride)
    for y in range(h):
        f = raw[y * (stride + 1)]; line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for x in range(stride):
            a = line[x - bpp] if x >= bpp else 0; up = prev[x]; c = prev[x - bpp] if x >= bpp else 0
            if f == 1: line[x] = (line[x] + a) & 255
            elif f == 2: line[x] = (line[x] + up) & 255
            elif f == 3: line[x] = (line[x] + (a + up) // 2) & 255
            elif f == 4:
                p = a + up - c; pa, pb, pc = abs(p - a), abs(p - up), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else up if pb <= pc else c)) & 255
        out += [bytes(line[k:k + bpp]) for k in range(0, stride, bpp)]; prev = line
    return out
if not ref: same = "–"
elif exr_pixels(f"{work}/{sys.argv[2]}.exr") == exr_pixels(f"{work}/{ref}.exr"): same = "identical"
else:
    a, r = png_pixels(f"{work}/{sys.argv[2]}.png"), png_pixels(f"{work}/{ref}.png")
    same = f"{sum(x != y for x, y in zip(a, r))} of {len(a)} pixels differ (PNG)"
doubt = f"{g['doubtful_fraction']*100:.3f} %" if "doubtful_fraction" in g and g["rays"] else "–"
print(f"| {sys.argv[2]} | {f'{b/2**20:.0f} MiB' if b else 'in core'} | {g['device'] or 'none'} | {m['seconds']:.2f} s | "
      f"{m['rays_per_second']/1e6:.2f} M | {m['samples_per_second']/1e3:.1f} k | "
      f"{g['rays']/max(1,m['rays']['cell_visits'])*100:.0f} % | {g['jobs']} | {g['kernel_seconds']:.2f} | {doubt} | "
      f"{g['block_uploads']} | {m['io']['loads']} | {m['io']['unplanned_loads']} | {same} |")
PY
}
run cpu-in-core none ""
run gpu-in-core "$GPU" "" cpu-in-core
run cpu-budget-25 none "$((SCENE_BYTES / 4))B"
run gpu-budget-25 "$GPU" "$((SCENE_BYTES / 4))B" cpu-budget-25
