"""The simulator against the real renderer (docs/validation.md): real `rayline render` runs
and their simulated twins (`rayline simulate --like`), point by point.

Grid: generated museum-like scenes of three sizes x memory budgets (in core, 50, 25, 10 %
of the scene's block bytes) x schedulers (gmb, budge, loadanyonce). Per scene and budget,
right before that budget's renders, `rayline calibrate` at the grid's resolution and spp
gives the platform they drive: with the low-quality BVH builder for the budgets, the medium
one in core (the renders ask for it: `render --bvh-quality auto` would take the low one in
core on the 10 M scene). The development VM drifts by 10-15 % within minutes; one
calibration per scene, made up to ten minutes before some of the renders it predicts, put
that drift into the prediction (docs/validation.md). Per point:
  * real: R unrecorded renders, alternated across the schedulers (the machine is shared:
    alternating spreads its noise over all of them); their median and spread
    ((max - min) / median);
  * recorded: one render with --record-twin (it keeps every ray's outcome);
  * twins: fidelity replay | markov x timing platform | recorded:
      - timing platform: the calibrated platform, compared with the real median (the
        prediction a user gets);
      - timing recorded: Eq. 1, Eq. 2 and the dispatch latency fitted to the recorded
        run itself, compared with that run (the workload model's error alone).
Metrics: makespan (the frame's wall time / the simulated frame), block loads, bytes
loaded, compute busy share, and the simulator's wall time.

  experiments.py validation [--mode full|reduced] [--out DIR]
It writes DIR/validation.csv (one row per point and twin variant) and DIR/validation-real.csv
(every real run). The reduced (CI) setting: one small scene, one budget, two schedulers."""
import csv
import json
import os
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rayline_exp as rx  # noqa: E402

RES, SPP, DEPTH, THREADS = "256x256", 8, 5, 2
FULL = {"scenes": [("museum-0.3M", 300_000, 16), ("museum-1M", 1_000_000, 16), ("museum-10M", 10_000_000, 64)],
        "budgets": [1.0, 0.5, 0.25, 0.10], "schedulers": ["gmb", "budge", "loadanyonce"], "repeats": 3}
REDUCED = {"scenes": [("museum-0.1M", 100_000, 8)], "budgets": [0.25], "schedulers": ["gmb", "budge"], "repeats": 2,
           "resolution": "96x96", "spp": 2}
TWINS = [("replay", "platform"), ("replay", "recorded"), ("markov", "platform"), ("markov", "recorded")]


def reuse(path):
    """RAYLINE_EXP_REUSE=1: a render whose outputs exist already (an earlier run of the same
    grid) is read, not run again; twins are always run."""
    return os.environ.get("RAYLINE_EXP_REUSE", "") not in ("", "0") and os.path.exists(path)


def run(cmd, timeout=1800):
    t0 = time.monotonic()
    p = subprocess.run([rx.rayline_bin()] + cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=timeout)
    if p.returncode != 0:
        sys.exit(rx.scrub(f"rayline {' '.join(cmd)} failed ({p.returncode}):\n{p.stderr[-3000:]}"))
    return time.monotonic() - t0


def real_metrics(path):
    m = json.load(open(path))
    busy = [(d["busy_s"] + d["setup_s"]) / max(1e-12, m["seconds"]) for d in m["devices"]]
    return {"makespan_s": m["seconds"], "loads": m["io"]["loads"], "bytes_loaded": m["io"]["bytes_read"],
            "busy": statistics.mean(busy), "jobs": m["jobs"]["created"],
            "dispatch_gap_s": m.get("dispatch_gap_s", {}).get("mean", "")}


def twin_metrics(path):
    m = json.load(open(path))
    t = m["twin"]
    busy = [(d["busy_s"] + d["setup_s"]) / max(1e-12, t["makespan_s"]) for d in m["devices"]]
    return {"makespan_s": t["makespan_s"], "loads": t["loads"], "bytes_loaded": t["bytes_loaded"],
            "busy": statistics.mean(busy), "jobs": t["jobs"], "sim_wall_s": m["simulator"]["wall_s"],
            "frame_done": t["frame_done"]}


def rel(sim, real):
    return (sim - real) / real if real else ""


def scene_files(out, name, triangles, blocks, log):
    """The scene, its partition, and the calibrated platform (made once, reused)."""
    d = os.path.join(out, "scenes", name)
    os.makedirs(d, exist_ok=True)
    mesh, scene, parts = os.path.join(d, "scene.ply"), os.path.join(d, "scene.json"), os.path.join(d, "blocks")
    if not os.path.exists(scene):
        run(["generate", "museum-like", "--triangles", str(triangles), "-o", mesh, "--scene-out", scene, "-q"])
    if not os.path.exists(os.path.join(parts, "blocks.json")):
        run(["partition", "--scene", scene, "-n", str(blocks), "-o", parts, "-q"])
    return scene, parts


def calibrate(out, name, scene, blocks, res, spp, quality, tag=""):
    """`rayline calibrate` with the BVH builder the renders use (low under a budget, medium in
    core, as the renders ask for; a load's time is mostly its build). `tag`: one file per
    budget, made again unless RAYLINE_EXP_REUSE keeps it."""
    cal = os.path.join(out, "scenes", name, f"calibrated-{quality}{tag}.json")
    if not reuse(cal) and (tag or not os.path.exists(cal)):
        run(["calibrate", "--scene", scene, "-n", str(blocks), "--resolution", res, "--spp", str(spp),
             "--threads", str(THREADS), "--budget-fraction", "0.25", "--bvh-quality", quality, "--out", cal, "-q"])
    return cal


def scene_bytes(out, name, scene, parts, cal):
    probe = os.path.join(out, "scenes", name, "probe.png")
    run(["render", "--scene", scene, "--blocks-dir", parts, "--platform", cal, "--resolution", "8x8", "--spp", "1",
         "--threads", str(THREADS), "--out", probe, "-q"])
    return json.load(open(probe.removesuffix(".png") + ".metrics.json"))["memory"]["scene_block_bytes"]


def run_grid(reduced, out):
    """The whole grid into `out` (validation.csv, validation-real.csv, runs/validation/)."""
    g = REDUCED if reduced else FULL
    res, spp = g.get("resolution", RES), g.get("spp", SPP)
    runs = os.path.join(out, "runs", "validation")
    os.makedirs(runs, exist_ok=True)
    rows, real_rows = [], []
    for name, triangles, blocks in g["scenes"]:
        scene, parts = scene_files(out, name, triangles, blocks, print)
        total = scene_bytes(out, name, scene, parts, calibrate(out, name, scene, blocks, res, spp, "low"))
        for budget in g["budgets"]:
            cal = calibrate(out, name, scene, blocks, res, spp, "medium" if budget >= 1 else "low",
                            f"-b{int(round(budget * 100))}")
            flags = ["--bvh-quality", "medium"] if budget >= 1 else ["--memory-budget", f"{int(total * budget)}B"]
            tag = f"{name}-b{int(round(budget * 100))}"
            base = ["render", "--scene", scene, "--blocks-dir", parts, "--platform", cal, "--resolution", res,
                    "--spp", str(spp), "--max-depth", str(DEPTH), "--threads", str(THREADS), "-q"] + flags
            real = {s: [] for s in g["schedulers"]}
            for rep in range(g["repeats"]):  # alternated: rep-major, schedulers inside
                for s in g["schedulers"]:
                    img = os.path.join(runs, f"{tag}-{s}-real{rep}.png")
                    if not reuse(img.removesuffix(".png") + ".metrics.json"):
                        run(base + ["--scheduler", s, "--out", img])
                    r = real_metrics(img.removesuffix(".png") + ".metrics.json")
                    real[s].append(r)
                    real_rows.append({"scene": name, "triangles": triangles, "budget": budget, "scheduler": s, "repeat": rep, **r})
            for s in g["schedulers"]:
                twin = os.path.join(runs, f"{tag}-{s}.twin.json")
                img = os.path.join(runs, f"{tag}-{s}-rec.png")
                if not reuse(twin):
                    run(base + ["--scheduler", s, "--out", img, "--record-twin", twin])
                rec = real_metrics(img.removesuffix(".png") + ".metrics.json")
                mk = [r["makespan_s"] for r in real[s]]
                med = {k: statistics.median(r[k] for r in real[s]) for k in ("makespan_s", "loads", "bytes_loaded", "busy")}
                spread = (max(mk) - min(mk)) / med["makespan_s"]
                for fid, timing in TWINS:
                    sim_dir = os.path.join(runs, f"{tag}-{s}-{fid}-{timing}")
                    run(["simulate", "--like", twin, "--fidelity", fid, "--timing", timing, "--no-timeline",
                         "--no-progress", "--out", sim_dir])
                    t = twin_metrics(os.path.join(sim_dir, "metrics.json"))
                    ref = med if timing == "platform" else rec  # what the twin predicts
                    row = {"scene": name, "triangles": triangles, "blocks": blocks, "budget": budget, "scheduler": s,
                           "fidelity": fid, "timing": timing, "real_makespan_s": med["makespan_s"],
                           "real_spread": spread, "real_loads": med["loads"], "real_bytes": med["bytes_loaded"],
                           "real_busy": med["busy"], "recorded_makespan_s": rec["makespan_s"],
                           "recorded_loads": rec["loads"], "sim_makespan_s": t["makespan_s"], "sim_loads": t["loads"],
                           "sim_bytes": t["bytes_loaded"], "sim_busy": t["busy"], "sim_wall_s": t["sim_wall_s"],
                           "frame_done": t["frame_done"],
                           "makespan_error": rel(t["makespan_s"], ref["makespan_s"]),
                           "loads_error": rel(t["loads"], ref["loads"]),
                           "bytes_error": rel(t["bytes_loaded"], ref["bytes_loaded"]),
                           "busy_error": t["busy"] - ref["busy"]}
                    rows.append(row)
                    print(f"  {tag} {s} {fid}/{timing}: makespan {t['makespan_s']:.3f} s vs {ref['makespan_s']:.3f} s "
                          f"({100 * row['makespan_error']:+.0f} %), loads {t['loads']} vs {ref['loads']} "
                          f"({100 * row['loads_error']:+.0f} %), real spread {100 * spread:.0f} %, sim {t['sim_wall_s']:.2f} s wall")
                    sys.stdout.flush()
    write(os.path.join(out, "validation.csv"), rows)
    write(os.path.join(out, "validation-real.csv"), real_rows)
    print(f"wrote {rx.shown(os.path.join(out, 'validation.csv'))} ({len(rows)} rows)")


def write(path, rows):
    tmp = path + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, path)
