"""Throughput of vanishing points for N directions, against (a) a per-direction
scipy.optimize.least_squares solver and (b) the straightforward batched route: the
paper's degree-10 polynomial (spurious factor included) for all N directions, its roots
by companion-matrix eigenvalues (np.linalg.eigvals), then the same back-substitution,
polish and checks as ours. All three run in one process, on the same directions."""
from __future__ import annotations

import numpy as np

from catadioptric.rigs import preset
from catadioptric.solvers.constraints import general_resultant
from catadioptric.solvers.general import GeneralSolver

from common import best_time, least_squares_reflection


class EigvalsRoute(GeneralSolver):
    """The straightforward batched route: degree-10 kappa_16 and np.linalg.eigvals."""

    name = "general_eigvals"

    def _candidates(self, h):
        import catadioptric.solvers.general as g

        R, _ = general_resultant(self.A, self.B, self.C, self.c2, self.c3, self.zt, h)
        R = R[:, :11]  # degree 10 in t
        lead = R[:, -1:]
        comp = np.zeros((len(R), 10, 10))
        comp[:, 1:, :-1] = np.eye(9)
        with np.errstate(all="ignore"):
            comp[:, :, -1] = -R[:, :10] / lead
        roots = np.linalg.eigvals(comp)
        real = (np.abs(roots.imag) <= 1e-7 * np.maximum(1.0, np.abs(roots.real))) & (np.abs(roots.real) <= 1.0)
        ridx, k = np.nonzero(real)
        t = roots.real[ridx, k]
        saved = g.roots_in_unit_interval
        calls = []

        def octic_roots_once(Q):  # the octic's roots: these; later calls (the in-plane 1-D problem): unchanged
            calls.append(1)
            return (ridx, t) if len(calls) == 1 else saved(Q)

        g.roots_in_unit_interval = octic_roots_once  # reuse the back-substitution unchanged
        try:
            return super()._candidates(h)
        finally:
            g.roots_in_unit_interval = saved


def run(sizes=(1_000, 10_000, 100_000, 1_000_000), rig="hyperboloid_9pct", n_baseline=200, seed=0):
    cam = preset(rig)
    rng = np.random.default_rng(seed)
    S = rng.normal(size=(max(sizes), 3))
    S /= np.linalg.norm(S, axis=1, keepdims=True)
    m = cam.mirror
    ours = cam.solver
    eig = EigvalsRoute(m.A, m.B, m.C, m.z_min, m.z_max, cam.center, m.scale)
    # the two batched routes find the same vanishing points
    a = ours.solve(S[:2000], 0.0)
    b = eig.solve(S[:2000], 0.0)
    agree = float(np.mean(a.found.sum(1) == b.found.sum(1)))
    t_ls = best_time(lambda: [least_squares_reflection(cam, s, 0.0) for s in S[:n_baseline]], repeat=1)
    ls_rate = n_baseline / t_ls
    rows = []
    for n in sizes:
        rep = 3 if n <= 100_000 else 1
        t_ours = best_time(lambda: cam.vanishing_points(S[:n]), rep)
        t_solver = best_time(lambda: ours.solve_flat(S[:n], 0.0), rep)
        t_eig = best_time(lambda: [eig.solve_flat(S[i:min(i + 65536, n)], 0.0) for i in range(0, n, 65536)], rep)
        rows.append({"n": n, "vanishing_points_per_s": n / t_ours, "solver_per_s": n / t_solver,
                     "eigvals_route_per_s": n / t_eig, "speedup_vs_eigvals_route": t_eig / t_solver,
                     "speedup_vs_least_squares": (n / t_ours) / ls_rate})
        print(f"  N={n:>9,}  vanishing_points {n / t_ours:>11,.0f}/s  (solver {n / t_solver:>11,.0f}/s)  "
              f"eigvals route {n / t_eig:>9,.0f}/s  -> {t_eig / t_solver:5.1f}x;  "
              f"{(n / t_ours) / ls_rate:,.0f}x least_squares", flush=True)
    return {"rig": rig, "solver": ours.name, "least_squares_per_s": ls_rate, "least_squares_directions": n_baseline,
            "routes_agree_fraction": agree, "rows": rows}
