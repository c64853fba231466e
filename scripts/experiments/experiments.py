#!/usr/bin/python3
"""The paper's experiments (Son & Yoon 2017, Sec. 6) and further sweeps, as real
`rayline simulate` runs. One sub-command per notebook:

  scaling     Fig. 8: peak rays/s of gmb, budge, loadanyonce on A .. 4A+B+C+D+R, both scenes (cold)
  peak        Fig. 8 warm: each method's peak over clients (--clients auto), rays shot/s, compute bound
              (gmb, budge, loadanyonce and Rayline's policy)
  ablation    Rayline's policy with each rule off in turn, 8 warm nodes, both scenes
  central     Fig. 9 (cold): only node D holds the scene; rays shot over time, slave-to-slave share
  workstation one multi-GPU workstation (platforms/workstation-4gpu.json)
  horizon     horizon k 0.2..10 s, prediction depth 0..3, scheduling-overhead share
  accuracy    fidelity levels: simulator wall time vs throughput error; scheduler cost vs k
  stability   tiny k, memory below the working set, 10x slower LAN, fast GPU + slow CPUs, many clients
  scale       clusters of 8 to 128 type-A nodes in racks: simulator wall time, SimGrid and scheduler shares, RSS
  validation  real renders against their simulated twins (validation.py; docs/validation.md)

  experiments.py NAME [--mode full|reduced] [--out DIR]

--mode reduced (or RAYLINE_EXPERIMENTS=reduced) is the CI setting: fewer points, short
simulated durations. Results: DIR/NAME.csv (one row per run, columns in rayline_exp.FIELDS)
plus NAME-*.csv extras; raw run folders under DIR/runs/NAME/ (metrics.json, jobs.csv, ...).
Default DIR: notebooks/results (full) or out/experiments-reduced (reduced)."""
import argparse
import csv
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rayline_exp as rx  # noqa: E402
import validation as val  # noqa: E402

SCHEDULERS = ["gmb", "budge", "loadanyonce"]
SCALING = ["paper-A", "paper-2A", "paper-3A", "paper-4A", "paper-4A+B", "paper-4A+B+C", "paper-4A+B+C+D", "paper-cluster"]
LABEL = {"paper-A": "A", "paper-2A": "2A", "paper-3A": "3A", "paper-4A": "4A", "paper-4A+B": "+B",
         "paper-4A+B+C": "+C", "paper-4A+B+C+D": "+D", "paper-cluster": "+R"}


class Ctx:
    def __init__(self, name, reduced, out):
        self.name, self.reduced, self.out = name, reduced, out
        self.runs = os.path.join(out, "runs", name)
        self.variants = os.path.join(out, "platforms")
        self.rows = []
        self.dur = "8s" if reduced else "20s"
        self.timeout = 90 if reduced else 300
        # RAYLINE_RERUN_SCHEDULERS=rayline,...: run only those methods again; the others'
        # rows are taken from the existing DIR/NAME.csv (same run folder) when it has them.
        self.rerun = [x for x in os.environ.get("RAYLINE_RERUN_SCHEDULERS", "").split(",") if x]
        self._kept = None

    def kept_rows(self):
        if self._kept is None:
            path = os.path.join(self.out, self.name + ".csv")
            self._kept = []
            if os.path.exists(path):
                with open(path, newline="") as f:
                    self._kept = list(csv.DictReader(f))
        return self._kept

    def run(self, tag, platform, scene, scheduler, **kw):
        if self.rerun and scheduler not in self.rerun:
            folder = os.path.join(self.runs, tag)
            for r in self.kept_rows():
                if os.path.normpath(r.get("out_dir", "")) == os.path.normpath(folder):
                    self.rows.append(r)
                    return r
        kw.setdefault("duration", self.dur)
        kw.setdefault("timeout", self.timeout)
        row = rx.simulate(os.path.join(self.runs, tag), platform, scene, scheduler, experiment=self.name, **kw)
        rx.log(row)
        self.rows.append(row)
        return row

    def save(self):
        if self.name == "validation":  # writes its own tables (validation.py)
            return
        rx.write_csv(os.path.join(self.out, self.name + ".csv"), self.rows)
        print(f"wrote {rx.shown(os.path.join(self.out, self.name + '.csv'))} ({len(self.rows)} runs)")


def scaling(c):
    """Fig. 8, plus Rayline's completion-aware GMB (gmb-ca) as a fourth series, plus the
    investigation runs: the same schedulers with the CPU threads removed (GPUs only)."""
    plats = ["paper-A", "paper-4A", "paper-cluster"] if c.reduced else SCALING
    clients = [4] if c.reduced else [2, 8]
    scheds = SCHEDULERS if c.reduced else SCHEDULERS + ["gmb-ca"]
    dur = c.dur if c.reduced else "20s"
    for scene in ["boeing", "museum"]:
        for p in plats:
            for s in scheds:
                for n in clients:
                    c.run(f"{scene}-{p}-{s}-c{n}", p, scene, s, clients=n, label=LABEL[p], duration=dur)
    for p in (["paper-A"] if c.reduced else ["paper-A", "paper-cluster"]):
        gp = rx.load_platform(p)
        for t in gp["node_types"].values():
            t["compute"] = [x for x in t["compute"] if x["kind"] != "cpu"]
        plat = rx.save_platform(gp, c.variants, p + "-gpu-only")
        for s in scheds:
            c.run(f"museum-{p}-gpu-only-{s}", plat, "museum", s, clients=8, label=LABEL[p] + " GPUs only", duration=dur)
    # How steady is "steady"? One long run per scheduler (Boeing, 8 nodes, 8 clients).
    series = []
    for s in SCHEDULERS:
        r = c.run(f"long-boeing-paper-cluster-{s}", "paper-cluster", "boeing", s, clients=8, label="long run",
                  duration="30s" if c.reduced else "120s")
        mp = os.path.join(r["out_dir"], "metrics.json")
        if os.path.exists(mp):
            for t, v in enumerate(json.load(open(mp)).get("rays_per_second_series", [])):
                series.append({"scheduler": s, "t_s": t + 1, "rays_per_second": v})
    _write(os.path.join(c.out, "scaling-long-series.csv"), series)


def peak(c):
    """Fig. 8 the way the paper measured it: warm start (docs/simulator.md), clients doubled
    until throughput stops rising (`--clients auto`), rays shot per second, beside the
    compute bound of each platform and profile (path_trace.bound)."""
    # Reduced (CI): two small node sets, two client counts, 4 s runs: the whole chain in
    # about a minute. Full: every node set, the automatic sweep, 12 s runs.
    plats = ["paper-A", "paper-2A"] if c.reduced else SCALING
    # RAYLINE_PEAK_PLATFORMS=paper-A,paper-cluster limits a run to those platforms; a sweep
    # whose folder holds sweep.done (a finished earlier run) is read, not run again.
    only = [x for x in os.environ.get("RAYLINE_PEAK_PLATFORMS", "").split(",") if x]
    # RAYLINE_RERUN_SCHEDULERS=rayline sweeps only those methods (and the free-I/O runs are
    # skipped); the other methods' rows are kept from the existing DIR/peak.csv.
    methods = c.rerun
    if methods:
        c.rows.extend(r for r in c.kept_rows() if r["scheduler"] not in methods)
    dur = "4s" if c.reduced else "12s"
    for scene in ["museum", "boeing"]:
        # Boeing's sweeps are capped at 256 clients: past that a point costs minutes of wall
        # time (GMB's plan grows with the queued jobs) and its frames still do not finish.
        sweep = "1,2" if c.reduced else ("auto:256" if scene == "boeing" else "auto")
        for p in plats:
            for s in SCHEDULERS + ["rayline"]:  # the paper's three, then Rayline's policy
                if methods and s not in methods:
                    continue
                folder = os.path.join(c.runs, f"{scene}-{p}-{s}")
                done = os.path.join(folder, "sweep.done")
                if os.path.exists(done):
                    rows = rx.read_peak(folder, p, scene, s, duration=dur, experiment=c.name, label=LABEL[p])
                elif only and p not in only:
                    continue
                else:
                    rows = rx.simulate_peak(folder, p, scene, s, duration=dur, timeout=c.timeout * 12, clients=sweep,
                                            experiment=c.name, label=LABEL[p])
                    if any(r["status"] == "ok" for r in rows):
                        open(done, "w").close()
                for r in rows:
                    rx.log(r)
                c.rows.extend(rows)
    # The bound checked against runs: the 8 nodes (reduced: one node) with I/O made free
    # (64 GiB memories, 1000 GB/s channels and LAN links), warm: only compute limits them.
    if methods:
        return
    base = "paper-A" if c.reduced else "paper-cluster"
    fp = rx.load_platform(base)
    for t in fp["node_types"].values():
        for m in t["memory"]:
            if m["kind"] != "disk":
                m["capacity"] = "64GiB"
        for ch in t["channels"]:
            ch.update(bandwidth="1000GB/s", latency="1us")
    for net in fp.get("networks", []):
        net["latency"] = "1us"
        for mem in net["members"]:
            mem["bandwidth"] = "1000GB/s"
    plat = rx.save_platform(fp, c.variants, base + "-free-io")
    # The museum only: on Boeing, GMB with the load it needs (64 clients) runs at under
    # 1/25 of real time, and Budge's AdditiveCompose finds no room on the client's RAM once
    # the warm start filled it with the whole scene (a stall the run reports).
    for scene, n in [("museum", 8)]:
        for s in SCHEDULERS:
            c.run(f"{scene}-free-io-{s}", plat, scene, s, clients=2 if c.reduced else n,
                  label=LABEL[base] + " free I/O", duration=dur, extra=["--start", "warm", "--no-timeline"])


RAYLINE_RULES = ["ownership", "image-split", "completion", "batching", "no-waiting", "job-size", "room"]  # docs/rayline-policy.md
RAYLINE_RULES_ON = ["generation", "hold"]  # off by default (rule 8; rule 4's hold of every small ray job)


def ablation(c):
    """Rayline's policy with each rule switched off in turn (`--rayline-off RULE`), and with
    each rule that is off by default switched on (`--rayline-on generation`, `hold`), on the 8 warm nodes,
    each variant at its best of a short client sweep around the full policy's peak (museum
    16-64 clients, Boeing 64-256), 12 s as `peak` measures Fig. 8. Reduced: one node, 1 and
    2 clients, 4 s."""
    plat = "paper-A" if c.reduced else "paper-cluster"
    dur = "4s" if c.reduced else "12s"
    for scene, sweep in [("museum", "1,2" if c.reduced else "16,32,64"), ("boeing", "1,2" if c.reduced else "64,128,256")]:
        for rule in [""] + RAYLINE_RULES + ["+" + r for r in RAYLINE_RULES_ON]:
            on = rule.startswith("+")
            folder = os.path.join(c.runs, f"{scene}-{plat}-{('with-' + rule[1:]) if on else (rule or 'every-rule')}")
            done = os.path.join(folder, "sweep.done")
            label = f"with {rule[1:]}" if on else f"without {rule}" if rule else "every rule"
            extra = ["--rayline-on", rule[1:]] if on else ["--rayline-off", rule] if rule else []
            if os.path.exists(done):
                rows = rx.read_peak(folder, plat, scene, "rayline", duration=dur, experiment=c.name, label=label)
            else:
                rows = rx.simulate_peak(folder, plat, scene, "rayline", duration=dur, timeout=c.timeout * 12,
                                        clients=sweep, extra=extra,
                                        experiment=c.name, label=label)
                if any(r["status"] == "ok" for r in rows):
                    open(done, "w").close()
            for r in rows:
                rx.log(r)
            c.rows.extend(rows)


def central(c):
    """Fig. 9, cold: only node D holds the Boeing scene (blocks start on D's disk only). Paper
    NICs (D on 100 Mb/s: one 210 MB block takes 17 s to leave D), the same with every NIC at
    1 Gb/s (Fig. 7's bandwidths are not in the text), and, as references, the usual full copy
    on every disk (cold) and each method's warm steady peak on the full copy at the same
    clients (12 s, as `peak` measures Fig. 8). 64 clients: every method's offered load at or
    above LoadAnyOnce's Fig. 8 peak count; GMB's (512) is unaffordable cold for 120 s."""
    base = rx.load_platform("paper-cluster")
    central = rx.save_platform(rx.central_database(base, "D"), c.variants, "paper-cluster-central-D")
    fast = rx.central_database(base, "D")
    for m in fast["networks"][0]["members"]:
        m["bandwidth"] = "1Gb/s"
    central_1g = rx.save_platform(fast, c.variants, "paper-cluster-central-D-1g")
    dur, clients = ("20s", 8) if c.reduced else ("120s", 64)
    windows = [w for w in (10, 30, 60, 120) if w <= rx._seconds(dur)]
    settings = [(central, "central database on D"), (central_1g, "central database on D, 1 Gb/s NICs"),
                ("paper-cluster", "full copy on every disk")]
    for plat, label in settings[:2] if c.reduced else settings:
        for s in SCHEDULERS + ["rayline"]:
            row = c.run(f"{os.path.basename(plat).removesuffix('.json')}-{s}-c{clients}", plat, "boeing", s,
                        clients=clients, duration=dur, extra=["--start", "cold", "--warmup", "5s", "--no-timeline"],
                        label=label)
            for w in windows:
                row.update({f"{k}_{w}s": v for k, v in _central_metrics(row["out_dir"], "D", float(w)).items()})
    # The peak each method is measured against: warm, full copy, same clients, 12 s (Fig. 8's sense).
    for s in SCHEDULERS + ["rayline"]:
        c.run(f"warm-paper-cluster-{s}-c{clients}", "paper-cluster", "boeing", s, clients=clients,
              duration="4s" if c.reduced else "12s", extra=["--start", "warm", "--no-timeline"],
              label="full copy, warm: reference peak")
    # extras: rays shot (and block visits) per simulated second, and link shares
    series, links = [], []
    for r in c.rows:
        mp = os.path.join(r["out_dir"], "metrics.json")
        if os.path.exists(mp):
            m = json.load(open(mp))
            shot = m.get("path_trace", {}).get("rays_shot_per_second_series", [])
            visits = m.get("rays_per_second_series", [])
            for t in range(max(len(shot), len(visits))):
                series.append({"label": r["label"], "scheduler": r["scheduler"], "clients": r["clients"], "t_s": t + 1,
                               "rays_shot_per_second": shot[t] if t < len(shot) else "",
                               "block_visits_per_second": visits[t] if t < len(visits) else ""})
        if r["label"].startswith("full copy, warm"):
            continue
        links.append({k: r.get(k, "") for k in ["label", "scheduler", "clients"] + [
            f"{m}_{w}s" for w in windows for m in ("scene_lan_bytes", "slave_to_slave_bytes", "slave_to_slave_share",
                                                   "master_out_bytes")]})
    _write(os.path.join(c.out, "central-series.csv"), series)
    _write(os.path.join(c.out, "central-links.csv"), links)


def _central_metrics(run_dir, master, window):
    """SceneData bytes moved on LAN channels in [0, window] s (pro rata of each transfer's
    actual interval), and the share on slave-to-slave channels (neither end the master)."""
    path = os.path.join(run_dir, "jobs.csv")
    tot = s2s = mout = 0.0
    if os.path.exists(path):
        for r in csv.DictReader(open(path)):
            ch = r["device_or_channel"]
            if r["kind"] != "T" or not ch.startswith("lan:") or not r["block"].startswith("scene"):
                continue
            if not r["actual_start"]:
                continue  # never started
            # a transfer still running at the end of the run: its planned end stands in
            a, b = float(r["actual_start"]), float(r["actual_end"] or r["planned_end"])
            if a >= window or b <= a:
                continue
            part = float(r["bytes"]) * (min(b, window) - a) / (b - a)
            src, dst = ch[4:].split("->")
            tot += part
            if src != master and dst != master:
                s2s += part
            if src == master:
                mout += part
    return {"scene_lan_bytes": tot, "slave_to_slave_bytes": s2s, "master_out_bytes": mout,
            "slave_to_slave_share": s2s / tot if tot > 0 else 0.0}


def workstation(c):
    scenes = ["museum"] if c.reduced else ["boeing", "museum"]
    clients = [4] if c.reduced else [2, 8]
    for scene in scenes:
        for s in (SCHEDULERS if c.reduced else SCHEDULERS + ["gmb-ca"]):
            for n in clients:
                # Up to ~100 M rays/s: many more jobs per simulated second than the cluster
                # runs. 10 s, not 3 s: the first seconds are the cold start (scene blocks
                # still on their way to the GPUs), and the methods only separate after it.
                c.run(f"{scene}-{s}-c{n}", "workstation-4gpu", scene, s, clients=n, label="workstation-4gpu",
                      duration="1.5s" if c.reduced else "10s")


def horizon(c):
    plats = ["paper-A", "paper-cluster"]
    ks = ["0.2s", "2s", "10s"] if c.reduced else ["0.2s", "0.5s", "1s", "2s", "5s", "10s"]
    scenes = ["museum"] if c.reduced else ["boeing", "museum"]
    for scene in scenes:
        for p in plats:
            for k in ks:
                c.run(f"k-{scene}-{p}-{k}", p, scene, "gmb", clients=8, horizon=k, label="horizon")
            for d in ([0, 2] if c.reduced else [0, 1, 2, 3]):
                c.run(f"d-{scene}-{p}-{d}", p, scene, "gmb", clients=8, depth=d, label="depth")
            # the same without withdrawing failed predictions (their T-jobs still run)
            for d in ([2] if c.reduced else [1, 2, 3]):
                c.run(f"d-{scene}-{p}-{d}-kept", p, scene, "gmb", clients=8, depth=d, label="depth, failed kept",
                      extra=["--cancel-failed", "off"])


def accuracy(c):
    """Fidelity levels: the replay of a recorded run is the reference (today recorded from a
    Markov run of the simulator itself, docs/scene-profiles.md); analytic and Markov runs with
    other seeds are compared against it. Plus scheduler cost vs quality as k varies."""
    seeds = [2] if c.reduced else [2, 3, 4]
    scenes = ["museum"] if c.reduced else ["boeing", "museum"]
    plat = "paper-4A" if c.reduced else "paper-cluster"
    for scene in scenes:
        rec = c.run(f"fid-{scene}-record", plat, scene, "gmb", clients=4, seed=1, extra=["--record-replay"],
                    label="recording")
        log = os.path.join(rec["out_dir"], "replay.log")
        for seed in seeds:
            for fid in ["analytic", "markov", "replay"]:
                extra = ["--replay", log] if fid == "replay" else []
                c.run(f"fid-{scene}-{fid}-s{seed}", plat, scene, "gmb", clients=4, seed=seed, fidelity=fid,
                      extra=extra, label=f"seed {seed}")
    for k in (["0.5s", "5s"] if c.reduced else ["0.2s", "0.5s", "1s", "2s", "5s", "10s"]):
        for p in (["paper-A"] if c.reduced else ["paper-A", "paper-cluster"]):
            c.run(f"cost-{p}-{k}", p, "museum", "gmb", clients=8, horizon=k, label="cost-vs-k")


def stability(c):
    """Where methods fail: tiny k, memory below the working set, a 10x slower LAN, one fast
    GPU among slow CPUs, many clients; the paper's three and Rayline's policy (docs/rayline-policy.md),
    with each run's queue wait (p95, max, the oldest job still queued)."""
    red = c.reduced
    scheds = SCHEDULERS + ["rayline"]
    # tiny k: starvation (GMB and Rayline's policy, which plans k/4 ahead; the baselines have
    # no horizon: one run each as reference)
    for k in (["0.01s", "2s"] if red else ["0.005s", "0.02s", "0.05s", "0.2s", "2s"]):
        c.run(f"tinyk-{k}", "paper-A", "museum", "gmb", clients=8, horizon=k, label="tiny k")
        c.run(f"tinyk-rayline-{k}", "paper-A", "museum", "rayline", clients=8, horizon=k, label="tiny k")
    for s in ["budge", "loadanyonce"]:
        c.run(f"tinyk-{s}", "paper-A", "museum", s, clients=8, label="tiny k")
    # memory below the working set (museum 12.3 GiB; a node has 8 GiB RAM + 6 GiB GPU), with
    # the clients on a node of their own (as the paper ran them): their 8 framebuffers of
    # 512 MiB would otherwise take a quarter of the RAM at f = 0.25 and all of it at 0.05
    base = rx.load_platform("paper-A")
    for f in ([1.0, 0.05] if red else [1.0, 0.25, 0.1, 0.05, 0.025]):
        plat = rx.save_platform(rx.with_client_node(rx.scaled_memory(base, f)), c.variants, f"paper-A-mem{f:g}")
        for s in scheds:
            c.run(f"mem{f:g}-{s}", plat, "museum", s, clients=8, label=f"memory x{f:g}")
    # 10x slower LAN
    cl = rx.load_platform("paper-4A+B+C+D" if red else "paper-cluster")
    for f in [1.0, 0.1]:
        plat = rx.save_platform(rx.slower_lan(cl, f), c.variants, f"{cl['name']}-lan{f:g}")
        for s in scheds:
            c.run(f"lan{f:g}-{s}", plat, "museum", s, clients=8, label=f"LAN x{f:g}")
    # one very fast GPU among slow CPUs
    for gf, cf in ([(1, 1), (10, 0.1)] if red else [(1, 1), (4, 0.25), (10, 0.1), (30, 0.05)]):
        plat = rx.save_platform(rx.fast_gpu_slow_cpus(gf, cf), c.variants, f"paper-A-gpu{gf:g}-cpu{cf:g}")
        for s in scheds:
            c.run(f"gpu{gf:g}-{s}", plat, "museum", s, clients=8, label=f"GPU x{gf:g}, CPU x{cf:g}")
    # many clients: overload
    for n in ([1, 32] if red else [1, 4, 16, 64]):
        for s in scheds:
            c.run(f"clients{n}-{s}", "paper-4A", "museum", s, clients=n, label="clients")


def scale(c):
    """Clusters of type-A nodes in racks of 32 (platforms/scale-*.json's layout) against node
    count, for each method: the simulator's wall time, its share in SimGrid and in the
    scheduler, peak RSS and throughput. Boeing with one client per node, and the ray stream."""
    sizes = [4, 16] if c.reduced else [8, 16, 32, 64, 128]
    for n in sizes:
        plat = rx.save_platform(rx.scale_cluster(n), c.variants, f"scale-{n}")
        for s in SCHEDULERS:
            for scene, clients in (("boeing", n), ("ray-stream", 1)):
                c.run(f"{scene}-{s}-n{n}", plat, scene, s, clients=clients, label=str(n),
                      duration="2s" if c.reduced else "10s", extra=["--no-timeline"])
        # Past one plan cell (32 nodes), GMB plans cell by cell; the paper's flat GMB beside it.
        if n > 32 or c.reduced:
            for scene, clients in (("boeing", n), ("ray-stream", 1)):
                row = c.run(f"{scene}-gmb-flat-n{n}", plat, scene, "gmb", clients=clients, label=str(n),
                            duration="2s" if c.reduced else "10s", extra=["--no-timeline", "--plan-cell", "0"])
                row["scheduler"] = "gmb-flat"


def validation(c):
    val.run_grid(c.reduced, c.out)


def _write(path, rows):
    if not rows:
        open(path, "w").close()
        return
    keys = list(rows[0].keys())
    with open(path + ".tmp", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    os.replace(path + ".tmp", path)


EXPERIMENTS = {"scaling": scaling, "peak": peak, "ablation": ablation, "central": central, "workstation": workstation, "horizon": horizon,
               "accuracy": accuracy, "stability": stability, "scale": scale, "validation": validation}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("name", choices=list(EXPERIMENTS) + ["all"])
    ap.add_argument("--mode", choices=["full", "reduced"], default=None)
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    reduced = rx.is_reduced(a.mode)
    out = a.out or os.path.join(rx.REPO, "out/experiments-reduced" if reduced else "notebooks/results")
    print(f"rayline: {rx.shown(rx.rayline_bin_source())}  mode: {'reduced' if reduced else 'full'}  results: {rx.shown(out)}")
    for name in (list(EXPERIMENTS) if a.name == "all" else [a.name]):
        c = Ctx(name, reduced, out)
        EXPERIMENTS[name](c)
        c.save()


if __name__ == "__main__":
    main()
