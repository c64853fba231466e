#!/usr/bin/python3
"""Writes the experiment notebooks (notebooks/NN_*.ipynb) from the cells below; execute them
afterwards (scripts/experiments/run_all.sh does both). Prose lives in prose/NN.md files
(one markdown cell per '---' separated section, {{CODE}} markers not needed: the code cells
are inserted after the matching markdown section)."""
import os

import nbformat as nbf

HERE = os.path.dirname(os.path.abspath(__file__))
SETUP = """import os, sys
sys.path.insert(0, os.path.abspath('.'))
from _nb import *
import numpy as np
pd.set_option('display.width', 160); pd.set_option('display.max_columns', 30)
print('setting:', 'reduced (CI)' if REDUCED else 'full', '| results:', shown_path(OUT))"""

NB = {}

NB["01_scaling"] = [
"""df = load('scaling')
inv = df[df.label.str.contains('GPUs only')]; long = df[df.label == 'long run']
df = df[~df.label.str.contains('GPUs only') & (df.label != 'long run')]
order = ['A', '2A', '3A', '4A', '+B', '+C', '+D', '+R']
pk = peak(df, ['scene', 'label', 'scheduler'])
pk['x'] = pk.label.map({l: i for i, l in enumerate(order)})
fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
for ax, scene in zip(axes, ['boeing', 'museum']):
    d = pk[pk.scene == scene]
    floor = max(1.0, d[d.steady_rays_per_second > 0].steady_rays_per_second.min() / 3) if (d.steady_rays_per_second > 0).any() else 1
    for s in schedulers_in(d):
        r = d[d.scheduler == s].sort_values('x')
        ok = r[(r.status == 'ok') & (r.steady_rays_per_second > 0)]
        ax.plot(ok.x, ok.steady_rays_per_second, 'o-', color=COLORS[s], label=NAMES[s])
        mark_failures(ax, r.x, r, floor, COLORS[s])
    ax.set_xticks(range(len(order))); ax.set_xticklabels(order)
    ax.set_yscale('log'); ax.set_title(f'{scene}: peak rays/s (steady state)'); ax.set_xlabel('nodes'); ax.grid(alpha=.3)
axes[0].set_ylabel('rays / s'); axes[1].legend(fontsize=8)
savefig(fig, 'fig8_scaling.png')
tab = pk.pivot_table(index=['scene', 'label'], columns='scheduler', values='steady_rays_per_second').reindex(columns=schedulers_in(pk))
tab = tab.reindex([(s, l) for s in ['boeing', 'museum'] for l in order if (s, l) in tab.index])
tab['gmb/budge'] = tab.gmb / tab.budge; tab['gmb/loadanyonce'] = tab.gmb / tab.loadanyonce
print(tab.to_string(float_format=lambda v: f'{v:.3g}'))""",
"""cl = pk[pk.label == '+R']
fig, axes = plt.subplots(1, 2, figsize=(12, 3.6))
ss = schedulers_in(cl); w = 0.8 / len(ss)
for i, s in enumerate(ss):
    r = cl[cl.scheduler == s].set_index('scene').reindex(['boeing', 'museum'])
    bars = axes[0].bar(np.arange(2) + (i - (len(ss) - 1) / 2) * w, 100 * r.lan_utilisation_mean, w, color=COLORS[s], label=NAMES[s])
    axes[0].bar_label(bars, fmt='%.1f', fontsize=7, padding=1)
axes[0].axhline(87.8, color=COLORS['gmb'], ls=':', lw=1); axes[0].axhline(37.1, color=COLORS['budge'], ls=':', lw=1)
axes[0].axhline(39.2, color=COLORS['loadanyonce'], ls=':', lw=1)
axes[0].set_xticks(range(2)); axes[0].set_xticklabels(['boeing', 'museum']); axes[0].set_ylabel('mean LAN utilisation %')
axes[0].set_title('heterogeneous 8 nodes (dotted: paper)'); axes[0].set_ylim(0, 100)
axes[0].legend(fontsize=7, loc='upper center', bbox_to_anchor=(0.5, -0.1), ncol=2, frameon=False)
shares = cl.set_index(['scene', 'scheduler'])[['busy', 'fetching', 'true_idle']].rename(columns={'true_idle': 'idle'})
shares.index = [f'{sc} · {SHORT[s]}' for sc, s in shares.index]
shares.plot.barh(stacked=True, ax=axes[1], color=['tab:green', 'tab:red', 'tab:gray'])
axes[1].set_xlabel('share of compute-device time'); axes[1].set_title('where device time goes (8 nodes)')
axes[1].set_ylabel(''); axes[1].set_xlim(0, 1)
axes[1].legend(fontsize=8, loc='upper center', bbox_to_anchor=(0.5, -0.16), ncol=3, frameon=False)
fig.subplots_adjust(wspace=0.45)
savefig(fig, 'fig8_lan_utilisation.png')
print(cl[['scene', 'scheduler', 'clients', 'steady_rays_per_second', 'lan_utilisation_mean', 'busy', 'fetching', 'true_idle',
          'exec_prediction_error', 'scheduler_share']].to_string(index=False, float_format=lambda v: f'{v:.3g}'))""",
"""# Investigation: where do the rays go? (peak runs of one node A and of the 8 nodes, and the same with the CPU threads removed)
diag = pd.concat([pk[pk.label.isin(['A', '+R'])], peak(inv, ['scene', 'label', 'scheduler'])])
diag = diag.assign(gpu_job_share=diag.ray_jobs_gpu / diag.ray_jobs.where(diag.ray_jobs > 0))
cols = ['scene', 'label', 'scheduler', 'steady_rays_per_second', 'ray_jobs', 'gpu_job_share', 'rays_per_ray_job',
        'scene_bytes_per_ray', 'cpu_busy', 'gpu_busy', 'fetching', 'exec_prediction_error']
print(diag.sort_values(['scene', 'label', 'scheduler'])[cols].to_string(index=False, float_format=lambda v: f'{v:.3g}'))
fig, axes = plt.subplots(1, 3, figsize=(15, 3.6))
m = diag[diag.scene == 'museum']
for ax, col, title in [(axes[0], 'gpu_job_share', 'share of ray jobs run on a GPU'), (axes[1], 'rays_per_ray_job', 'rays per ray job (batch size)'),
                       (axes[2], 'steady_rays_per_second', 'steady rays/s')]:
    labs = list(dict.fromkeys(m.label)); ss = schedulers_in(m); w = 0.8 / len(ss)
    for i, s in enumerate(ss):
        r = m[m.scheduler == s].set_index('label').reindex(labs)
        ax.bar(np.arange(len(labs)) + (i - (len(ss) - 1) / 2) * w, r[col].fillna(0), w, color=COLORS[s], label=NAMES[s])
    ax.set_xticks(range(len(labs))); ax.set_xticklabels(labs, fontsize=8); ax.set_title('museum: ' + title, fontsize=9)
    if col != 'gpu_job_share': ax.set_yscale('log')
axes[0].legend(fontsize=7)
savefig(fig, 'fig8_investigation.png')""",
"""ls = load('scaling', 'scaling-long-series')
fig, ax = plt.subplots(figsize=(8, 3.6))
for s in SCHEDULERS:
    r = ls[ls.scheduler == s].sort_values('t_s')
    ax.plot(r.t_s, r.rays_per_second.rolling(10, min_periods=1).mean(), color=COLORS[s], label=NAMES[s])
ax.set_yscale('log'); ax.set_xlabel('simulated time (s)'); ax.set_ylabel('rays/s (10 s mean)'); ax.grid(alpha=.3); ax.legend(fontsize=8)
ax.set_title('one long run: Boeing, 8 nodes, 8 clients')
savefig(fig, 'fig8_long_run.png')
print(long[['scheduler', 'duration_s', 'steady_rays_per_second', 'frames_delivered', 'fetching', 'true_idle']].to_string(index=False, float_format=lambda v: f'{v:.3g}'))""",
]

NB["07_peak"] = [
"""df = load('peak')
df['steady_rays_shot_per_second'] = pd.to_numeric(df.steady_rays_shot_per_second, errors='coerce').fillna(0)
order = ['A', '2A', '3A', '4A', '+B', '+C', '+D', '+R']
ok = df[df.status == 'ok'].copy()
# A point whose rays alive kept growing is not a steady state (metrics.json path_trace.steady):
# the peak is the best steady point, as the sweep itself reports it.
ok['is_steady'] = ok.steady.astype(str).str.lower().isin(['true', '1'])
best = (ok.sort_values(['is_steady', 'steady_rays_shot_per_second', 'clients'], ascending=[True, True, False])
        .groupby(['scene', 'label', 'scheduler']).tail(1).copy())  # equal rates: the fewest clients
best['x'] = best.label.map({l: i for i, l in enumerate(order)})
bound = ok.groupby(['scene', 'label']).compute_bound_rays_shot_per_second.max().reset_index()
bound['x'] = bound.label.map({l: i for i, l in enumerate(order)})
fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
for ax, scene in zip(axes, ['boeing', 'museum']):
    b = bound[bound.scene == scene].sort_values('x')
    ax.plot(b.x, b.compute_bound_rays_shot_per_second, 'k--', lw=1.2, label='compute bound (platform + profile)')
    for s in schedulers_in(ok):
        r = best[(best.scene == scene) & (best.scheduler == s)].sort_values('x')
        ax.plot(r.x, r.steady_rays_shot_per_second, 'o-', color=COLORS[s], label=NAMES[s])
    ax.axhline(50e6, color='0.6', ls=':', lw=1)
    ax.text(0, 52e6, '50 M', color='0.4', fontsize=8)
    ax.set_xticks(range(len(order))); ax.set_xticklabels(order); ax.set_yscale('log')
    ax.set_title(f'{scene}: peak rays shot/s, warm'); ax.set_xlabel('nodes'); ax.grid(alpha=.3)
axes[0].set_ylabel('rays shot / s (each method at its peak over clients)')
axes[1].legend(fontsize=8, loc='lower right')
savefig(fig, 'fig8_peak.png')
cols = ['scene', 'label', 'scheduler', 'clients', 'is_steady', 'steady_rays_shot_per_second', 'share_of_compute_bound', 'cpu_busy',
        'gpu_busy', 'cpu_fetching', 'gpu_fetching', 'lan_utilisation_mean', 'scene_bytes_per_ray', 'sim_speedup']
tab = best.sort_values(['scene', 'x', 'scheduler'])[cols]
print(tab.to_string(index=False, float_format=lambda v: f'{v:.3g}'))""",
"""top = [l for l in order if l in set(ok.label)][-1]  # the most nodes measured (+R in the full run)
cl = ok[ok.label == top]
fig, axes = plt.subplots(1, 2, figsize=(12, 3.8))
for ax, scene in zip(axes, ['boeing', 'museum']):
    for s in schedulers_in(ok):
        r = cl[(cl.scene == scene) & (cl.scheduler == s)].sort_values('clients')
        ax.plot(r.clients, r.steady_rays_shot_per_second, '-', color=COLORS[s], label=NAMES[s])
        ax.plot(r.clients[r.is_steady], r.steady_rays_shot_per_second[r.is_steady], 'o', color=COLORS[s])
        ax.plot(r.clients[~r.is_steady], r.steady_rays_shot_per_second[~r.is_steady], 'o', mfc='white', color=COLORS[s])
    bnd = cl[cl.scene == scene].compute_bound_rays_shot_per_second.max()
    ax.axhline(bnd, color='k', ls='--', lw=1.2, label='compute bound')
    ax.set_xscale('log', base=2); ax.set_yscale('log'); ax.grid(alpha=.3)
    ax.set_title(f'{scene}, {top}: the sweep over clients (open: not steady)'); ax.set_xlabel('clients')
axes[0].set_ylabel('rays shot / s'); axes[1].legend(fontsize=8)
savefig(fig, 'fig8_peak_sweep.png')
b8 = best[best.label == top].set_index(['scene', 'scheduler'])
paper_lan = {'gmb': 87.8, 'budge': 37.1, 'loadanyonce': 39.2}
rows = []
for (scene, s), r in b8.iterrows():
    rows.append({'scene': scene, 'scheduler': s, 'peak clients': r.clients, 'M rays shot/s': r.steady_rays_shot_per_second / 1e6,
                 'of bound': r.share_of_compute_bound, 'CPU busy': r.cpu_busy, 'GPU busy': r.gpu_busy,
                 'CPU fetching': r.cpu_fetching, 'GPU fetching': r.gpu_fetching,
                 'LAN % (paper)': f"{100 * float(r.lan_utilisation_mean or 0):.1f} ({paper_lan.get(s, '-')})",
                 'scene B/visit': r.scene_bytes_per_ray})
print(pd.DataFrame(rows).to_string(index=False, float_format=lambda v: f'{v:.3g}'))
free = ok[ok.label.astype(str).str.endswith('free I/O')][['scene', 'scheduler', 'clients', 'steady_rays_shot_per_second',
                                      'compute_bound_rays_shot_per_second', 'share_of_compute_bound']]
print('\\nThe bound checked against runs: I/O made free, warm')
print(free.to_string(index=False, float_format=lambda v: f'{v:.3g}'))""",
"""ab = load('ablation')
ab['steady_rays_shot_per_second'] = pd.to_numeric(ab.steady_rays_shot_per_second, errors='coerce').fillna(0)
ab = ab[ab.status == 'ok'].copy()
ab['is_steady'] = ab.steady.astype(str).str.lower().isin(['true', '1'])
variants = [v for v in ['every rule', 'without ownership', 'without image-split', 'without completion', 'without batching',
                        'without no-waiting', 'without job-size', 'without room', 'with generation', 'with hold'] if v in set(ab.label)]
bestab = (ab[ab.is_steady].sort_values(['steady_rays_shot_per_second', 'clients'], ascending=[True, False])
          .groupby(['scene', 'label']).tail(1).set_index(['scene', 'label']))
fig, axes = plt.subplots(1, 2, figsize=(12, 3.6))
rows = []
for ax, scene in zip(axes, ['museum', 'boeing']):
    if scene not in set(ab.scene): continue
    full = bestab.steady_rays_shot_per_second.get((scene, 'every rule'), float('nan'))
    vals = [bestab.steady_rays_shot_per_second.get((scene, v), 0.0) for v in variants]
    bars = ax.barh(range(len(variants)), [v / 1e6 for v in vals], color=[COLORS['rayline']] + ['0.6'] * (len(variants) - 1))
    ax.bar_label(bars, labels=[f'{v / 1e6:.2f} M ({v / full:.2f}x)' if full > 0 else f'{v / 1e6:.2f} M' for v in vals], fontsize=7, padding=2)
    ax.set_yticks(range(len(variants))); ax.set_yticklabels(variants, fontsize=8); ax.invert_yaxis()
    ax.set_xlabel('peak rays shot / s (M), steady'); ax.set_title(f'{scene}, {ab[ab.scene == scene].platform.iloc[0]}: each rule off in turn; rule 8, the hold on', fontsize=9)
    ax.set_xlim(0, max(vals) / 1e6 * 1.35 if max(vals) > 0 else 1)
    for v in variants:
        r = bestab.loc[(scene, v)] if (scene, v) in bestab.index else None
        rows.append({'scene': scene, 'variant': v, 'peak clients': r.clients if r is not None else '-',
                     'M rays shot/s': r.steady_rays_shot_per_second / 1e6 if r is not None else float('nan'),
                     'vs every rule': r.steady_rays_shot_per_second / full if r is not None and full > 0 else float('nan'),
                     'CPU busy': r.cpu_busy if r is not None else float('nan'), 'GPU busy': r.gpu_busy if r is not None else float('nan'),
                     'GPU fetching': r.gpu_fetching if r is not None else float('nan'),
                     'LAN %': 100 * float(r.lan_utilisation_mean or 0) if r is not None else float('nan'),
                     'scheduler share': r.scheduler_share if r is not None else float('nan')})
fig.tight_layout()
savefig(fig, 'rayline_ablation.png')
print(pd.DataFrame(rows).to_string(index=False, float_format=lambda v: f'{v:.3g}'))""",
]

NB["02_central_database"] = [
"""df = load('central'); series = load('central', 'central-series'); links = load('central', 'central-links')
REF = 'full copy, warm: reference peak'
labels = [l for l in ['central database on D', 'central database on D, 1 Gb/s NICs', 'full copy on every disk'] if l in set(series.label)]
ref = df[df.label == REF].set_index('scheduler').steady_rays_shot_per_second
runs = df[df.label != REF].set_index(['label', 'scheduler'])
clients = int(df.clients.max())
fig, axes = plt.subplots(1, len(labels), figsize=(6 * len(labels), 4), squeeze=False, sharey=True); axes = axes[0]
rows = []
for label, ax in zip(labels, axes):
    for s in schedulers_in(series):
        r = series[(series.label == label) & (series.scheduler == s)].sort_values('t_s')
        if r.empty: continue
        burst = r.rays_shot_per_second.iloc[0]  # second 1: camera rays that leave the scene without visiting a block
        r = r[r.t_s >= 2]
        sm = r.rays_shot_per_second.rolling(5, min_periods=1).mean()
        ax.plot(r.t_s, sm, color=COLORS[s], label=NAMES[s])
        pk = ref.get(s, float('nan')); top = sm.max()
        t90 = r.t_s[sm >= 0.9 * pk].min() if pk > 0 else float('nan')
        t90_own = r.t_s[sm >= 0.9 * top].min() if top > 0 else float('nan')
        if pk > 0: ax.axhline(pk, color=COLORS[s], ls='--', lw=0.8)
        if t90 == t90: ax.axvline(t90, color=COLORS[s], ls=':', lw=1)
        run = runs.loc[(label, s)] if (label, s) in runs.index else None
        rows.append(dict(setting=label, scheduler=s, warm_peak=pk, time_to_90pct_of_warm_peak_s=t90,
                         top_of_5s_mean=top, time_to_90pct_of_top_s=t90_own, first_second=burst,
                         steady_after_5s=run.steady_rays_shot_per_second if run is not None else float('nan'),
                         last_20s_mean=r.rays_shot_per_second.tail(20).mean()))
    ax.set_yscale('symlog', linthresh=1e4); ax.set_title(f'{label} (Boeing, 8 nodes, {clients} clients, cold)', fontsize=9)
    ax.set_xlabel('simulated time (s)'); ax.grid(alpha=.3)
axes[0].set_ylabel('rays shot/s (5 s mean, from second 2)'); axes[0].legend(fontsize=8)
fig.text(0.5, -0.04, 'dashed: each method\\'s warm steady peak on the full copy at the same clients; dotted: where the 5 s mean first reaches 90 % of it',
         ha='center', fontsize=8)
savefig(fig, 'fig9_central_database.png')
t90 = pd.DataFrame(rows)
print(t90.to_string(index=False, float_format=lambda v: f'{v:.3g}'))""",
"""cen = [l for l in labels if l.startswith('central')]
ws = [w for w in (10, 30, 60, 120) if f'slave_to_slave_share_{w}s' in links.columns]
fig, axes = plt.subplots(1, len(cen), figsize=(7 * len(cen), 3.4), squeeze=False); axes = axes[0]
for ax, lab in zip(axes, cen):
    ss = schedulers_in(links)
    l = links[links.label == lab].set_index('scheduler').reindex(ss)
    for j, w in enumerate(ws):
        bars = ax.bar(np.arange(len(ss)) + (j - (len(ws) - 1) / 2) * 0.8 / len(ws), 100 * l[f'slave_to_slave_share_{w}s'].fillna(0), 0.8 / len(ws),
                      color=[COLORS[s] for s in ss], alpha=0.3 + 0.7 * j / max(1, len(ws) - 1), edgecolor='k', label=f'first {w} s')
        ax.bar_label(bars, labels=[f'{w}s: {100 * v:.0f}%' for v in l[f'slave_to_slave_share_{w}s'].fillna(0)],
                     fontsize=6, rotation=90, padding=2)
    if not (l[[f'slave_to_slave_share_{w}s' for w in ws]].fillna(0).to_numpy() > 0).any():
        ax.text((len(ss) - 1) / 2, 60, 'no scene bytes went slave to slave,\\nfor any method, in any window', ha='center', fontsize=9, color='0.3')
    ax.axhline(31, color='k', ls=':', lw=1); ax.text(len(ss) - 0.6, 32, 'paper, GMB, first 10 s: 31 %', ha='right', fontsize=8)
    ax.set_xticks(range(len(ss))); ax.set_xticklabels([SHORT[s] for s in ss], fontsize=8); ax.legend(fontsize=7)
    ax.set_ylim(0, 100); ax.set_ylabel('% of LAN scene bytes'); ax.set_title(lab + ': slave-to-slave share', fontsize=9)
savefig(fig, 'fig9_slave_to_slave.png')
gb = links[links.label.str.startswith('central')].set_index(['label', 'scheduler'])
tab = pd.concat({f'{w}s': pd.DataFrame({'share %': 100 * gb[f'slave_to_slave_share_{w}s'], 'LAN scene GB': gb[f'scene_lan_bytes_{w}s'] / 1e9,
                                         'out of D GB': gb[f'master_out_bytes_{w}s'] / 1e9}) for w in ws}, axis=1)
print(tab.to_string(float_format=lambda v: f'{v:.3g}'))""",
]

NB["03_workstation"] = [
"""df = load('workstation')
pk = peak(df, ['scene', 'scheduler'])
scenes = sorted(pk.scene.unique())
fig, ax = plt.subplots(figsize=(7, 3.6)); ss = schedulers_in(pk); w = 0.8 / len(ss)
for i, s in enumerate(ss):
    r = pk[pk.scheduler == s].set_index('scene').reindex(scenes)
    xs = np.arange(len(scenes)) + (i - (len(ss) - 1) / 2) * w
    bars = ax.bar(xs, r.steady_rays_per_second.fillna(0), w, color=COLORS[s], label=NAMES[s])
    ax.bar_label(bars, labels=[f'{v / 1e6:.3g} M' if v > 0 else '' for v in r.steady_rays_per_second.fillna(0)], fontsize=7, padding=1)
    mark_failures(ax, xs, r.reset_index(), 1e4, COLORS[s])
ax.set_yscale('log'); ax.set_ylim(bottom=1e4)
ax.set_xticks(range(len(scenes))); ax.set_xticklabels(scenes); ax.set_ylabel('peak rays/s (log)')
ax.legend(fontsize=8, loc='upper center', bbox_to_anchor=(0.5, -0.1), ncol=2, frameon=False)
ax.set_title('one workstation: 16 CPU threads + 4 GPUs, NVMe')
savefig(fig, 'workstation.png')
t = pk.pivot_table(index='scene', columns='scheduler', values='steady_rays_per_second').reindex(columns=ss)
t['gmb vs budge %'] = 100 * (t.gmb / t.budge - 1); t['gmb vs loadanyonce %'] = 100 * (t.gmb / t.loadanyonce - 1)
print(t.to_string(float_format=lambda v: f'{v:.3g}'))
print(df[['scene', 'scheduler', 'clients', 'status', 'steady_rays_per_second', 'busy', 'fetching', 'true_idle', 'ray_jobs', 'ray_jobs_gpu', 'rays_per_ray_job', 'sim_wall_s', 'run_wall_s']].to_string(index=False, float_format=lambda v: f'{v:.3g}'))""",
]

NB["04_horizon_prediction"] = [
"""df = load('horizon')
k = df[df.label == 'horizon']; d = df[df.label == 'depth']
kept = df[df.label == 'depth, failed kept']  # --cancel-failed off: failed predictions' T-jobs still run
scenes = sorted(df.scene.unique())
fig, axes = plt.subplots(1, 3, figsize=(15, 3.8))
for scene, ls in zip(scenes, ['-', '--']):
    for p, c in [('paper-A', 'tab:purple'), ('paper-cluster', 'tab:blue')]:
        r = k[(k.scene == scene) & (k.platform == p)].sort_values('horizon_s')
        axes[0].plot(r.horizon_s, r.steady_rays_per_second, 'o' + ls, color=c, label=f'{scene}, {p}')
        mark_failures(axes[0], r.horizon_s, r, max(1, k.steady_rays_per_second[k.steady_rays_per_second > 0].min() / 3), c)
        axes[2].plot(r.horizon_s, 100 * r.scheduler_share, 'o' + ls, color=c, label=f'{scene}, {p}')
        r2 = d[(d.scene == scene) & (d.platform == p)].sort_values('prediction_depth')
        axes[1].plot(r2.prediction_depth, r2.steady_rays_per_second, 'o' + ls, color=c, label=f'{scene}, {p}')
        r3 = kept[(kept.scene == scene) & (kept.platform == p)].sort_values('prediction_depth')
        if len(r3): axes[1].plot(r3.prediction_depth, r3.steady_rays_per_second, 'x', color=c, ms=8, label=f'{scene}, {p}: failed kept')
for ax in axes: ax.grid(alpha=.3)
axes[0].set_xscale('log'); axes[0].set_yscale('log'); axes[0].set_xlabel('horizon k (s)'); axes[0].set_ylabel('steady rays/s'); axes[0].set_title('GMB throughput vs k')
axes[1].set_yscale('log'); axes[1].set_xlabel('prediction depth'); axes[1].set_title('GMB throughput vs prediction depth (k = 2 s)'); axes[1].set_xticks(sorted(d.prediction_depth.unique()))
axes[2].set_xscale('log'); axes[2].set_xlabel('horizon k (s)'); axes[2].set_ylabel('scheduler wall time / simulated time (%)'); axes[2].set_title('scheduling overhead share')
axes[0].legend(fontsize=7)
savefig(fig, 'horizon_prediction.png')
print(k[['scene', 'platform', 'horizon_s', 'steady_rays_per_second', 'scheduler_share', 'busy', 'fetching', 'true_idle', 'exec_prediction_error']].to_string(index=False, float_format=lambda v: f'{v:.3g}'))
print(pd.concat([d, kept])[['label', 'scene', 'platform', 'prediction_depth', 'steady_rays_per_second', 'prediction_accuracy', 'prediction_ray_accuracy', 'withdrawn_t_jobs', 'scheduler_share']].to_string(index=False, float_format=lambda v: f'{v:.3g}'))""",
]

NB["05_speed_accuracy"] = [
"""df = load('accuracy')
fid = df[df.label.astype(str).str.startswith('seed')]
ref = fid[fid.fidelity == 'replay'].groupby('scene').steady_rays_per_second.mean()
fid = fid.assign(error=(fid.steady_rays_per_second / fid.scene.map(ref) - 1).abs())
g = fid.groupby(['scene', 'fidelity']).agg(wall_s=('sim_wall_s', 'mean'), error=('error', 'mean'), error_max=('error', 'max'),
                                          rays=('steady_rays_per_second', 'mean'), n=('error', 'size')).reset_index()
cost = df[df.label == 'cost-vs-k']
fig, axes = plt.subplots(1, 2, figsize=(12, 4))
mk = {'analytic': 's', 'markov': 'o', 'replay': '^'}
for (scene, f), r in g.set_index(['scene', 'fidelity']).iterrows():
    axes[0].errorbar(r.wall_s, 100 * r.error, yerr=[[0], [100 * (r.error_max - r.error)]], marker=mk[f],
                     color='tab:blue' if scene == 'boeing' else 'tab:red', ls='', capsize=3, label=f'{scene}, {f}')
axes[0].set_xlabel('simulator wall time per run (s)'); axes[0].set_ylabel('|throughput error| vs replay mean (%)')
axes[0].set_title('workload fidelity: cost vs error'); axes[0].legend(fontsize=7); axes[0].grid(alpha=.3)
for p, c in [('paper-A', 'tab:purple'), ('paper-cluster', 'tab:blue')]:
    r = cost[cost.platform == p].sort_values('horizon_s')
    if r.empty: continue
    axes[1].plot(r.scheduler_wall_s, r.steady_rays_per_second, 'o-', color=c, label=p)
    # labels staggered around their points (in order of wall time), so close points stay readable
    offs = [(5, 6), (5, -12), (-34, 6), (-34, -12)]
    for i, (_, x) in enumerate(r.sort_values('scheduler_wall_s').iterrows()):
        axes[1].annotate(f"k={x.horizon_s:g}s", (x.scheduler_wall_s, x.steady_rays_per_second), fontsize=7,
                         textcoords='offset points', xytext=offs[i % len(offs)], color=c)
axes[1].set_xscale('log'); axes[1].set_xlabel('GMB wall time in the run (s)'); axes[1].set_ylabel('steady rays/s')
axes[1].set_title('scheduler cost vs schedule quality (museum, 8 clients)'); axes[1].legend(fontsize=8); axes[1].grid(alpha=.3)
savefig(fig, 'speed_accuracy.png')
print(g.to_string(index=False, float_format=lambda v: f'{v:.3g}'))
print(cost[['platform', 'horizon_s', 'scheduler_wall_s', 'steady_rays_per_second']].to_string(index=False, float_format=lambda v: f'{v:.3g}'))""",
]

NB["06_stability"] = [
"""df = load('stability')
def pan(ax, rows, xcol, title, xlabel, logx=False, xticks=None):
    pos = rows.steady_rays_per_second[rows.steady_rays_per_second > 0]
    floor = max(1.0, pos.min() / 5) if len(pos) else 1.0
    for s in schedulers_in(rows):
        r = rows[rows.scheduler == s].sort_values(xcol)
        if r.empty: continue
        ok = r[(r.status == 'ok') & (r.steady_rays_per_second > 0)]
        ax.plot(ok[xcol], ok.steady_rays_per_second, 'o-', color=COLORS[s], label=NAMES[s])
        mark_failures(ax, r[xcol], r, floor, COLORS[s])
    ax.set_yscale('log'); ax.set_title(title, fontsize=9); ax.set_xlabel(xlabel); ax.grid(alpha=.3)
    if logx: ax.set_xscale('log')
    if xticks is not None: ax.set_xticks(xticks)
fig, axes = plt.subplots(2, 3, figsize=(18, 9)); axes = axes.ravel(); axes[5].axis('off')
fig.subplots_adjust(hspace=0.35, wspace=0.25)
tk = df[df.label == 'tiny k'].copy()
gk = tk[tk.scheduler.isin(['gmb', 'rayline'])]
pan(axes[0], gk, 'horizon_s', 'tiny k: starvation? (A, museum)', 'k (s)', logx=True)
for s in ['budge', 'loadanyonce']:
    r = tk[tk.scheduler == s]
    if len(r) and r.iloc[0].status == 'ok' and r.iloc[0].steady_rays_per_second > 0:
        axes[0].axhline(r.iloc[0].steady_rays_per_second, color=COLORS[s], ls=':', label=NAMES[s] + ' (no k)')
    elif len(r):
        axes[0].text(0.5, 0.1, f'{s}: {r.iloc[0].status}/no rays', transform=axes[0].transAxes, color='red')
mem = df[df.label.astype(str).str.startswith('memory')].copy(); mem['f'] = mem.label.str.extract(r'x([0-9.e-]+)').astype(float)
pan(axes[1], mem, 'f', 'RAM and GPU memory x f (A; clients on a node of their own)', 'memory factor f', logx=True)
lan = df[df.label.astype(str).str.startswith('LAN')].copy(); lan['f'] = lan.label.str.extract(r'x([0-9.e-]+)').astype(float)
pan(axes[2], lan, 'f', 'LAN bandwidth x f (' + str(lan.platform.iloc[0]).split('-lan')[0] + ')', 'LAN factor f', logx=True)
gpu = df[df.label.astype(str).str.startswith('GPU')].copy(); gpu['f'] = gpu.label.str.extract(r'GPU x([0-9.e-]+)').astype(float)
pan(axes[3], gpu, 'f', 'one GPU x f, CPU threads / f (A)', 'GPU speed-up f', logx=True)
cl = df[df.label == 'clients']
pan(axes[4], cl, 'clients', 'many clients (4A, museum)', 'clients', logx=True)
axes[0].legend(fontsize=7, loc='lower right'); axes[0].set_ylabel('steady rays/s'); axes[3].set_ylabel('steady rays/s')
from matplotlib.lines import Line2D
key = [Line2D([], [], color=COLORS[s], marker='o', label=NAMES[s]) for s in schedulers_in(df)]
key.append(Line2D([], [], color='0.5', marker='X', markeredgecolor='red', markersize=10, ls='',
                  label='a run that stalled, failed or traced no rays\\nafter its warm-up (drawn at the floor)'))
axes[5].legend(handles=key, loc='center', fontsize=10, frameon=False, title='every panel')
savefig(fig, 'stability.png')
print(df[['label', 'platform', 'scheduler', 'clients', 'horizon_s', 'status', 'steady_rays_per_second', 'busy', 'fetching',
          'true_idle', 'queued_at_end', 'queue_wait_p95_s', 'oldest_queued_s', 'sim_wall_s']].to_string(index=False, float_format=lambda v: f'{v:.3g}'))""",
]


NB["08_scale"] = [
"""df = load('scale')
df['nodes'] = df.label.astype(int)
if 'simgrid_s' in df.columns:
    df['simgrid_share_of_wall'] = pd.to_numeric(df.simgrid_s, errors='coerce') / df.sim_wall_s
fig, axes = plt.subplots(2, 3, figsize=(15, 7.5))
for row, scene in zip(axes, ['boeing', 'ray-stream']):
    d = df[df.scene == scene]
    for s in schedulers_in(d):
        r = d[(d.scheduler == s) & (d.status == 'ok')].sort_values('nodes')
        row[0].plot(r.nodes, r.sim_speedup, 'o-', color=COLORS[s], label=NAMES[s])
        row[1].plot(r.nodes, 100 * r.scheduler_share, 'o-', color=COLORS[s])
        row[2].plot(r.nodes, r.peak_rss_mb, 'o-', color=COLORS[s])
    row[0].axhline(1, color='k', lw=0.8, ls=':'); row[0].set_ylabel(f'{scene}: simulated / wall')
    row[1].set_ylabel('scheduler wall, % of simulated time'); row[2].set_ylabel('peak RSS (MB)')
    for ax in row:
        ax.set_xscale('log', base=2); ax.set_yscale('log'); ax.grid(alpha=.3); ax.set_xlabel('nodes')
axes[0][0].legend(fontsize=8)
savefig(fig, 'scale.png')
cols = ['scene', 'nodes', 'scheduler', 'status', 'sim_wall_s', 'sim_speedup', 'scheduler_share', 'peak_rss_mb',
        'steady_rays_shot_per_second', 'steady_rays_per_second']
cols += [c for c in ['simgrid_share_of_wall'] if c in df.columns]
print(df.sort_values(['scene', 'scheduler', 'nodes'])[cols].to_string(index=False, float_format=lambda v: f'{v:.3g}'))""",
]


NB["09_validation"] = [
"""df = load('validation')
real = load('validation', 'validation-real')
df['budget_pct'] = (100 * df.budget).round().astype(int)
BOUND = {'replay': 0.10, 'markov': 0.20}
df['bound'] = df.fidelity.map(BOUND)
df['judged'] = df.real_spread < 0.05  # the acceptance bounds hold where the real runs agree within 5 %
df['outside'] = df.judged & ((df.makespan_error.abs() > df.bound) | (df.loads_error.abs() > df.bound))
cols = ['scene', 'budget_pct', 'scheduler', 'fidelity', 'timing', 'real_makespan_s', 'real_spread', 'recorded_makespan_s',
        'sim_makespan_s', 'makespan_error', 'real_loads', 'recorded_loads', 'sim_loads', 'loads_error', 'busy_error',
        'sim_wall_s', 'outside']
print(df[cols].to_string(index=False, float_format=lambda v: f'{v:.3g}'))""",
"""fig, axes = plt.subplots(2, 2, figsize=(13, 8))
mk = {'replay': 'o', 'markov': 's'}
ls = {'platform': '-', 'recorded': '--'}
scenes = list(dict.fromkeys(df.scene))
cmap = dict(zip(scenes, ['tab:blue', 'tab:red', 'tab:green', 'tab:purple']))
for (ax, metric, title) in [(axes[0][0], 'makespan_error', 'frame makespan'), (axes[0][1], 'loads_error', 'block loads')]:
    for (scene, fid, timing), r in df.groupby(['scene', 'fidelity', 'timing']):
        g = r.groupby('budget_pct')[metric].apply(lambda v: v.abs().max()).sort_index()
        ax.plot(g.index, 100 * g.values, marker=mk[fid], ls=ls[timing], color=cmap[scene],
                label=f'{scene}, {fid}, {timing} timing')
    ax.axhline(10, color='k', lw=0.8, ls=':'); ax.axhline(20, color='k', lw=0.8, ls=':')
    ax.set_ylabel(f'|error| of the {title}, worst scheduler (%)'); ax.set_title(title); ax.grid(alpha=.3)
    ax.set_xlabel('memory budget (% of the scene; 100 = in core)'); ax.set_xticks([10, 25, 50, 100])
axes[0][0].legend(fontsize=6)
# speed against accuracy, against the real runs: each twin's wall time (x) and its error (y);
# the real render's own wall time for the same frame as a star on the x axis
for (scene, fid), r in df[df.timing == 'platform'].groupby(['scene', 'fidelity']):
    axes[1][0].scatter(r.sim_wall_s, (100 * r.makespan_error.abs()).clip(lower=0.5), marker=mk[fid], color=cmap[scene],
                       s=18, label=f'{scene}, {fid}')
for scene, r in real.groupby('scene'):
    axes[1][0].scatter(r.makespan_s, [0.5] * len(r), marker='*', color=cmap[scene], s=40, alpha=.5)
axes[1][0].set_xscale('log'); axes[1][0].set_yscale('log')
axes[1][0].set_xlabel('wall time (s): twin (markers), real render (stars)')
axes[1][0].set_ylabel('|makespan error| against the real median (%)'); axes[1][0].grid(alpha=.3)
axes[1][0].legend(fontsize=6)
for (scene, budget), r in real.groupby(['scene', 'budget']):
    spread = r.groupby('scheduler').makespan_s.agg(lambda v: (v.max() - v.min()) / v.median())
    axes[1][1].scatter([100 * budget] * len(spread), 100 * spread.values, color=cmap[scene], s=14)
axes[1][1].axhline(5, color='k', lw=0.8, ls=':')
axes[1][1].set_ylabel('real runs: spread of the makespan (%)'); axes[1][1].set_xlabel('memory budget (%)')
axes[1][1].set_xticks([10, 25, 50, 100])
axes[1][1].grid(alpha=.3)
savefig(fig, 'validation.png')""",
"""rows = []
for (scene, budget, fid, timing), r in df.groupby(['scene', 'budget', 'fidelity', 'timing']):
    ref_col = 'real_makespan_s' if timing == 'platform' else 'recorded_makespan_s'
    real_order = list(r.sort_values(ref_col).scheduler)
    sim_order = list(r.sort_values('sim_makespan_s').scheduler)
    # pairs whose real makespans differ by more than the larger real spread must keep their order
    bad = []
    for i, a in r.iterrows():
        for j, b in r.iterrows():
            if a[ref_col] < b[ref_col] and (b[ref_col] - a[ref_col]) / a[ref_col] > max(a.real_spread, b.real_spread):
                if not a.sim_makespan_s < b.sim_makespan_s:
                    bad.append(f'{a.scheduler}<{b.scheduler}')
    rows.append({'scene': scene, 'budget_pct': round(100 * budget), 'fidelity': fid, 'timing': timing,
                 'real order': ' < '.join(real_order), 'simulated order': ' < '.join(sim_order),
                 'separated pairs reversed': ', '.join(bad) or 'none'})
print(pd.DataFrame(rows).to_string(index=False))
best = []
for scene, r in df[df.timing == 'platform'].groupby('scene'):
    for fid in ['markov', 'replay']:
        x = r[(r.fidelity == fid) & r.judged]
        ok = len(x) > 0 and (x.makespan_error.abs() <= 0.10).all() and (x.loads_error.abs() <= 0.10).all()
        best.append({'scene': scene, 'fidelity': fid, 'judged points': len(x), 'all within 10 %': ok,
                     'median sim wall (s)': r[r.fidelity == fid].sim_wall_s.median()})
print(pd.DataFrame(best).to_string(index=False))""",
]


def prose(name):
    path = os.path.join(HERE, "prose", name + ".md")
    if not os.path.exists(path):
        return [f"# {name}\n\n(prose missing)"]
    return [p.strip() for p in open(path).read().split("\n---\n")]


def main():
    for name, code in NB.items():
        md = prose(name)
        nb = nbf.v4.new_notebook()
        nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
        cells = [nbf.v4.new_markdown_cell(md[0]), nbf.v4.new_code_cell(SETUP)]
        for i, c in enumerate(code):
            if i + 1 < len(md):
                cells.append(nbf.v4.new_markdown_cell(md[i + 1]))
            cells.append(nbf.v4.new_code_cell(c))
        for extra in md[len(code) + 1:]:
            cells.append(nbf.v4.new_markdown_cell(extra))
        nb.cells = cells
        nbf.write(nb, os.path.join(HERE, name + ".ipynb"))
        print("wrote", name + ".ipynb")


if __name__ == "__main__":
    main()
