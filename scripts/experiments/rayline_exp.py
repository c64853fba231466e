#!/usr/bin/python3
"""Shared helpers of the experiment scripts (scripts/experiments/exp*.py): find the `rayline`
binary, run `rayline simulate` once per configuration (one process each: SimGrid's engine is
a process-wide singleton), read its metrics.json into one flat row, and write platform
variants (generated from the committed platforms/*.json, never hand-edited).

Every number a notebook shows comes from a row written here by a real `rayline` run. A run
that fails (non-zero exit), stalls (jobs no device can take) or exceeds its wall-clock limit
is kept as a row with `status` = failed / stalled / timeout, so a chart can mark it."""
import atexit
import copy
import csv
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
PLATFORMS = os.path.join(REPO, "platforms")


def shown(path):
    """A path as printed: relative to the repository when inside it (no machine's absolute
    paths in logs or executed notebooks)."""
    path = os.path.abspath(path)
    return os.path.relpath(path, REPO) if path.startswith(REPO + os.sep) else os.path.basename(path)


def scrub(text):
    """Log text with the repository's absolute prefix taken off its paths."""
    return text.replace(REPO + os.sep, "")


_BIN = {}


def rayline_bin_source():
    """RAYLINE_BIN, else build/apps/rayline, else any build*/apps/rayline of the checkout:
    the binary an experiment runs, chosen once per process."""
    if "source" not in _BIN:
        env = os.environ.get("RAYLINE_BIN")
        cands = [env] if env else [os.path.join(REPO, "build", "apps", "rayline")] + [
            os.path.join(REPO, d, "apps", "rayline") for d in sorted(os.listdir(REPO)) if d.startswith("build")]
        found = next((c for c in cands if os.access(c, os.X_OK)), None)
        if not found:
            sys.exit("rayline binary not found: build it (ninja -C build rayline) or set RAYLINE_BIN")
        _BIN["source"] = found
    return _BIN["source"]


def rayline_bin():
    """A private copy of rayline_bin_source(), made once per process: every run of an
    experiment uses the same binary even if the build tree is relinked meanwhile (a binary
    being relinked is briefly missing, and a fresh search would fall through to another
    build folder). The copy finds its data through the source tree, as the build's does."""
    if "copy" not in _BIN:
        folder = tempfile.mkdtemp(prefix="rayline-bin-")
        atexit.register(shutil.rmtree, folder, True)
        _BIN["copy"] = shutil.copy2(rayline_bin_source(), os.path.join(folder, "rayline"))
    return _BIN["copy"]


def is_reduced(argv_mode=None):
    """The reduced (CI) setting: --mode reduced, or RAYLINE_EXPERIMENTS=reduced."""
    if argv_mode:
        return argv_mode == "reduced"
    return os.environ.get("RAYLINE_EXPERIMENTS", "full") == "reduced"


FIELDS = ["experiment", "label", "platform", "scene", "scheduler", "clients", "horizon_s", "prediction_depth",
          "fidelity", "duration_s", "status", "exit_code", "steady_rays_per_second", "rays_per_second",
          "lan_utilisation_mean", "busy", "fetching", "true_idle", "scheduler_wall_s", "scheduler_share",
          "sim_wall_s", "run_wall_s", "prediction_accuracy", "prediction_ray_accuracy", "exec_prediction_error",
          "transfer_prediction_error", "e_jobs_done", "queued_at_end", "frames_delivered", "cpu_busy", "gpu_busy",
          "work_units_done", "ray_jobs", "ray_jobs_gpu", "rays_per_ray_job", "scene_fetch_bytes",
          "scene_bytes_per_ray", "withdrawn_t_jobs", "withdrawn_t_job_bytes", "scheduler_parameters", "out_dir",
          "start", "steady_rays_shot_per_second", "compute_bound_rays_shot_per_second", "share_of_compute_bound",
          "block_visits_per_ray_shot", "cpu_fetching", "gpu_fetching", "sim_speedup", "peak_rss_mb", "simgrid_s", "steady",
          "alive_growth_share", "queue_wait_p95_s", "queue_wait_max_s", "oldest_queued_s"]


def run_rayline(cmd, out_dir, timeout):
    """Runs one `rayline` command into a fresh out_dir; returns (status, exit code, wall s).
    Status: ok, stalled (a job no device can take), failed, or timeout; failures are logged."""
    shutil.rmtree(out_dir, ignore_errors=True)
    t0 = time.monotonic()
    status, rc = "ok", 0
    # As logged: the binary the copy was made from, not the private copy's path.
    shown_cmd = " ".join([rayline_bin_source() if c == _BIN.get("copy") else c for c in cmd])
    try:
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=timeout)
        rc = p.returncode
        if rc != 0:
            status = "stalled" if "could not be placed" in p.stderr else "failed"
            sys.stderr.write(scrub(f"[{status}] {shown_cmd}\n{p.stderr[-2000:]}\n"))
    except subprocess.TimeoutExpired:
        status, rc = "timeout", 124
        sys.stderr.write(scrub(f"[timeout after {timeout} s] {shown_cmd}\n"))
    return status, rc, time.monotonic() - t0


def simulate(out_dir, platform, scene, scheduler, clients=4, horizon="2s", depth=0, fidelity="markov",
             duration="30s", seed=1, timeout=300, extra=(), **labels):
    """One `rayline simulate` run; returns a row (dict of FIELDS) whatever happened."""
    cmd = [rayline_bin(), "simulate", "--platform", platform, "--workload", scene, "--scheduler", scheduler,
           "--clients", str(clients), "--horizon", str(horizon), "--prediction-depth", str(depth),
           "--fidelity", fidelity, "--duration", str(duration), "--seed", str(seed), "--no-progress",
           "--out", out_dir] + list(extra)
    # RAYLINE_EXP_REUSE=1: a run whose folder already holds a metrics.json (an earlier,
    # finished run of the same command) is read, not run again.
    reuse = (os.environ.get("RAYLINE_EXP_REUSE", "") not in ("", "0")
             and os.path.exists(os.path.join(out_dir, "metrics.json")))
    status, rc, wall = ("ok", 0, "") if reuse else run_rayline(cmd, out_dir, timeout)
    row = {k: "" for k in FIELDS}
    row.update(labels)
    row.update(platform=os.path.basename(platform).removesuffix(".json"), scene=scene, scheduler=scheduler,
               clients=clients, horizon_s=_seconds(horizon), prediction_depth=depth, fidelity=fidelity,
               duration_s=_seconds(duration), status=status, exit_code=rc,
               run_wall_s="" if reuse else round(wall, 3), out_dir=out_dir)
    return read_run(row, out_dir, outcome_from_metrics=reuse)


def simulate_peak(out_dir, platform, scene, scheduler, duration="12s", timeout=1800, extra=(), clients="auto", **labels):
    """The paper's peak (Sec. 6): one `rayline simulate --clients auto` sweep (clients
    doubled until two counts in a row gain no more than 2 %; or a fixed list such as
    "1,2"), warm start. Returns one row per client count."""
    cmd = [rayline_bin(), "simulate", "--platform", platform, "--workload", scene, "--scheduler", scheduler,
           "--clients", clients, "--start", "warm", "--duration", str(duration), "--no-progress", "--no-timeline",
           "--out", out_dir] + list(extra)
    status, rc, wall = run_rayline(cmd, out_dir, timeout)
    return read_peak(out_dir, platform, scene, scheduler, duration, status, rc, wall, **labels)


def read_peak(out_dir, platform, scene, scheduler, duration="12s", status="ok", rc=0, wall="", **labels):
    """The rows of a client sweep's folder (one per clients-N/ subfolder)."""
    rows = []
    found = os.listdir(out_dir) if os.path.isdir(out_dir) else []
    for n, d in sorted((int(d.split("-")[1]), d) for d in found if d.startswith("clients-")):
        row = {k: "" for k in FIELDS}
        row.update(labels)
        row.update(platform=os.path.basename(platform).removesuffix(".json"), scene=scene, scheduler=scheduler,
                   clients=n, duration_s=_seconds(duration), status=status, exit_code=rc,
                   run_wall_s=round(wall, 3) if wall != "" else "",
                   out_dir=os.path.join(out_dir, d))
        # Each point's own outcome (metrics.json "stalled"): a sweep fails as a whole when
        # one point stalls.
        rows.append(read_run(row, os.path.join(out_dir, d), outcome_from_metrics=True))
    return rows


def read_run(row, out_dir, outcome_from_metrics=False):
    """Fills a row from a run folder's metrics.json and jobs.csv (when they exist); with
    outcome_from_metrics, its status and exit code too (ok, or stalled: exit 1)."""
    mpath = os.path.join(out_dir, "metrics.json")
    if os.path.exists(mpath):  # a stalled run still writes its metrics
        m = json.load(open(mpath))
        if outcome_from_metrics:
            stalled = m.get("stalled", False)
            row.update(status="stalled" if stalled else "ok", exit_code=1 if stalled else 0)
        pt = m.get("path_trace", {})
        ds = m.get("device_summary", {})
        tot = {k: 0.0 for k in ("busy", "fetching", "true_idle")}
        n = 0
        for d in m.get("devices", []):
            n += 1
            span = max(1e-12, d["busy_s"] + d["setup_s"] + d["fetching_s"] + d["idle_s"])
            tot["busy"] += (d["busy_s"] + d["setup_s"]) / span
            tot["fetching"] += d["fetching_s"] / span
            tot["true_idle"] += d["idle_s"] / span
        pred = pt.get("prediction", {})
        row.update(
            steady_rays_per_second=pt.get("steady_rays_per_second", m.get("rays_per_second", 0.0)),
            rays_per_second=m.get("rays_per_second", 0.0),
            lan_utilisation_mean=m.get("lan_utilisation_mean", ""),
            busy=tot["busy"] / max(1, n), fetching=tot["fetching"] / max(1, n), true_idle=tot["true_idle"] / max(1, n),
            scheduler_wall_s=m["scheduler_cost"]["wall_s"],
            scheduler_share=m["scheduler_cost"]["share_of_simulated_time"],
            sim_wall_s=m["simulator"]["wall_s"],
            prediction_accuracy=pred.get("accuracy", ""), prediction_ray_accuracy=pred.get("ray_accuracy", ""),
            withdrawn_t_jobs=pred.get("withdrawn", {}).get("t_jobs", ""),
            withdrawn_t_job_bytes=pred.get("withdrawn", {}).get("t_job_bytes", ""),
            exec_prediction_error=m["prediction_error"]["exec_mean_rel"],
            transfer_prediction_error=m["prediction_error"]["transfer_mean_rel"],
            e_jobs_done=m["activities"]["e_jobs_done"], queued_at_end=m["activities"]["queued_at_end"],
            frames_delivered=pt.get("frames", {}).get("delivered", ""),
            cpu_busy=ds.get("cpu", {}).get("busy", ""), gpu_busy=ds.get("gpu", {}).get("busy", ""),
            work_units_done=m.get("work_units_done", 0),
            scheduler_parameters=m.get("scheduler_parameters", ""), start=m.get("start", ""),
            steady_rays_shot_per_second=pt.get("steady_rays_shot_per_second", ""),
            steady=pt.get("steady", {}).get("steady", ""),
            alive_growth_share=pt.get("steady", {}).get("alive_growth_share_of_shot", ""),
            compute_bound_rays_shot_per_second=pt.get("bound", {}).get("compute_rays_shot_per_second", ""),
            share_of_compute_bound=pt.get("bound", {}).get("share_of_compute_bound", ""),
            block_visits_per_ray_shot=(pt["steady_block_visits_per_second"] / pt["steady_rays_shot_per_second"]
                                       if pt.get("steady_rays_shot_per_second") else ""),
            cpu_fetching=ds.get("cpu", {}).get("fetching", ""), gpu_fetching=ds.get("gpu", {}).get("fetching", ""),
            sim_speedup=m["simulator"].get("speedup_vs_simulated", ""),
            peak_rss_mb=m["simulator"].get("peak_rss_mb", ""),
            simgrid_s=m["simulator"].get("simgrid_s", ""),
            queue_wait_p95_s=m.get("queue_wait_s", {}).get("p95", ""),
            queue_wait_max_s=m.get("queue_wait_s", {}).get("max", ""),
            oldest_queued_s=m.get("queue_wait_s", {}).get("oldest_queued_at_end", ""))
        row.update(job_diagnostics(os.path.join(out_dir, "jobs.csv"), float(m.get("work_units_done", 0))))
    return row


def job_diagnostics(path, rays):
    """From jobs.csv: finished ray jobs (RayIntersect + ShadowIntersect), how many ran on a
    GPU, rays per ray job (batch size), and SceneData bytes moved (every channel)."""
    out = {"ray_jobs": 0, "ray_jobs_gpu": 0, "rays_per_ray_job": "", "scene_fetch_bytes": 0.0, "scene_bytes_per_ray": ""}
    if not os.path.exists(path):
        return out
    with open(path) as f:
        for r in csv.DictReader(f):
            if r["state"] != "done":
                continue
            if r["kind"] == "E" and r["type"] in ("RayIntersect", "ShadowIntersect"):
                out["ray_jobs"] += 1
                if ".gpu" in r["device_or_channel"]:
                    out["ray_jobs_gpu"] += 1
            elif r["kind"] == "T" and r["block"].startswith("scene"):
                out["scene_fetch_bytes"] += float(r["bytes"])
    if out["ray_jobs"]:
        out["rays_per_ray_job"] = rays / out["ray_jobs"]
    if rays > 0:
        out["scene_bytes_per_ray"] = out["scene_fetch_bytes"] / rays
    return out


def _seconds(text):
    text = str(text)
    mm = re.fullmatch(r"([0-9.eE+-]+)(ms|s|min)?", text)
    if not mm:
        return text
    v = float(mm.group(1))
    return v / 1000 if mm.group(2) == "ms" else v * 60 if mm.group(2) == "min" else v


def write_csv(path, rows):
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    tmp = path + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=FIELDS, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow(r)
    os.replace(tmp, path)


def log(row):
    sys.stdout.write(f"  {row.get('label','')} {row['platform']} {row['scene']} {row['scheduler']} c={row['clients']} "
                     f"k={row['horizon_s']} d={row['prediction_depth']}: {row['status']} "
                     f"{float(row['steady_rays_per_second'] or 0):.4g} block visits/s"
                     + (f", {float(row['steady_rays_shot_per_second']):.4g} rays shot/s" if row.get('steady_rays_shot_per_second') not in ("", None) else "")
                     + f" ({row['run_wall_s']} s wall)\n")
    sys.stdout.flush()


# ---------------------------------------------------------------- platform variants

def load_platform(name):
    return json.load(open(os.path.join(PLATFORMS, name + ".json")))


def save_platform(p, folder, name):
    os.makedirs(folder, exist_ok=True)
    p = copy.deepcopy(p)
    p["name"] = name
    path = os.path.join(folder, name + ".json")
    with open(path + ".tmp", "w") as f:
        json.dump(p, f, indent=1)
    os.replace(path + ".tmp", path)
    return path


_UNIT = re.compile(r"^([0-9.eE+-]+)([kMGT]i?)?([Bb]/s|B)$")


def scale_quantity(text, factor):
    """'1Gb/s' x 0.1 -> '100000000b/s' (unit kept, prefix folded into the number)."""
    mm = _UNIT.match(text)
    if not mm:
        raise ValueError(f"not a size/bandwidth: {text}")
    mult = {None: 1, "k": 1e3, "M": 1e6, "G": 1e9, "T": 1e12, "Ki": 2**10, "Mi": 2**20, "Gi": 2**30, "Ti": 2**40}[mm.group(2)]
    v = float(mm.group(1)) * mult * factor
    if mm.group(3) == "B":
        return f"{int(v)}B"
    return f"{v:.6g}{mm.group(3)}"


def slower_lan(p, factor):
    """Every NIC `factor` times slower (Sec. 6's 1 GbE / 100 Mb become 100 Mb / 10 Mb for 0.1)."""
    p = copy.deepcopy(p)
    for net in p.get("networks", []):
        if "bandwidth" in net:
            net["bandwidth"] = scale_quantity(net["bandwidth"], factor)
        for m in net["members"]:
            if "bandwidth" in m:
                m["bandwidth"] = scale_quantity(m["bandwidth"], factor)
    return p


def scale_cluster(n, rack=32):
    """n type-A nodes in racks of `rack` (fewer: one rack) on a backbone as fast as all rack
    uplinks together: platforms/scale-64.json's layout at any size."""
    p = copy.deepcopy(load_platform("scale-64"))
    racks = max(1, (n + rack - 1) // rack)
    net = p["networks"][0]
    p["nodes"] = [{"name": f"A{i}", "type": "A"} for i in range(n)]
    net["backbone"] = {"bandwidth": f"{10 * racks}Gb/s", "latency": "5us"}
    net["racks"] = [{"name": f"r{r}", "uplink": "10Gb/s"} for r in range(racks)]
    net["members"] = [{"node": f"A{i}", "rack": f"r{i // rack}"} for i in range(n)]
    p["description"] = f"{n} type-A nodes in {racks} rack(s) of up to {rack} on a backbone"
    return p


def scaled_memory(p, factor, kinds=("host", "gpu")):
    """Host RAM and GPU memory capacities x factor (the scene working set stays the same)."""
    p = copy.deepcopy(p)
    for t in p["node_types"].values():
        for m in t["memory"]:
            if m["kind"] in kinds:
                m["capacity"] = scale_quantity(m["capacity"], factor)
    return p


def with_client_node(p, bandwidth="1Gb/s"):
    """The clients on a node of their own, as the paper ran them (platforms/README.md,
    "clients"): node K with 64 GiB of RAM and one CPU thread that runs AdditiveCompose (the
    first node type's timing), on the platform's LAN (made if there is none) at `bandwidth`.
    Without it the clients keep their framebuffers on the first node's RAM."""
    p = copy.deepcopy(p)
    first = p["node_types"][p["nodes"][0]["type"]]
    compose = next(c["timing"]["AdditiveCompose"] for c in first["compute"] if "AdditiveCompose" in c["timing"])
    p["node_types"]["client"] = {
        "description": "the clients: their framebuffers, and a thread that composes frames",
        "memory": [{"name": "ram", "kind": "host", "capacity": "64GiB"}],
        "compute": [{"name": "cpu", "kind": "cpu", "count": 1, "memory": "ram", "timing": {"AdditiveCompose": compose}}],
        "channels": [],
    }
    p["nodes"].append({"name": "K", "type": "client"})
    member = {"node": "K", "memory": "ram", "bandwidth": bandwidth}
    if p.get("networks"):
        p["networks"][0]["members"].append(member)
    else:
        p["networks"] = [{"name": "lan", "kind": "lan", "latency": "100us", "duplex": "full",
                          "members": [{"node": n["name"], "memory": "ram", "bandwidth": bandwidth} for n in p["nodes"][:-1]]
                          + [member]}]
    p["clients"] = "K.ram"
    return p


def central_database(p, master):
    """Only `master` keeps a disk (the scene database, Sec. 6.2); every other node is a
    diskless copy of its type, caching what it fetches in RAM and GPU memory (the paper's
    slaves also cache on their local HDD: not modelled)."""
    p = copy.deepcopy(p)
    types = p["node_types"]
    for node in p["nodes"]:
        if node["name"] == master:
            continue
        t = node["type"]
        nt = t + "-slave"
        if nt not in types:
            s = copy.deepcopy(types[t])
            s["description"] = s.get("description", "") + "; diskless slave of a central scene database"
            s["memory"] = [m for m in s["memory"] if m["kind"] != "disk"]
            disks = {m["name"] for m in types[t]["memory"] if m["kind"] == "disk"}
            s["channels"] = [c for c in s["channels"] if not set(c["between"]) & disks]
            types[nt] = s
        node["type"] = nt
    return p


def scale_timing(timing, factor):
    out = copy.deepcopy(timing)
    for jt in out.values():
        for k, v in jt.get("rate", {}).items():
            jt["rate"][k] = scale_quantity(v, factor)
    return out


def fast_gpu_slow_cpus(gpu_factor, cpu_factor, base="paper-A"):
    """One node: its GPU `gpu_factor` times faster, its CPU threads `cpu_factor` times slower
    (one very fast GPU among slow CPUs)."""
    p = load_platform(base)
    for t in p["node_types"].values():
        for c in t["compute"]:
            c["timing"] = scale_timing(c["timing"], gpu_factor if c["kind"] == "gpu" else cpu_factor)
    return p
