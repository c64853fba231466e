#!/usr/bin/env python3
"""Scene profiles for the simulator's path-tracing workload (docs/scene-profiles.md).

    scripts/make_profiles.py [make] [--rayline build/apps/rayline] [--work out/profiles] [--profiles scenes]
                             [--scenes boeing,museum] [--seed 1] [--synthetic]
        writes PROFILES/boeing.profile.json and PROFILES/museum.profile.json (statistics from
        `rayline render --record-profile`), and WORK/NAME-render.profile.json + NAME.replay.log
    scripts/make_profiles.py stability [--profile-seeds 1,2] [--seeds 1-6] [--out out/stability] [--reuse]
        makes the profiles once per profile seed into OUT/seed-S/ and writes OUT/stability.csv:
        steady rays shot per second (budge, gmb; paper-cluster, warm start, 8 clients, 12 s) and
        the compute bound of each, and how far the seeds' profiles differ (target: < 5 %)
    scripts/make_profiles.py fidelity [--rayline ...] [--duration 30s] [--out out/fidelity]
        writes OUT/fidelity.csv: simulator wall time vs throughput error of the three fidelity
        levels on both scenes, error measured against replay of the renderer-recorded logs
        (run `make` first: it reads WORK/NAME-render.profile.json and WORK/NAME.replay.log),
        and OUT/prediction.csv (as below)
    scripts/make_profiles.py prediction [--rayline ...] [--duration 30s] [--clients 4] [--out out/fidelity]
        writes OUT/prediction.csv: prediction accuracy and steady throughput without
        prediction, with it (failed predictions withdrawn with their T-jobs) and with failed
        predictions kept (--cancel-failed off), 1 and --clients clients, on paper-A and --platform,
        means over --seeds (default 1,2,3)

How a profile is made (standard library only; deterministic for --seed; docs/scene-profiles.md):
 1. `rayline generate boeing-like|museum-like --seed S` at --triangles (default: Boeing 8M,
    museum 2M: enough parts and statues that two seeds give the same throughput within a few
    per cent), then `rayline partition` into 129 / 65 blocks (the paper's block counts,
    Table 1): cell bounds, geometry bounds, triangle counts, block file sizes, face
    neighbours with shared areas (blocks.json). The partition is the paper's median split
    (Sec. 6): each kd-tree node cuts at the quantile of its triangles' centroids, so blocks
    own equal triangle counts; triangles crossing a plane are stored on both sides.
 2. Sizes are scaled to the paper's footprints (Table 1: 26.5 GiB / 12.3 GiB): block b gets
    file_bytes(b) * target / sum(file_bytes), i.e. the median split's even blocks, differing
    only by the straddling triangles each holds (Boeing 201-220 MiB, museum 190-199 MiB).
 3. THE RENDERER'S KERNELS (default): for each of --keyframes camera keyframes (an orbit
    outside the Boeing-like model, a walk through the museum-like interior) the scene is
    rendered by `rayline render` on that partition at --render-resolution / --render-spp
    (default 256x256, 4 spp) with the profile's max_bounces as --max-depth, --seed
    1000*S+k, --skip-empty off (every cell along a ray is visited, as in the simulator's
    graph, whose missed rays go to face neighbours), with --record-profile (per-cell counts of
    every ray the kernels traced: hits, continuations, escapes, transitions to each face
    neighbour, shadow rays occluded / lit / going on) and --record-replay (a per-keyframe
    replay log). The counts of all keyframes are summed; per block, alpha, beta, escape,
    p(b -> n), shadow_occlusion, shadow_exit are ratios of those counts with a --prior of
    pseudo-rays at the scene mean (area-weighted for transitions, so every face neighbour
    keeps p > 0); camera entry distributions come from the camera rays of each keyframe.
    Also written to --work: NAME-render.profile.json (the same statistics at the render's
    image size, for replay) and NAME.replay.log (all keyframes), used by `fidelity`.
    --synthetic: the old SYNTHETIC tracer instead (homogeneous media inside each block's
    geometry bounds, density kappa*(triangles/volume)^(1/3), kappa calibrated to a target
    hit ratio per cell visit, uniform scattering, fixed beta, one shadow ray per hit to a
    point light above the scene) -- a fallback for builds without the renderer.
 4. The analytic section holds the scene means of the same counts (the paper's global
    alpha/beta; neighbours weighted by area).
"""
import argparse
import csv
import json
import math
import os
import random
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GIB = 1024 ** 3
DEFAULT_OUT = os.path.join(ROOT, "out", "fidelity")

SCENES = {
    "boeing": dict(generator="boeing-like", triangles="8M", blocks=129, bytes=26.5 * GIB, width=512, height=512, spp=4,
                   tiles=[8, 8], wave_rays=262144, inflight_rays=4000000, max_bounces=5, alpha=0.55, beta=0.5,
                   camera="orbit", description="Boeing 777-like CAD model (rayline generate boeing-like), "
                   "partitioned into the paper's 129 blocks, scaled to 26.5 GiB; 512^2, 4 spp (Table 1)"),
    "museum": dict(generator="museum-like", triangles="2M", blocks=65, bytes=12.3 * GIB, width=2048, height=2048, spp=128,
                   tiles=[8, 8], wave_rays=1048576, inflight_rays=8000000, max_bounces=8, alpha=0.7, beta=0.8,
                   camera="walk", description="SponzaMuseum-like interior (rayline generate museum-like), "
                   "partitioned into the paper's 65 blocks, scaled to 12.3 GiB; 2048^2, 128 spp, many diffuse "
                   "bounces (Table 1)"),
}


def seed_list(text):
    """'1,2,5-8' -> [1, 2, 5, 6, 7, 8]"""
    out = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


def run(cmd):
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


class Partition:
    def __init__(self, index):
        self.nodes = index["kdtree"]["nodes"]
        self.root = index["kdtree"]["root"]
        self.lo = index["bounds"]["lo"]
        self.hi = index["bounds"]["hi"]
        self.blocks = index["blocks"]

    def inside(self, p):
        return all(self.lo[a] <= p[a] <= self.hi[a] for a in range(3))

    def locate(self, p):
        n = self.nodes[self.root]
        while "block" not in n:
            n = self.nodes[n["left"] if p[n["axis"]] < n["split"] else n["right"]]
        return n["block"]


def box_interval(o, d, lo, hi):
    t0, t1 = 0.0, math.inf
    for a in range(3):
        if abs(d[a]) < 1e-12:
            if o[a] < lo[a] or o[a] > hi[a]:
                return None
            continue
        inv = 1.0 / d[a]
        ta, tb = (lo[a] - o[a]) * inv, (hi[a] - o[a]) * inv
        if ta > tb:
            ta, tb = tb, ta
        t0, t1 = max(t0, ta), min(t1, tb)
        if t0 > t1:
            return None
    return t0, t1


def unit(v):
    n = math.sqrt(sum(x * x for x in v)) or 1.0
    return [x / n for x in v]


def random_dir(rng):
    z = 2 * rng.random() - 1
    phi = 2 * math.pi * rng.random()
    r = math.sqrt(max(0.0, 1 - z * z))
    return [r * math.cos(phi), r * math.sin(phi), z]


class Tracer:
    def __init__(self, part, kappa, beta, max_bounces, rng):
        self.part, self.kappa, self.beta, self.max_bounces, self.rng = part, kappa, beta, max_bounces, rng
        nb = len(part.blocks)
        self.media = []
        for b in part.blocks:
            c, g = b["cell"], b.get("geometry_bounds")
            if not g or b["triangles"] == 0:
                self.media.append(None)
                continue
            lo = [max(c["lo"][a], g["lo"][a]) for a in range(3)]
            hi = [min(c["hi"][a], g["hi"][a]) for a in range(3)]
            ext = max(hi[a] - lo[a] for a in range(3))
            if ext <= 0:
                self.media.append(None)
                continue
            vol = 1.0
            for a in range(3):
                vol *= max(hi[a] - lo[a], 1e-3 * ext)
            self.media.append((lo, hi, (b["triangles"] / vol) ** (1 / 3)))
        self.visits = [0] * nb
        self.hits = [0] * nb
        self.escapes = [0] * nb
        self.trans = [dict() for _ in range(nb)]
        self.s_visits = [0] * nb
        self.s_occ = [0] * nb
        self.s_exit = [0] * nb
        self.s_trans = [dict() for _ in range(nb)]
        span = [part.hi[a] - part.lo[a] for a in range(3)]
        self.eps = 1e-6 * max(span)
        self.light = [(part.lo[0] + part.hi[0]) / 2, part.hi[1] + 2 * span[1], (part.lo[2] + part.hi[2]) / 2]

    def medium_hit(self, b, o, d, t0, t1):
        """Distance of a hit inside cell b's medium within [t0, t1], or None."""
        m = self.media[b]
        if m is None:
            return None
        iv = box_interval(o, d, m[0], m[1])
        if iv is None:
            return None
        a, z = max(iv[0], t0), min(iv[1], t1)
        if a >= z:
            return None
        t = a - math.log(1 - self.rng.random()) / (self.kappa * m[2])
        return t if t < z else None

    def walk(self, o, d, shadow, max_t=math.inf):
        """Walks cells from o (inside the scene) along d. Returns ('hit', point, block) or
        ('escape', None, block) / shadow: ('occluded'|'lit', ...)."""
        b = self.part.locate(o)
        t = 0.0
        while True:
            c = self.part.blocks[b]["cell"]
            iv = box_interval(o, d, c["lo"], c["hi"])
            t_exit = iv[1] if iv else t
            if shadow:
                self.s_visits[b] += 1
            else:
                self.visits[b] += 1
            th = self.medium_hit(b, o, d, t, min(t_exit, max_t))
            if th is not None:
                if shadow:
                    self.s_occ[b] += 1
                    return "occluded", None, b
                self.hits[b] += 1
                return "hit", [o[a] + th * d[a] for a in range(3)], b
            if t_exit >= max_t:
                return "lit", None, b
            p = [o[a] + (t_exit + self.eps) * d[a] for a in range(3)]
            if not self.part.inside(p):
                if shadow:
                    return "lit", None, b
                self.escapes[b] += 1
                return "escape", None, b
            n = self.part.locate(p)
            if n == b:  # numerically stuck on a face: nudge
                t = t_exit + 10 * self.eps
                continue
            tr = self.s_trans if shadow else self.trans
            tr[b][n] = tr[b].get(n, 0) + 1
            if shadow:
                self.s_exit[b] += 1
            b, t = n, t_exit + self.eps

    def path(self, o, d):
        for bounce in range(self.max_bounces):
            kind, p, b = self.walk(o, d, False)
            if kind == "escape":
                return
            # next-event estimation: one shadow ray to the light
            to_l = [self.light[a] - p[a] for a in range(3)]
            dist = math.sqrt(sum(x * x for x in to_l))
            self.walk(p, unit(to_l), True, max_t=dist)
            if bounce + 1 >= self.max_bounces or self.rng.random() >= self.beta:
                return
            o, d = p, random_dir(self.rng)


def cameras(part, mode, keys):
    lo, hi = part.lo, part.hi
    c = [(lo[a] + hi[a]) / 2 for a in range(3)]
    span = [hi[a] - lo[a] for a in range(3)]
    cams = []
    for k in range(keys):
        if mode == "orbit":  # outside, around the model, looking at its centre
            ang = 2 * math.pi * k / keys
            r = 0.9 * max(span)
            eye = [c[0] + r * math.cos(ang), c[1] + 0.3 * span[1] + 0.2 * max(span), c[2] + r * math.sin(ang)]
            look = c
        else:  # a walk through the interior along its longest axis
            ax = max(range(3), key=lambda a: span[a])
            f = 0.15 + 0.7 * k / max(1, keys - 1)
            eye = [c[0], lo[1] + 0.3 * span[1], c[2]]
            eye[ax] = lo[ax] + f * span[ax]
            look = list(eye)
            look[ax] += span[ax]
            look[(ax + 2) % 3 if ax != 1 else 0] += 0.3 * span[ax] * math.sin(k)
        cams.append((eye, unit([look[a] - eye[a] for a in range(3)])))
    return cams


def primary(eye, fwd, rng, fov=math.radians(50)):
    up = [0.0, 1.0, 0.0]
    right = unit([fwd[1] * up[2] - fwd[2] * up[1], fwd[2] * up[0] - fwd[0] * up[2], fwd[0] * up[1] - fwd[1] * up[0]])
    upv = [right[1] * fwd[2] - right[2] * fwd[1], right[2] * fwd[0] - right[0] * fwd[2], right[0] * fwd[1] - right[1] * fwd[0]]
    s = math.tan(fov / 2)
    x, y = (2 * rng.random() - 1) * s, (2 * rng.random() - 1) * s
    return unit([fwd[a] + x * right[a] + y * upv[a] for a in range(3)])


def enter(part, eye, d):
    """First point of the ray inside the scene bounds, or None (background)."""
    if part.inside(eye):
        return eye
    iv = box_interval(eye, d, part.lo, part.hi)
    if iv is None:
        return None
    span = max(part.hi[a] - part.lo[a] for a in range(3))
    return [eye[a] + (iv[0] + 1e-6 * span) * d[a] for a in range(3)]


def trace_scene(part, cfg, paths, seed, keys=8):
    rng = random.Random(seed)
    cams = cameras(part, cfg["camera"], keys)
    # kappa: hit ratio per cell visit ~ target (a few secant steps on a small sample).
    kappa = 1.0
    for _ in range(6):
        t = Tracer(part, kappa, cfg["beta"], 1, random.Random(seed + 1))
        for i in range(1500):
            eye, fwd = cams[i % keys]
            d = primary(eye, fwd, t.rng)
            o = enter(part, eye, d)
            if o is not None:
                t.path(o, d)
        a = sum(t.hits) / max(1, sum(t.visits))
        a = min(max(a, 1e-3), 0.999)
        # hit prob per visit ~ 1 - exp(-kappa x): scale kappa by the ratio of -log(1 - alpha)
        kappa *= min(4.0, max(0.25, math.log(1 - cfg["alpha"]) / math.log(1 - a)))
    tr = Tracer(part, kappa, cfg["beta"], cfg["max_bounces"], rng)
    entry = [[0] * len(part.blocks) for _ in range(keys)]
    background = [0] * keys
    for i in range(paths):
        k = i % keys
        eye, fwd = cams[k]
        d = primary(eye, fwd, rng)
        o = enter(part, eye, d)
        if o is None:
            background[k] += 1
            continue
        entry[k][part.locate(o)] += 1
        tr.path(o, d)
    return tr, entry, background, kappa


class RenderCounts:
    """Per-cell counts summed over the keyframes' `rayline render --record-profile` files,
    with the attribute names of the synthetic Tracer (build_profile reads either)."""

    def __init__(self, nb):
        self.visits, self.hits, self.escapes = [0] * nb, [0] * nb, [0] * nb
        self.survived = [0] * nb
        self.trans = [dict() for _ in range(nb)]
        self.s_visits, self.s_occ, self.s_exit = [0] * nb, [0] * nb, [0] * nb
        self.s_trans = [dict() for _ in range(nb)]
        self.mapping = {}
        self.rays = 0

    def add(self, st):
        for b in st["blocks"]:
            i = b["id"]
            self.visits[i] += b["path_rays"]
            self.hits[i] += b["hits"]
            self.escapes[i] += b["escaped"]
            self.survived[i] += b["survived"]
            for n, c in b["transitions"]:
                self.trans[i][n] = self.trans[i].get(n, 0) + c
            self.s_visits[i] += b["shadow_rays"]
            self.s_occ[i] += b["occluded"]
            for n, c in b["shadow_transitions"]:
                self.s_trans[i][n] = self.s_trans[i].get(n, 0) + c
                self.s_exit[i] += c
        for k, v in st["mapping"].items():
            self.mapping[k] = self.mapping.get(k, 0) + v
        self.rays += st["render_rays"]["traced"]


def build_profile(name, index, cfg, tr, entry, background, provenance, prior=20.0, image=None, batching=None):
    part = Partition(index)
    blocks = index["blocks"]
    nb = len(blocks)
    total_file = sum(b["bytes"] for b in blocks)
    lo, hi = part.lo, part.hi
    out_blocks = []
    vis, hit = sum(tr.visits), sum(tr.hits)
    g_alpha = hit / max(1, vis)
    s_vis, s_occ = sum(tr.s_visits), sum(tr.s_occ)
    g_occ = s_occ / max(1, s_vis)
    g_exit = sum(tr.s_exit) / max(1, s_vis - s_occ)
    measured_beta = hasattr(tr, "survived")
    g_beta = sum(tr.survived) / max(1, hit) if measured_beta else cfg["beta"]
    # prior: pseudo-rays at the scene mean / area weights
    for i, b in enumerate(blocks):
        c = b["cell"]
        boundary = 0.0
        for a in range(3):
            face = 1.0
            for o in range(3):
                if o != a:
                    face *= c["hi"][o] - c["lo"][o]
            boundary += face * ((c["lo"][a] <= lo[a]) + (c["hi"][a] >= hi[a]))
        nbrs = b["neighbours"]
        area = sum(n["area"] for n in nbrs)
        area_all = area + boundary
        alpha = (tr.hits[i] + prior * g_alpha) / (tr.visits[i] + prior)
        miss = tr.visits[i] - tr.hits[i]
        esc_prior = boundary / area_all if area_all > 0 else 1.0
        escape = (tr.escapes[i] + prior * esc_prior) / (miss + prior) if nbrs else 1.0
        weights = []
        for n in nbrs:
            w = area / len(nbrs) if area <= 0 else n["area"]
            weights.append(tr.trans[i].get(n["block"], 0) + prior * w / max(area, 1e-300))
        wsum = sum(weights) or 1.0
        ps = [round(w / wsum, 9) for w in weights]
        if ps:
            ps[-1] = round(1.0 - sum(ps[:-1]), 9)
        beta = (tr.survived[i] + prior * g_beta) / (tr.hits[i] + prior) if measured_beta else cfg["beta"]
        occ = (tr.s_occ[i] + prior * g_occ) / (tr.s_visits[i] + prior)
        ex = (tr.s_exit[i] + prior * g_exit) / (tr.s_visits[i] - tr.s_occ[i] + prior)
        out_blocks.append({
            "id": i,
            "bytes": int(round(b["bytes"] * cfg["bytes"] / total_file)),
            "triangles": b["triangles"],
            "lo": [round(x, 5) for x in c["lo"]], "hi": [round(x, 5) for x in c["hi"]],
            "boundary_area": round(boundary, 5),
            "alpha": round(alpha, 5), "beta": round(beta, 5), "escape": round(min(1.0, escape), 5),
            "shadow_occlusion": round(occ, 5), "shadow_exit": round(min(1.0, ex), 5),
            "neighbours": [[n["block"], round(n["area"], 5), p] for n, p in zip(nbrs, ps)],
        })
    # Integer bytes summing exactly to the target.
    diff = int(round(cfg["bytes"])) - sum(b["bytes"] for b in out_blocks)
    out_blocks[max(range(nb), key=lambda i: out_blocks[i]["bytes"])]["bytes"] += diff
    cams = []
    for k in range(len(entry)):
        n = sum(entry[k]) + background[k]
        e = [[b, round(entry[k][b] / n, 9)] for b in range(nb) if entry[k][b]]
        bg = round(1.0 - sum(p for _, p in e), 9)
        cams.append({"background": max(0.0, bg), "entry": e})
    return {
        "format": "rayline-scene-profile", "version": 1, "name": name,
        "description": cfg["description"],
        "provenance": provenance,
        "image": image or {"width": cfg["width"], "height": cfg["height"], "spp": cfg["spp"], "tiles": cfg["tiles"]},
        "batching": batching or {"wave_rays": cfg["wave_rays"], "inflight_rays": cfg["inflight_rays"],
                                 "max_bounces": cfg["max_bounces"]},
        "records": {"ray_bytes": 64, "shadow_ray_bytes": 64, "hit_bytes": 64, "sample_bytes": 16,
                    "framebuffer_bytes_per_pixel": 16, "request_bytes": 4096},
        "analytic": {"alpha": round(g_alpha, 5), "beta": round(g_beta, 5), "shadow_occlusion": round(g_occ, 5),
                     "shadow_exit": round(g_exit, 5)},
        "block_count": nb, "blocks": out_blocks, "camera_path": cams,
    }


def write_compact(path, prof):
    """One block / keyframe per line: small, diffable files."""
    head = {k: v for k, v in prof.items() if k not in ("blocks", "camera_path")}
    lines = ["{"]
    for k, v in head.items():
        lines.append(f"  {json.dumps(k)}: {json.dumps(v)},")
    lines.append('  "blocks": [')
    lines += ["    " + json.dumps(b, separators=(",", ":")) + ("," if i + 1 < len(prof["blocks"]) else "")
              for i, b in enumerate(prof["blocks"])]
    lines.append("  ],")
    lines.append('  "camera_path": [')
    lines += ["    " + json.dumps(c, separators=(",", ":")) + ("," if i + 1 < len(prof["camera_path"]) else "")
              for i, c in enumerate(prof["camera_path"])]
    lines.append("  ]")
    lines.append("}")
    tmp = path + ".partial"
    with open(tmp, "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(tmp, path)


def keyframe_scene(scene, eye, fwd, width, height):
    """The generated scene with one camera: keyframe (eye, fwd) (the renderer renders cameras[0])."""
    sc = {k: v for k, v in scene.items() if k != "camera_paths"}
    look = [eye[a] + fwd[a] for a in range(3)]
    sc["cameras"] = {"key": {"position": eye, "look_at": look, "up": [0.0, 1.0, 0.0], "fov_deg": 50.0,
                             "resolution": [width, height]}}
    return sc


def render_seed(args):
    return args.seed if args.render_seed is None else args.render_seed


def render_counts(args, name, cfg, scene_path, blocks_dir, part):
    """Renders every keyframe with --record-profile / --record-replay; returns the summed
    counts, per-keyframe entry counts, and the concatenated replay log's pieces."""
    with open(scene_path) as f:
        scene = json.load(f)
    w, h = (int(x) for x in args.render_resolution.split("x"))
    counts = RenderCounts(len(part.blocks))
    entry, background, pieces = [], [], []
    for k, (eye, fwd) in enumerate(cameras(part, cfg["camera"], args.keyframes)):
        key_scene = os.path.join(args.work, f"{name}-key{k}.json")
        with open(key_scene, "w") as f:
            json.dump(keyframe_scene(scene, eye, fwd, w, h), f)
        stats = os.path.join(args.work, f"{name}-key{k}.stats.json")
        log = os.path.join(args.work, f"{name}-key{k}.replay.log")
        run([args.rayline, "render", "--scene", key_scene, "--blocks-dir", blocks_dir, "--resolution", f"{w}x{h}",
             "--spp", str(args.render_spp), "--max-depth", str(cfg["max_bounces"]), "--threads", str(args.threads),
             "--seed", str(1000 * render_seed(args) + k), "--gpu", "none", "--skip-empty", args.skip_empty, "--record-profile", stats, "--record-replay", log,
             "--record-keyframe", str(k), "--record-tiles", "x".join(str(t) for t in cfg["tiles"]),
             "--out", os.path.join(args.work, f"{name}-key{k}.exr"), "-q"])
        with open(stats) as f:
            st = json.load(f)
        counts.add(st)
        e = [0] * len(part.blocks)
        for b, c in st["camera"]["entry"]:
            e[b] += c
        entry.append(e)
        background.append(st["camera"]["background"])
        with open(log) as f:
            pieces += [line for line in f if line.strip() and not line.startswith(("#", "rayline-replay"))]
    return counts, entry, background, pieces


def make(args):
    os.makedirs(args.work, exist_ok=True)
    os.makedirs(args.profiles, exist_ok=True)
    seconds = {}
    for name in args.scenes.split(","):
        cfg = SCENES[name]
        ply = os.path.join(args.work, name + ".ply")
        scene = os.path.join(args.work, name + ".json")
        blocks_dir = os.path.join(args.work, name + "-blocks")
        t0 = time.time()
        triangles = args.triangles or cfg["triangles"]
        run([args.rayline, "generate", cfg["generator"], "--triangles", triangles, "--out", ply,
             "--seed", str(args.seed), "-q"])
        if os.path.isdir(blocks_dir):
            shutil.rmtree(blocks_dir)
        run([args.rayline, "partition", "--scene", scene, "--blocks", str(cfg["blocks"]), "--out", blocks_dir, "-q"])
        with open(os.path.join(blocks_dir, "blocks.json")) as f:
            index = json.load(f)
        part = Partition(index)
        total_file = sum(b["bytes"] for b in index["blocks"])
        mib = sorted(b["bytes"] * cfg["bytes"] / total_file / 2 ** 20 for b in index["blocks"])
        base = (f"scripts/make_profiles.py --seed {args.seed}: rayline generate {cfg['generator']} --triangles "
                f"{triangles} --seed {args.seed}, "
                f"rayline partition --blocks {cfg['blocks']} (median split); {cfg['bytes'] / GIB:.1f} GiB shared in "
                f"proportion to the block files ({mib[0]:.0f}-{mib[-1]:.0f} MiB per block); ")
        if args.synthetic:
            tr, entry, bg, kappa = trace_scene(part, cfg, args.paths, args.seed)
            prov = base + (f"statistics from a SYNTHETIC tracer ({args.paths} camera paths through the cells, homogeneous "
                           f"media of density kappa*(tri/vol)^(1/3), kappa={kappa:.4g}), not the renderer's kernels")
            prof = build_profile(name, index, cfg, tr, entry, bg, prov)
            note = f"kappa {kappa:.3g}"
        else:
            tr, entry, bg, pieces = render_counts(args, name, cfg, scene, blocks_dir, part)
            m = tr.mapping
            prov = base + (f"Markov statistics from the renderer's kernels: rayline render --record-profile of "
                           f"{args.keyframes} camera keyframes at {args.render_resolution}, {args.render_spp} spp, "
                           f"--max-depth {cfg['max_bounces']}, --skip-empty {args.skip_empty}, --seed {1000 * render_seed(args)}+k "
                           f"({tr.rays} rays traced; prior {args.prior:g} pseudo-rays "
                           f"at the scene mean; shadow rays the renderer did not make counted occluded: "
                           f"{m.get('shadow_not_created', 0)})")
            prof = build_profile(name, index, cfg, tr, entry, bg, prov, prior=args.prior)
            # The same statistics at the render's image size, and its replay log (for `fidelity`).
            w, h = (int(x) for x in args.render_resolution.split("x"))
            frame = w * h * args.render_spp
            rprof = build_profile(name + "-render", index, cfg, tr, entry, bg,
                                  prov + "; image at the recorded render's size (replay with NAME.replay.log)",
                                  prior=args.prior, image={"width": w, "height": h, "spp": args.render_spp,
                                                           "tiles": cfg["tiles"]},
                                  batching={"wave_rays": max(1, frame // 4), "inflight_rays": 4 * frame,
                                            "max_bounces": cfg["max_bounces"]})
            write_compact(os.path.join(args.work, name + "-render.profile.json"), rprof)
            log = os.path.join(args.work, name + ".replay.log")
            with open(log + ".partial", "w") as f:
                f.write("rayline-replay 1 per-keyframe\n")
                f.write(f"# {name}: rayline render --record-replay, {args.keyframes} keyframes at "
                        f"{args.render_resolution}, {args.render_spp} spp (keyframe k = client 0, frame k)\n")
                f.writelines(pieces)
            os.replace(log + ".partial", log)
            note = f"{tr.rays} rays traced, mapping {m}"
        out = os.path.join(args.profiles, name + ".profile.json")
        write_compact(out, prof)
        print(f"{out}: {len(prof['blocks'])} blocks, {sum(b['bytes'] for b in prof['blocks']) / GIB:.2f} GiB, "
              f"alpha {prof['analytic']['alpha']:.3f}, beta {prof['analytic']['beta']:.3f}, shadow occlusion "
              f"{prof['analytic']['shadow_occlusion']:.3f}; {note}; {time.time() - t0:.1f} s")
        seconds[name] = time.time() - t0
    return seconds


def write_csv(path, rows):
    with open(path + ".partial", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    os.replace(path + ".partial", path)
    print(path)
    for r in rows:
        print(r)


def fidelity(args):
    """Simulator wall time vs throughput error of analytic / markov against replay of the
    renderer-recorded logs (`make` wrote WORK/NAME-render.profile.json: the profile's
    statistics at the render's image size, and WORK/NAME.replay.log: every keyframe's
    render, replayed for every frame of that keyframe). Then prediction accuracy and the
    throughput gain of prediction on the committed (paper-scale) profiles."""
    os.makedirs(args.out, exist_ok=True)
    rows = []
    for scene in ("boeing", "museum"):
        prof = os.path.join(args.work, scene + "-render.profile.json")
        log = os.path.join(args.work, scene + ".replay.log")
        if not (os.path.exists(prof) and os.path.exists(log)):
            sys.exit(f"{prof} / {log} missing: run `scripts/make_profiles.py` (make) first")
        base = [args.rayline, "simulate", "--workload", prof, "--duration", args.duration, "--clients", str(args.clients),
                "--prediction-depth", str(args.depth), "--platform", args.platform, "--no-progress"]
        results = {}
        for fid in ("replay", "markov", "analytic"):
            out = os.path.join(args.out, f"{scene}-{fid}")
            extra = ["--replay", log] if fid == "replay" else []
            run(base + ["--fidelity", fid, "--seed", "1", "--out", out] + extra)
            with open(os.path.join(out, "metrics.json")) as f:
                results[fid] = json.load(f)
        ref = results["replay"]["path_trace"]["steady_rays_per_second"]
        rep = results["replay"]["path_trace"]["replay"]
        fallback = rep["fallback_rays"] / max(1, rep["fallback_rays"] + rep["replayed_rays"])
        for fid in ("analytic", "markov", "replay"):
            m = results[fid]
            r = m["path_trace"]["steady_rays_per_second"]
            rows.append({"scene": scene, "fidelity": fid, "simulated_s": m["simulated_s"],
                         "wall_s": round(m["simulator"]["wall_s"], 3),
                         "workload_and_loop_s": round(m["simulator"]["bookkeeping_s"], 3),
                         "steady_rays_per_second": round(r), "replay_rays_per_second": round(ref),
                         "throughput_error": round((r - ref) / ref, 5) if ref else "",
                         "abs_throughput_error": round(abs(r - ref) / ref, 5) if ref else "",
                         "frames_delivered": m["path_trace"]["frames"]["delivered"],
                         "replay_fallback_share": round(fallback, 6) if fid == "replay" else ""})
    write_csv(os.path.join(args.out, "fidelity.csv"), rows)
    prediction(args)


def stability(args):
    """How much the simulated throughput depends on the profile's seed: `make` once per seed
    in --profile-seeds (generator, render and partition inputs all follow --seed) into
    OUT/seed-S/ (kept and reused with --reuse), then for each scene and --schedulers one
    `rayline simulate` run per profile and simulator seed in --seeds (same platform, clients
    and duration), and the spread of the profiles' mean steady rays shot per second and
    compute bound next to the simulator's own spread over its seeds on each profile
    (docs/scene-profiles.md, "Stability"). Writes OUT/stability.csv (make_s: 0 when reused)."""
    seeds = seed_list(args.profile_seeds)
    scenes = args.scenes.split(",")
    os.makedirs(args.out, exist_ok=True)
    make_seconds = {}
    for seed in seeds:
        folder = os.path.join(args.out, f"seed-{seed}")
        if args.reuse and all(os.path.exists(os.path.join(folder, n + ".profile.json")) for n in scenes):
            continue
        sub = argparse.Namespace(**vars(args))
        sub.seed, sub.render_seed, sub.profiles = seed, None, folder
        sub.work = os.path.join(args.work, f"seed-{seed}")
        make_seconds.update({(seed, n): s for n, s in make(sub).items()})
    rows = []
    for scene in scenes:
        for sched in args.schedulers.split(","):
            res, runs = {}, {}
            for seed in seeds:
                vals = []
                for sim_seed in seed_list(args.seeds):
                    out = os.path.join(args.out, f"run-{scene}-{sched}-profile{seed}-sim{sim_seed}")
                    run([args.rayline, "simulate", "--platform", args.platform, "--workload",
                         os.path.join(args.out, f"seed-{seed}", scene + ".profile.json"), "--scheduler", sched,
                         "--start", "warm", "--clients", str(args.clients), "--duration", args.duration,
                         "--seed", str(sim_seed), "--no-timeline", "-q", "-o", out])
                    with open(os.path.join(out, "metrics.json")) as f:
                        pt = json.load(f)["path_trace"]
                    vals.append((pt["steady_rays_shot_per_second"], pt["bound"]["compute_rays_shot_per_second"]))
                res[seed] = [sum(v[i] for v in vals) / len(vals) for i in range(2)]
                runs[seed] = vals
            for i, metric in enumerate(("steady_rays_shot_per_second", "bound_compute_rays_shot_per_second")):
                v = [res[s][i] for s in seeds]
                mean = sum(v) / len(v)
                row = {"scene": scene, "scheduler": sched, "metric": metric}
                row.update({f"profile_seed_{s}": round(x) for s, x in zip(seeds, v)})
                row["spread"] = round((max(v) - min(v)) / mean, 5) if mean else ""
                # The simulator's own run-to-run spread on one profile (over --seeds).
                for s in seeds:
                    r = [x[i] for x in runs[s]]
                    row[f"sim_spread_seed_{s}"] = round((max(r) - min(r)) / res[s][i], 5) if res[s][i] else ""
                row.update({f"make_s_seed_{s}": round(make_seconds.get((s, scene), 0), 1) for s in seeds})
                rows.append(row)
    write_csv(os.path.join(args.out, "stability.csv"), rows)


def prediction(args):
    """Job prediction (Sec. 5.2) on the committed paper-scale profiles: steady throughput
    without prediction, with it (failed predictions withdrawn with their T-jobs), and with it
    but failed predictions kept (--cancel-failed off), on one node A and on the platform;
    each point is the mean over --seeds (these runs are chaotic: one seed can differ by tens of %)."""
    rows = []
    seeds = seed_list(args.seeds)
    for platform in dict.fromkeys(["paper-A", args.platform]):
        for scene in ("boeing", "museum"):
            for clients in sorted({1, args.clients}):
                res = {}  # tag -> one path_trace dict per seed
                for tag, depth, cancel in (("none", 0, "on"), ("withdrawn", args.prediction_depth, "on"),
                                           ("kept", args.prediction_depth, "off")):
                    for seed in seeds:
                        out = os.path.join(args.out, f"{scene}-{platform}-c{clients}-s{seed}-prediction-{tag}")
                        run([args.rayline, "simulate", "--workload", scene, "--duration", args.duration, "--clients",
                             str(clients), "--prediction-depth", str(depth), "--cancel-failed", cancel, "--platform",
                             platform, "--no-progress", "--fidelity", "markov", "--seed", str(seed), "--out", out])
                        with open(os.path.join(out, "metrics.json")) as f:
                            res.setdefault(tag, []).append(json.load(f)["path_trace"])
                mean = lambda tag, f: sum(f(r) for r in res[tag]) / len(res[tag])
                rate = lambda tag: mean(tag, lambda r: r["steady_rays_per_second"])
                pred = lambda key: mean("withdrawn", lambda r: r.get("prediction", {}).get(key, 0))
                wd = lambda key: mean("withdrawn", lambda r: r.get("prediction", {}).get("withdrawn", {}).get(key, 0))
                r0 = rate("none")
                gain = lambda tag: round(rate(tag) / r0 - 1, 5) if r0 else ""
                rows.append({"platform": platform, "scene": scene, "clients": clients, "seeds": len(seeds),
                             "prediction_depth": args.prediction_depth, "rays_per_second_without": round(r0),
                             "rays_per_second_with": round(rate("withdrawn")), "gain": gain("withdrawn"),
                             "rays_per_second_with_failed_kept": round(rate("kept")), "gain_failed_kept": gain("kept"),
                             "accuracy": round(pred("accuracy"), 5), "ray_accuracy": round(pred("ray_accuracy"), 5),
                             "predicted": round(pred("created")), "confirmed": round(pred("confirmed")),
                             "confirmed_planned": round(pred("confirmed_planned")), "failed": round(pred("failed")),
                             "withdrawn_e_jobs": round(wd("e_jobs")), "withdrawn_t_jobs": round(wd("t_jobs")),
                             "kept_t_jobs": round(wd("t_jobs_kept")), "withdrawn_t_job_bytes": round(wd("t_job_bytes"))})
    write_csv(os.path.join(args.out, "prediction.csv"), rows)
    for r in rows:
        print(f"{r['platform']:>14} {r['scene']:>7} c={r['clients']}: {r['rays_per_second_without']:>9} -> "
              f"{r['rays_per_second_with']:>9} rays/s ({100 * r['gain']:+.0f} %), failed kept "
              f"{r['rays_per_second_with_failed_kept']:>9} ({100 * r['gain_failed_kept']:+.0f} %), accuracy "
              f"{100 * r['accuracy']:.1f} % jobs / {100 * r['ray_accuracy']:.1f} % rays, withdrawn "
              f"{r['withdrawn_t_jobs']} T-jobs (kept {r['kept_t_jobs']})")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("command", nargs="?", default="make", choices=["make", "fidelity", "prediction", "stability"])
    ap.add_argument("--rayline", default=os.path.join(ROOT, "build", "apps", "rayline"))
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "profiles"))
    ap.add_argument("--profiles", default=os.path.join(ROOT, "scenes"), help="make: folder of NAME.profile.json")
    ap.add_argument("--scenes", default="boeing,museum", help="make: which profiles, comma-separated")
    ap.add_argument("--triangles", default=None, help="make: generated triangles (default: boeing 8M, museum 2M)")
    ap.add_argument("--synthetic", action="store_true", help="fallback: the synthetic tracer instead of the renderer")
    ap.add_argument("--keyframes", type=int, default=8)
    ap.add_argument("--render-resolution", default="256x256")
    ap.add_argument("--render-spp", type=int, default=4)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--skip-empty", default="off", choices=["on", "off"],
                    help="renderer's empty-space skipping (off: every cell along a ray is visited, as in the simulator)")
    ap.add_argument("--prior", type=float, default=20.0)
    ap.add_argument("--paths", type=int, default=20000)
    ap.add_argument("--seed", type=int, default=1, help="make: the generator's seed, and the renderer's")
    ap.add_argument("--render-seed", type=int, default=None, help="make: the renderer's seed (default: --seed)")
    ap.add_argument("--duration", default=None, help="simulated time (fidelity, prediction: 30s; stability: 12s)")
    ap.add_argument("--clients", type=int, default=None, help="clients (fidelity, prediction: 4; stability: 8)")
    ap.add_argument("--depth", type=int, default=0, help="fidelity runs: prediction depth")
    ap.add_argument("--prediction-depth", type=int, default=2, help="prediction.csv: depth compared with 0")
    ap.add_argument("--platform", default="paper-cluster")
    ap.add_argument("--seeds", default=None, help="simulator seeds averaged per point, e.g. 1,2,5-8 (prediction: 1,2,3; stability: 1-6)")
    ap.add_argument("--profile-seeds", default="1,2", help="stability: the profiles' --seed values compared")
    ap.add_argument("--schedulers", default="budge,gmb", help="stability: schedulers simulated")
    ap.add_argument("--reuse", action="store_true", help="stability: keep profiles already in OUT/seed-S/")
    ap.add_argument("--out", default=DEFAULT_OUT)
    args = ap.parse_args()
    if args.duration is None:
        args.duration = "12s" if args.command == "stability" else "30s"
    if args.seeds is None:
        args.seeds = "1-6" if args.command == "stability" else "1,2,3"
    if args.clients is None:
        args.clients = 8 if args.command == "stability" else 4
    if args.command == "stability" and args.out == DEFAULT_OUT:
        args.out = os.path.join(ROOT, "out", "stability")
    {"make": make, "fidelity": fidelity, "prediction": prediction, "stability": stability}[args.command](args)


if __name__ == "__main__":
    sys.exit(main())
