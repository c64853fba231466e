#!/usr/bin/env bash
# Distributed render (render/mpi/README.md) on this machine: one frame of a generated museum
# rendered by one process, then by 1, 2 and 3 MPI ranks (`mpirun --oversubscribe`, THREADS
# compute threads and a BUDGET of RAM each), and each of those configurations simulated
# from the platform file `calibrate --distributed` writes for them (the twin recorded from the
# one-process render: `simulate --like`). Prints one markdown table row per run.
# Usage: scripts/bench_distributed.sh [TRIANGLES=300000] [RES=128] [SPP=4] [BUDGET=8MiB] [BLOCKS=16]
# Environment: THREADS (per rank, default 1), BENCH_DIR (default out/bench-distributed),
# SUMMARY_ONLY=1 (print the table of the runs already in BENCH_DIR).
set -euo pipefail
cd "$(dirname "$0")/.."
TRIS="${1:-300000}"; RES="${2:-128}"; SPP="${3:-4}"; BUDGET="${4:-8MiB}"; BLOCKS="${5:-16}"
THREADS="${THREADS:-1}"
BIN=build/apps/rayline
[ -x "$BIN" ] || { echo "build first: scripts/setup.sh" >&2; exit 2; }
command -v mpirun > /dev/null || { echo "mpirun missing: scripts/setup.sh installs openmpi-bin" >&2; exit 2; }
[ "$(id -u)" -eq 0 ] && export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
WORK="${BENCH_DIR:-out/bench-distributed}"
mkdir -p "$WORK"
SCENE="$WORK/museum-$TRIS.json"
[ -f "$SCENE" ] || "$BIN" generate museum-like --triangles "$TRIS" --out "$WORK/museum-$TRIS.ply" > /dev/null
[ -f "$WORK/blocks/blocks.json" ] || "$BIN" partition -q --scene "$SCENE" --blocks "$BLOCKS" --out "$WORK/blocks" > /dev/null
FRAME=(--scene "$SCENE" --blocks-dir "$WORK/blocks" --resolution "${RES}x${RES}" --spp "$SPP" --seed 3
       --threads "$THREADS" --memory-budget "$BUDGET")
if [ -z "${SUMMARY_ONLY:-}" ]; then  # SUMMARY_ONLY=1: the table of the runs already in BENCH_DIR
"$BIN" render -q "${FRAME[@]}" --out "$WORK/one.exr" --record-twin "$WORK/one.twin.json"
for n in 1 2 3; do
  mpirun -np "$n" --oversubscribe "$BIN" render -q --distributed "${FRAME[@]}" --out "$WORK/ranks$n.exr"
done
for n in 1 2 3; do
  mpirun -np "$n" --oversubscribe "$BIN" calibrate -q --distributed --threads "$THREADS" --scene "$SCENE" \
    --resolution "${RES}x${RES}" --spp "$SPP" \
    --out "$WORK/cluster$n.json" > "$WORK/calibrate$n.txt"
  "$BIN" simulate -q --like "$WORK/one.twin.json" --platform "$WORK/cluster$n.json" --memory-budget "$BUDGET" \
    --out "$WORK/sim$n" > /dev/null
done
fi
/usr/bin/python3 - "$WORK" <<'PY'
import json, sys, os
w = sys.argv[1]
def load(p): return json.load(open(os.path.join(w, p)))
one = load("one.metrics.json")
print(f"one process, {one['threads']} thread(s): {one['seconds']:.2f} s, {one['io']['loads']} loads")
print("| ranks | seconds | time vs one process | LAN measured (latency, bandwidth) | rank-to-rank T-jobs | messages, MB sent | E-jobs per rank | traced / seen by rank 0, s per rank | disk loads per rank | blocks via LAN | simulated (calibrated file) | sim − real |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|")
for n in (1, 2, 3):
    m = load(f"ranks{n}.metrics.json"); d = m["distributed"]; r = d["ranks"]; lan = d["lan"]; t = d["lan_transfers"]
    split = " / ".join("%.2f/%.2f" % (x["exec_traced_seconds"], x["exec_seen_seconds"]) for x in r)
    sim = ""
    if os.path.exists(os.path.join(w, f"sim{n}", "metrics.json")):
        s = load(f"sim{n}/metrics.json")["twin"]
        sim = f"{s['makespan_s']:.2f} s | {100 * (s['makespan_s'] - m['seconds']) / m['seconds']:+.0f} %"
    else:
        sim = "– | –"
    measured = f"{lan['latency_s'] * 1e6:.0f} µs, {lan['bandwidth_bytes_per_s'] / 1e9:.1f} GB/s" if n > 1 else "–"
    print(f"| {n} | {m['seconds']:.2f} | {m['seconds'] / one['seconds']:.2f}× | "
          f"{measured} | {t['count']} ({t['planned_bytes'] / 1e6:.0f} MB, {t['seconds']:.2f} s) | "
          f"{sum(x['messages_sent'] for x in r)}, {sum(x['bytes_sent'] for x in r) / 1e6:.0f} | "
          f"{' / '.join(str(x['execs']) for x in r)} | {split} | "
          f"{' / '.join(str(x['loads']) for x in r)} | "
          f"{sum(x['scene_blocks_in'] for x in r)} | {sim} |")
    assert m["rays"] == one["rays"], "the distributed render's rays differ from the one-process render's"
for n in (1, 2, 3):
    print(f"calibrate --distributed, {n} ranks:")
    for line in open(os.path.join(w, f"calibrate{n}.txt")):
        if line.startswith(("LAN", "the platform file's LAN")): print("   ", line.rstrip())
PY
