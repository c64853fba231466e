#!/usr/bin/env bash
# In-core tracing speed against Embree's own `pathtracer` tutorial (Debian embree-tools), with
# scene loading and BVH builds excluded on both sides in the same way: each side renders the
# same frame at SPP and at 2*SPP samples per pixel, and the difference of the two wall times
# is the time of SPP samples per pixel of steady tracing (loading, BVH build and output are
# in both runs and cancel). The runs alternate, REPS rounds; medians are printed.
#
# Same mesh, camera, resolution, path length and threads on both sides. With a mesh file
# (MESH=, below) the light and the surfaces match too. On the generated museum the lights
# are alike, not equal: Rayline uses the scene's overhead area light, materials and
# environment; the tutorial (which reads only the mesh) gets one directional light from
# above and an ambient light. Paths there differ in length and in shadow rays, so its
# ratios are indicative.
# Both samples per second and rays per second are compared: the tutorial counts no rays, so
# one untimed run at each spp counts its rtcIntersect1 and rtcOccluded1 calls through
# bench/embree_ray_counter.cpp (LD_PRELOAD), against Rayline's `rays.created` (every ray
# shot, traced to its end once); without that library only samples/s is printed.
#
# A mesh file instead of the generated museum: MESH=assets/bunny.obj (OBJ or ASCII PLY). Both
# sides then see the same light and surfaces: the tutorial one directional light from
# above (--directionallight 0 -1 0 with irradiance pi) and its default white material;
# Rayline a scene file written here, the mesh with albedo 1, no environment, and a small
# square light 1000 radii above it whose radiance gives the same irradiance, so its rays
# arrive as parallel as the tutorial's. The camera is Rayline's framing camera of a bare
# mesh (render/scene/scene.cpp, frame_bounds), computed here for both.
#
# Usage: scripts/bench_embree.sh [TRIANGLES=1000000] [RES=512] [SPP=16] [DEPTH=5] [REPS=3]
# COPIES=N with an ASCII PLY MESH: N copies of it in rows of 4, written once as a binary PLY
# (COPIES=12 with the dragon: 10.5 M triangles, the large scene with the same light).
# Environment: RAYLINE_BIN (another rayline binary), RAY_COUNTER (the counting library,
# default build/bench/libembree_ray_counter.so), BENCH_DIR (default out/bench-embree),
# THREADS (default: all hardware threads), MESH (a mesh file; TRIANGLES is then ignored),
# RAYLINE_ARGS (more `rayline render` flags, e.g. "--camera-jobs off"), RAYLINE_B_ARGS (a
# second Rayline configuration timed in the same rounds, e.g. "--camera-jobs off
# --continue-in-cell off"; its ratio to the first is printed too).
set -euo pipefail
if [[ "${1:-}" == "--help" || "${1:-}" == "-h" ]]; then sed -n '2,35p' "$0" | sed 's/^# \{0,1\}//'; exit 0; fi
cd "$(dirname "$0")/.."
TRIS="${1:-1000000}"; RES="${2:-512}"; SPP="${3:-16}"; DEPTH="${4:-5}"; REPS="${5:-3}"
BIN="${RAYLINE_BIN:-build/apps/rayline}"
[ -x "$BIN" ] || { echo "build first: scripts/setup.sh" >&2; exit 2; }
command -v pathtracer > /dev/null || { echo "Embree's pathtracer tutorial is missing: apt-get install embree-tools" >&2; exit 2; }
THREADS="${THREADS:-$(nproc)}"
WORK="${BENCH_DIR:-out/bench-embree}"
mkdir -p "$WORK"
if [ -n "${MESH:-}" ]; then
  [ -f "$MESH" ] || { echo "MESH=$MESH: no such file" >&2; exit 2; }
  COPIES="${COPIES:-1}"
  [[ "$COPIES" =~ ^[1-9][0-9]*$ ]] || { echo "COPIES=$COPIES: a positive whole number" >&2; exit 2; }
  if [ "$COPIES" -gt 1 ]; then  # a large scene: copies of the mesh in rows of 4 (binary PLY)
    case "$MESH" in *.ply|*.PLY) ;; *) echo "COPIES needs an ASCII PLY mesh, not $MESH" >&2; exit 2 ;; esac
    GEN="$WORK/$(basename "${MESH%.*}")-x$COPIES.ply"
    [ -f "$GEN" ] || /usr/bin/python3 - "$MESH" "$COPIES" "$GEN" <<'PY'
import sys
import numpy as np
src, copies, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
with open(src) as f:
    nv = nf = 0
    for l in f:
        if l.startswith('format') and 'ascii' not in l: sys.exit('COPIES: only an ASCII PLY source')
        if l.startswith('element vertex'): nv = int(l.split()[2])
        if l.startswith('element face'): nf = int(l.split()[2])
        if l.strip() == 'end_header': break
    v = np.loadtxt(f, max_rows=nv, dtype=np.float32, usecols=(0, 1, 2), ndmin=2)
    fc = np.loadtxt(f, max_rows=nf, dtype=np.int64, ndmin=2)
if fc.shape[1] != 4 or (fc[:, 0] != 3).any(): sys.exit('COPIES: only triangles')
ext = v.max(0) - v.min(0)
V = np.concatenate([v + np.array([k % 4 * ext[0] * 1.1, 0, k // 4 * ext[2] * 1.3], np.float32) for k in range(copies)])
F = np.zeros(nf * copies, dtype=[('n', 'u1'), ('i', '<i4', 3)])
F['n'] = 3
F['i'] = np.concatenate([fc[:, 1:4] + k * nv for k in range(copies)])
with open(out + '.tmp', 'wb') as o:
    o.write(f'ply\nformat binary_little_endian 1.0\nelement vertex {len(V)}\nproperty float x\nproperty float y\n'
            f'property float z\nelement face {len(F)}\nproperty list uchar int vertex_indices\nend_header\n'.encode())
    o.write(V.astype('<f4').tobytes())
    o.write(F.tobytes())
import os
os.replace(out + '.tmp', out)
PY
    MESH="$GEN"
  fi
  PLY="$MESH"; TRIS="$(basename "$MESH")"; SCENE="$WORK/matched-$TRIS.json"
  LIGHT=(--directionallight 0 -1 0 3.14159 3.14159 3.14159)
  # The framing camera of a bare mesh (render/scene/scene.cpp, frame_bounds), and the scene.
  CAM="$(/usr/bin/python3 -c "
import math, sys
f = open('$MESH', 'rb'); lo = [math.inf] * 3; hi = [-math.inf] * 3
def add(v):
    for k in range(3): lo[k] = min(lo[k], v[k]); hi[k] = max(hi[k], v[k])
if '$MESH'.lower().endswith('.obj'):
    for l in f:
        if l.startswith(b'v '): add(list(map(float, l.split()[1:4])))
else:  # ASCII PLY, or the binary little-endian copies written above (x, y, z floats first)
    n = 0; binary = False
    for l in f:
        if l.startswith(b'format'):
            if l.split()[1] not in (b'ascii', b'binary_little_endian'): sys.exit('MESH: ASCII or little-endian PLY')
            binary = l.split()[1] == b'binary_little_endian'
        if l.startswith(b'element vertex'): n = int(l.split()[2])
        if l.strip() == b'end_header': break
    if binary:
        import numpy as np
        v = np.frombuffer(f.read(12 * n), dtype='<f4').reshape(n, 3)
        lo = [float(x) for x in v.min(0)]; hi = [float(x) for x in v.max(0)]
    else:
        for _ in range(n): add(list(map(float, f.readline().split()[:3])))
c = [(a + b) / 2 for a, b in zip(lo, hi)]
r = max(0.5 * math.dist(lo, hi), 1e-3); d = r / math.sin(math.radians(20)) * 1.05
u = [0.35, 0.45, 1.0]; n = math.hypot(*u)
pos = [c[k] + u[k] / n * d for k in range(3)]
# The light: a square of side w at height R above the centre, facing down (edge_u x edge_v
# points along -y); radiance L gives irradiance L * w^2 / R^2 = pi at normal incidence.
R = 1000 * r; w = 10 * r; L = math.pi * R * R / (w * w)
import json
json.dump({'version': 1, 'materials': {'white': {'albedo': [1, 1, 1], 'emission': [0, 0, 0]}},
           'meshes': [{'name': 'mesh', 'file': '$(readlink -f "$MESH")', 'material': 'white'}],
           'lights': [{'type': 'area', 'name': 'sun', 'corner': [c[0] - w / 2, c[1] + R, c[2] - w / 2],
                       'edge_u': [w, 0, 0], 'edge_v': [0, 0, w], 'emission': [L, L, L]},
                      {'type': 'environment', 'radiance': [0, 0, 0]}],
           'cameras': {'main': {'position': pos, 'look_at': c, 'up': [0, 1, 0], 'fov_deg': 40}}},
          open('$SCENE', 'w'), indent=1)
print(*pos, *c, 0, 1, 0, 40)")" || exit 2  # a mesh it cannot read (its message above)
  read -r PX PY PZ LX LY LZ UX UY UZ FOV <<< "$CAM"
  BLOCKS="$WORK/blocks-1-matched-$TRIS"
else
  PLY="$WORK/museum-$TRIS.ply"
  SCENE="$WORK/museum-$TRIS.json"
  LIGHT=(--directionallight 0 -1 0 8 8 7.5 --ambientlight 0.55 0.65 0.85)  # alike, not equal (above)
  [ -f "$PLY" ] || "$BIN" generate museum-like -q --triangles "$TRIS" --out "$PLY" > /dev/null
  read -r PX PY PZ LX LY LZ UX UY UZ FOV <<< "$(/usr/bin/python3 -c "
import json; c = next(iter(json.load(open('$SCENE'))['cameras'].values()))
print(*c['position'], *c['look_at'], *c['up'], c['fov_deg'])")"
  BLOCKS="$WORK/blocks-1-museum-$TRIS"
fi
[ -f "$BLOCKS/blocks.json" ] || "$BIN" partition -q --scene "$SCENE" --blocks 1 --out "$BLOCKS" > /dev/null

now() { date +%s.%N; }
ours() {  # spp [flags] -> wall seconds of one in-core render
  local t0; t0=$(now)
  "$BIN" render -q --scene "$SCENE" --blocks-dir "$BLOCKS" --resolution "${RES}x${RES}" --spp "$1" \
    --max-depth "$DEPTH" -j "$THREADS" ${2:-${RAYLINE_ARGS:-}} --out "$WORK/ours-$1.exr" > /dev/null
  /usr/bin/python3 -c "print($(now) - $t0)"
}
theirs() {  # spp -> wall seconds of one tutorial run
  local t0; t0=$(now)
  local counted=()  # COUNT_TO set: an untimed run that counts its rays into that file
  [ -z "${COUNT_TO:-}" ] || counted=(env RAYLINE_RAY_COUNT_FILE="$COUNT_TO" LD_PRELOAD="$(readlink -f "$COUNTER")")
  "${counted[@]}" pathtracer -i "$PLY" --vp "$PX" "$PY" "$PZ" --vi "$LX" "$LY" "$LZ" --vu "$UX" "$UY" "$UZ" --fov "$FOV" \
    --size "$RES" "$RES" --spp "$1" --max-path-length "$DEPTH" --threads "$THREADS" \
    "${LIGHT[@]}" -o "$WORK/embree-$1.ppm" > "$WORK/embree.log" 2>&1
  /usr/bin/python3 -c "print($(now) - $t0)"
}
COUNTER="${RAY_COUNTER:-build/bench/libembree_ray_counter.so}"
theirs_rays() {  # spp -> rays the tutorial traces (an untimed run)
  [ -f "$COUNTER" ] || { echo 0; return; }
  COUNT_TO="$WORK/embree-rays.txt" theirs "$1" > /dev/null
  cat "$WORK/embree-rays.txt"
}
ours_rays() {  # spp -> rays.created of the last timed run at that spp
  /usr/bin/python3 -c "import json; print(json.load(open('$WORK/ours-$1.metrics.json'))['rays']['created'])"
}
echo "scene: ${MESH:-$TRIS triangles}, ${RES}x${RES}, $SPP and $((2 * SPP)) spp, max depth $DEPTH, $THREADS threads, $REPS rounds"
rows=()
for i in $(seq 1 "$REPS"); do
  o1=$(ours "$SPP"); e1=$(theirs "$SPP"); o2=$(ours $((2 * SPP))); e2=$(theirs $((2 * SPP)))
  b1=0; b2=0
  if [ -n "${RAYLINE_B_ARGS:-}" ]; then b1=$(ours "$SPP" "$RAYLINE_B_ARGS"); b2=$(ours $((2 * SPP)) "$RAYLINE_B_ARGS"); fi
  rows+=("$o1 $o2 $e1 $e2 $b1 $b2")
  if [ "$i" = 1 ]; then
    r1=$(ours_rays "$SPP"); r2=$(ours_rays $((2 * SPP)))
    t1=$(theirs_rays "$SPP"); t2=$(theirs_rays $((2 * SPP)))
  fi
  printf 'round %d: rayline %.2f / %.2f s, tutorial %.2f / %.2f s' "$i" "$o1" "$o2" "$e1" "$e2"
  [ -z "${RAYLINE_B_ARGS:-}" ] || printf ', rayline B %.2f / %.2f s' "$b1" "$b2"
  echo
done
printf '%s\n' "${rows[@]}" | /usr/bin/python3 -c "
import statistics, sys
px = $RES * $RES * $SPP
our_rays, their_rays = $r2 - $r1, $t2 - $t1  # rays of SPP samples per pixel, each side
r = [tuple(map(float, l.split())) for l in sys.stdin if l.strip()]
ours = [px / (x[1] - x[0]) for x in r]
emb = [px / (x[3] - x[2]) for x in r]
ratio = [a / b for a, b in zip(ours, emb)]
print(f'steady samples/s (difference of {2 * $SPP} and {$SPP} spp): rayline {statistics.median(ours)/1e3:.1f} k, '
      f'tutorial {statistics.median(emb)/1e3:.1f} k; rayline / tutorial, median of rounds: {statistics.median(ratio):.2f}x '
      '(' + ', '.join(f'{x:.2f}' for x in ratio) + ')')
if their_rays > 0:
    ours_r = [our_rays / (x[1] - x[0]) for x in r]
    emb_r = [their_rays / (x[3] - x[2]) for x in r]
    ratio_r = [a / b for a, b in zip(ours_r, emb_r)]
    print(f'steady rays/s: rayline {statistics.median(ours_r)/1e6:.2f} M ({our_rays / px:.2f} rays per sample), '
          f'tutorial {statistics.median(emb_r)/1e6:.2f} M ({their_rays / px:.2f} per sample); rayline / tutorial, '
          f'median of rounds: {statistics.median(ratio_r):.2f}x (' + ', '.join(f'{x:.2f}' for x in ratio_r) + ')')
else:
    print('rays/s not compared: build the counting library (ninja -C build embree_ray_counter)')
if r[0][5] > 0:
    ab = [(x[5] - x[4]) / (x[1] - x[0]) for x in r]
    print(f'rayline / rayline B (${RAYLINE_B_ARGS:-}), median of rounds: {statistics.median(ab):.2f}x '
          '(' + ', '.join(f'{x:.2f}' for x in ab) + ')')
"
