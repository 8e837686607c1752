"""Throughput of back-projection and exact forward projection, against a per-point
scipy.optimize.least_squares baseline run in the same process."""
from __future__ import annotations

import numpy as np

from catadioptric.rigs import preset

from common import best_time, least_squares_reflection


def _points(cam, n, rng):
    out = []
    while sum(len(o) for o in out) < n:
        uv = np.stack([rng.uniform(0, cam.pinhole.width - 1, 2 * n), rng.uniform(0, cam.pinhole.height - 1, 2 * n)], -1)
        rays = cam.backproject(uv)
        ok = rays.valid
        out.append(rays.origins[ok] + rng.uniform(0.5, 20.0, (ok.sum(), 1)) * rays.directions[ok])
    return np.concatenate(out)[:n]


def run(sizes=(1_000, 10_000, 100_000, 1_000_000), rig="hyperboloid_9pct", n_baseline=200, seed=0):
    cam = preset(rig)
    rng = np.random.default_rng(seed)
    P = _points(cam, max(sizes), rng)
    uv = np.stack([rng.uniform(0, 639, max(sizes)), rng.uniform(0, 479, max(sizes))], -1)
    t_ls = best_time(lambda: [least_squares_reflection(cam, p, 1.0) for p in P[:n_baseline]], repeat=1)
    ls_rate = n_baseline / t_ls
    rows = []
    for n in sizes:
        rep = 3 if n <= 100_000 else 1
        tb = best_time(lambda: cam.backproject(uv[:n]), rep)
        tp = best_time(lambda: cam.project(P[:n]), rep)
        rows.append({"n": n, "backproject_per_s": n / tb, "project_per_s": n / tp,
                     "project_vs_least_squares": (n / tp) / ls_rate})
        print(f"  N={n:>9,}  backproject {n / tb:>12,.0f}/s   project {n / tp:>10,.0f}/s   "
              f"= {(n / tp) / ls_rate:,.0f}x least_squares", flush=True)
    return {"rig": rig, "least_squares_per_s": ls_rate, "least_squares_points": n_baseline, "rows": rows}
