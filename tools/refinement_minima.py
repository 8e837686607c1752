"""The two-view refinement of one benchmark draw started two ways, scored by the truth (issue 8:
on near-central rigs the refinement lands in minima whose rotation is worse than the central
baseline's; docs/relative_pose.md, "Where the refinement ends on near-central rigs").

    .venv/bin/python tools/refinement_minima.py hyperboloid 4 0

For pair ``PAIR`` (even: Mitsuba, odd: POV-Ray) of ``CONFIG`` and noise draw ``DRAW`` (the
benchmark's seeds, every pixel of each line, ``--noise`` px), the label path's answer
(:func:`catadioptric.pose.relative_pose`) and the refinement it ran, then
:func:`catadioptric.pose.bundle.refine_two_view` on the same pixels

* ``restart``: from its own answer (each restart begins a fresh robust stage, so the costs of
  restarts compare with each other; the first run's cost is its robust stage's, before its
  polish),
* ``truth``: from the true pose, the true family directions and the true lines,

each ``--restarts`` times, with a tight stop (``--tol``). Printed: rotation error, robust cost
(chi-square units), baseline against the truth; per line, where it is seen, its distance from
view A's centre in the two minima and the truth. Needs the benchmark's datasets
(render/out/relative_pose_benchmark/datasets).
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

import catadioptric.pose.relative as relative
from catadioptric.dataset import Dataset
from catadioptric.linefit.distances import _closest_depths, _depth_refine
from catadioptric.pose import ViewLines, relative_pose, rotation_angle_deg
from catadioptric.pose.bundle import refine_two_view
from catadioptric.validate.observations import line_pixels
from catadioptric.validate.relative_pose import _draw_pixels


def _median_px(cam, uv, q, s) -> float:
    """Median pixel distance of ``uv`` from the image of the line through ``q`` along ``s``."""
    r = cam.backproject(uv)
    Q, S = np.tile(q, (len(uv), 1)), np.tile(s, (len(uv), 1))
    lam0 = _closest_depths(Q, S, np.nan_to_num(r.origins), np.nan_to_num(r.directions))
    return float(np.nanmedian(_depth_refine(cam, Q, S, uv, lam0, iters=5)[1]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config")
    ap.add_argument("pair", type=int)
    ap.add_argument("draw", type=int)
    ap.add_argument("--noise", type=float, default=2.0)
    ap.add_argument("--restarts", type=int, default=2)
    ap.add_argument("--tol", type=float, default=1e-6, help="tol_chi2 of the restarts")
    ap.add_argument("--data", type=Path, default=Path("render/out/relative_pose_benchmark"))
    args = ap.parse_args()
    ren = "mitsuba" if args.pair % 2 == 0 else "povray"
    ds = Dataset(str(args.data / "datasets" / f"{args.config}_{ren}"))
    va, vb = ds[f"p{args.pair:02d}A"], ds[f"p{args.pair:02d}B"]
    R_gt = vb["pose"].R @ va["pose"].R.T
    t_gt = vb["pose"].t - R_gt @ va["pose"].t
    cams = (va["camera"], vb["camera"])
    base = [line_pixels(v, pixels="curve", min_pixels=30) for v in (va, vb)]
    rng = np.random.default_rng([args.pair, int(args.noise * 1000), args.draw])
    uvs = [_draw_pixels(b, rng, args.noise, 1000) for b in base]
    views = [ViewLines(c, u, b.family, b.segment) for c, u, b in zip(cams, uvs, base)]

    calls = []  # every refinement relative_pose runs: (args, kwargs, fit)

    def recorded(*a, **kw):
        fit = refine_two_view(*a, **kw)
        calls.append((a, kw, fit))
        return fit

    relative.refine_two_view = recorded
    try:
        with threadpool_limits(1):
            res = relative_pose(views[0], views[1], seed=args.draw, max_pixels=1000)
    finally:
        relative.refine_two_view = refine_two_view
    a, kw, fit = min(calls, key=lambda c: c[2].cost)
    cam_a, cam_b, R0, t0, dirs0, points0, fam, uv_a, own_a, uv_b, own_b = a
    kw = dict(kw, tol_chi2=args.tol, max_iter=300)
    c_a, c_b = kw["centres"]
    baseline = lambda f: float(np.linalg.norm(f.R @ c_a + f.t - c_b))
    print(f"{args.config} p{args.pair:02d} draw {args.draw}, {args.noise} px: answer {rotation_angle_deg(res.R @ R_gt.T):.3f} "
          f"deg; refinement from stage 1 ({rotation_angle_deg(R0 @ R_gt.T):.3f} deg): {rotation_angle_deg(fit.R @ R_gt.T):.3f} "
          f"deg, robust cost {fit.cost:.1f}, baseline {baseline(fit):.2f} m (true {np.linalg.norm(R_gt @ c_a + t_gt - c_b):.2f})")

    # the true lines in A's mirror frame: per line, the labelled segment (parallel to its family) whose
    # image is nearest a few of its pixels
    RA, tA = va["pose"].R, va["pose"].t
    segs = []
    for ln in va["lines"]:
        e = np.array(ln["ends_W"]) @ RA.T + tA
        s = (e[1] - e[0]) / np.linalg.norm(e[1] - e[0])
        segs.append((e[0], s))
    true_dirs, true_pts = np.zeros_like(dirs0), np.zeros_like(points0)
    for li in range(len(points0)):
        seen_a = own_a == li
        cam, uv, Rv, tv = (cam_a, uv_a[seen_a], np.eye(3), np.zeros(3)) if seen_a.any() else \
            (cam_b, uv_b[own_b == li], R_gt, t_gt)
        uv = uv[np.linspace(0, len(uv) - 1, 8).astype(int)]
        cands = [(q, s) for q, s in segs if abs(s @ dirs0[fam[li]]) > np.cos(np.radians(10))]
        q, s = min(cands, key=lambda c: _median_px(cam, uv, Rv @ c[0] + tv, Rv @ c[1]))
        s = s if s @ dirs0[fam[li]] >= 0 else -s
        true_pts[li] = q - (q @ s) * s
        true_dirs[fam[li]] = s

    ends = {}
    with threadpool_limits(1):
        for label, start in (("restart", (fit.R, fit.t, fit.directions, fit.points)),
                             ("truth", (R_gt, t_gt, true_dirs, true_pts))):
            f = None
            for k in range(args.restarts):
                R_, t_, d_, p_ = start if f is None else (f.R, f.t, f.directions, f.points)
                f = refine_two_view(cam_a, cam_b, R_, t_, d_, p_, fam, uv_a, own_a, uv_b, own_b, **kw)
                print(f"  from {label:7s} run {k}: rotation {rotation_angle_deg(f.R @ R_gt.T):.3f} deg, robust cost "
                      f"{f.cost:.1f}, baseline {baseline(f):.2f} m, {f.iterations} steps")
            ends[label] = f
    dir_err = lambda f, i: np.degrees(np.arccos(min(1.0, abs(f.directions[i] @ true_dirs[i]))))
    for i in range(len(dirs0)):
        print(f"  family {i}: direction error {dir_err(ends['restart'], i):.3f} deg (restart), "
              f"{dir_err(ends['truth'], i):.3f} (truth)")
    print("  line family seen | distance from c_A (m): restart truth true")
    for li in range(len(points0)):
        seen = ("A" if (own_a == li).any() else "") + ("B" if (own_b == li).any() else "")
        d = [np.linalg.norm(p - c_a) for p in (ends["restart"].points[li], ends["truth"].points[li], true_pts[li])]
        print(f"  {li:4d} {fam[li]:6d} {seen:4s} | {d[0]:10.3g} {d[1]:10.3g} {d[2]:8.3g}")


if __name__ == "__main__":
    main()
