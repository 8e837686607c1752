"""Throughput of back-projection and exact forward projection, against a per-point
scipy.optimize.least_squares baseline run in the same process."""
from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from catadioptric.rigs import preset

from common import best_time


def _points(cam, n, rng):
    out = []
    while sum(len(o) for o in out) < n:
        uv = np.stack([rng.uniform(0, cam.pinhole.width - 1, 2 * n), rng.uniform(0, cam.pinhole.height - 1, 2 * n)], -1)
        rays = cam.backproject(uv)
        ok = rays.valid
        out.append(rays.origins[ok] + rng.uniform(0.5, 20.0, (ok.sum(), 1)) * rays.directions[ok])
    return np.concatenate(out)[:n]


def least_squares_project(cam, p):
    """One reflection point of ``p`` by nonlinear least squares from the middle of the patch."""
    m = cam.mirror
    c = cam.center
    z0 = 0.5 * (m.z_min + m.z_max)
    r0 = np.array([0.0, 0.0, z0])
    rho = np.sqrt(max(float(m.radius_squared(z0)), 0.0))
    if rho > 0:  # start on the side facing the point
        az = np.arctan2(p[1], p[0])
        r0[:2] = rho * np.cos(az), rho * np.sin(az)
    L = m.scale

    def f(x):
        r = x * L
        n = m.normal(r)
        n = n / np.linalg.norm(n)
        i = (r - c) / np.linalg.norm(r - c)
        d = i - 2 * (i @ n) * n
        o = (p - r) / np.linalg.norm(p - r)
        return np.r_[d - o, m.implicit(r) / L**2]

    sol = least_squares(f, r0 / L, xtol=1e-14, ftol=1e-14, gtol=1e-14)
    return sol.x * L


def run(sizes=(1_000, 10_000, 100_000, 1_000_000), rig="hyperboloid_9pct", n_baseline=200, seed=0):
    cam = preset(rig)
    rng = np.random.default_rng(seed)
    P = _points(cam, max(sizes), rng)
    uv = np.stack([rng.uniform(0, 639, max(sizes)), rng.uniform(0, 479, max(sizes))], -1)
    t_ls = best_time(lambda: [least_squares_project(cam, p) for p in P[:n_baseline]], repeat=1)
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
