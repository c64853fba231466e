"""Helpers shared by the experiment notebooks.

Full setting (default): read the results that `scripts/experiments/run_all.sh --full`
wrote to notebooks/results/, and save figures as PNG next to the notebooks.
Reduced setting (RAYLINE_NB_REDUCED=1, used by ctest): run the experiment script itself in
its reduced mode into $RAYLINE_NB_OUT (the build tree), read that, and save figures there,
so CI executes the whole chain rayline -> CSV -> figures without touching committed files."""
import os
import subprocess
import sys

import matplotlib

matplotlib.use(os.environ.get("MPLBACKEND", "Agg"))
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
REDUCED = os.environ.get("RAYLINE_NB_REDUCED", "") not in ("", "0")
OUT = os.environ.get("RAYLINE_NB_OUT", os.path.join(REPO, "out", "notebooks-reduced")) if REDUCED else os.path.join(HERE, "results")
SCRIPT = os.path.join(REPO, "scripts", "experiments", "experiments.py")
COLORS = {"gmb": "tab:blue", "budge": "tab:orange", "loadanyonce": "tab:green", "gmb-ca": "tab:cyan",
          "rayline": "tab:red", "gmb-flat": "tab:purple"}
NAMES = {"gmb": "GMB (paper)", "budge": "Budge 2009", "loadanyonce": "Navratil 2014 (LoadAnyOnce)",
         "gmb-ca": "GMB completion-aware (Rayline)", "rayline": "Rayline's policy",
         "gmb-flat": "GMB in one cell (--plan-cell 0)"}
SHORT = {"gmb": "GMB", "budge": "Budge", "loadanyonce": "LAO", "gmb-ca": "GMB-CA", "rayline": "Rayline",
         "gmb-flat": "GMB-1cell"}
SCHEDULERS = ["gmb", "budge", "loadanyonce"]


def schedulers_in(df):
    """The three of the paper, then any extra series the results hold (gmb-ca, rayline, gmb-flat)."""
    return SCHEDULERS + [s for s in ["gmb-ca", "rayline", "gmb-flat"] if s in set(df.scheduler)]


def load(name, extra=None):
    """The result table of experiment `name` (and its extra table `extra`, e.g. 'central-series')."""
    done = os.path.join(OUT, f".{name}.done")
    reuse = os.environ.get("RAYLINE_NB_REUSE", "") not in ("", "0")  # debugging: skip re-running
    # An extra table comes from the run that wrote the main one (load(name) before it).
    if REDUCED and not ((reuse or extra) and os.path.exists(done)):
        os.makedirs(OUT, exist_ok=True)
        subprocess.run(["/usr/bin/python3", SCRIPT, name, "--mode", "reduced", "--out", OUT], check=True)
        open(done, "w").close()
    path = os.path.join(OUT, (extra or name) + ".csv")
    if not os.path.exists(path):
        sys.exit(f"{path} missing: run scripts/experiments/run_all.sh --full")
    return pd.read_csv(path)


def shown_path(path):
    """A path as printed in a notebook's output: relative to the repository when inside it,
    so executed notebooks carry no machine's absolute paths."""
    path = os.path.abspath(path)
    return os.path.relpath(path, REPO) if path.startswith(REPO + os.sep) else os.path.basename(path)


def savefig(fig, fname):
    """PNG next to the notebook (full setting) or into the reduced output folder, and the
    same image inline in the executed notebook."""
    folder = os.path.join(OUT, "figures") if REDUCED else HERE
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, fname)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    print("figure:", shown_path(path))
    try:
        from IPython import get_ipython
        from IPython.display import Image, display
        if get_ipython() is not None:
            display(Image(filename=path))
    except ImportError:
        pass


def peak(df, by):
    """Peak over client counts (Sec. 6: clients are added until each method peaks): the row
    of the highest steady rays/s per group; a group whose runs all failed keeps its failure."""
    ok = df[df.status == "ok"]
    best = ok.loc[ok.groupby(by).steady_rays_per_second.idxmax()] if len(ok) else ok
    bad = df[~df.set_index(by).index.isin(best.set_index(by).index)].drop_duplicates(by)
    return pd.concat([best, bad]).reset_index(drop=True)


def mark_failures(ax, xs, rows, y_floor, color):
    """Draw a run that stalled / timed out / failed / traced nothing after the warm-up as a
    cross at the floor of the axis, in the scheduler's colour and labelled with the
    scheduler and what happened, never as a missing point. Schedulers are staggered upwards."""
    for x, (_, r) in sorted(zip(xs, rows.iterrows()), key=lambda t: t[0]):
        bad = r.status != "ok" or not (r.steady_rays_per_second > 0)
        if bad:
            i = list(COLORS).index(r.scheduler) if r.scheduler in COLORS else 0
            y = y_floor * (1.5 ** i)
            if r.status != "ok":
                what = r.status
            elif r.get("true_idle", 0) > 0.5:
                what = f"no rays: devices idle, {int(r.queued_at_end)} jobs queued"
            else:
                what = "no rays after warm-up"
            ax.plot([x], [y], marker="X", color=color, markersize=10, markeredgecolor="red", zorder=5)
            seen = ax.__dict__.setdefault("_rayline_failure_labels", set())
            kind = what.split(",")[0]
            if (r.scheduler, kind) in seen:
                continue  # one label per method and kind of failure in a panel: crosses say the rest
            seen.add((r.scheduler, kind))
            ax.annotate(f"{SHORT.get(r.scheduler, r.scheduler)}: {what}", (x, y), textcoords="offset points",
                        xytext=(-6, 7), fontsize=6.5, color="red", ha="left")
