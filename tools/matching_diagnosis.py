"""How the matching without labels fares on the relative-pose benchmark's detections, scored by the
labels (docs/relative_pose.md, "What the matching finds").

For each ``CONFIG:PAIR`` (e.g. ``hyperboloid:8``): the lines detected in both beauty images, each
identified by the labelled segment that holds most of its pixels; the lines matched under the
assignments whose rotation is within 2 degrees of the truth, and how many are right; the true
corners (two detected lines of different families whose segments pass within 5 cm in 3-D, seen
in both views), with their epipolar residual under the true pose over its propagated deviation
and the rank of B's ray among the candidates of the same two families.

    .venv/bin/python tools/matching_diagnosis.py hyperboloid:8 sphere:7 hyperboloid:14

Needs the benchmark's datasets (render/out/relative_pose_benchmark/datasets; README, "relative
pose benchmark").
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from catadioptric.dataset import Dataset
from catadioptric.detect import detect_lines
from catadioptric.detect.evaluate import _match_lines, visible_curves
from catadioptric.pose import relative_pose, rotation_angle_deg
from catadioptric.pose import matching
from catadioptric.pose.central import _depths, _rad_per_px, _residual_weights, _residuals2
from catadioptric.pose.families import fit_view_families, rays_centre

DATA = Path("render/out/relative_pose_benchmark")


def _gap(ends, s1, s2):
    """Distance between the 3-D lines of segments ``s1`` and ``s2``."""
    a0, a1 = ends[s1]
    b0, b1 = ends[s2]
    n = np.cross(a1 - a0, b1 - b0)
    if np.linalg.norm(n) < 1e-12:
        return np.inf
    return abs((a0 - b0) @ n) / np.linalg.norm(n)


def diagnose(config: str, pair: int, data: Path = DATA) -> None:
    renderer = json.loads((data / "results_images" / config / f"p{pair:02d}.json").read_text())["renderer"] \
        if (data / "results_images" / config / f"p{pair:02d}.json").exists() else ("mitsuba" if pair % 2 == 0 else "povray")
    ds = Dataset(str(data / "datasets" / f"{config}_{renderer}"))
    names = (f"p{pair:02d}A", f"p{pair:02d}B")
    va, vb = ds[names[0]], ds[names[1]]
    R_gt = vb["pose"].R @ va["pose"].R.T
    t_gt = vb["pose"].t - R_gt @ va["pose"].t
    views = [detect_lines(v["beauty"], v["camera"]).to_view_lines(min_pixels=30) for v in (va, vb)]
    segs = []
    for v, name in zip(views, names):
        vis = visible_curves(ds[name])
        match, _ = _match_lines(list(v.uv), vis, 1.5, 0.5)
        segs.append([vis[k]["segment"] if k >= 0 else None for k in match])
    in_fam = [{s for s, f in zip(sg, v.family) if s is not None and f is not None and f >= 0}
              for sg, v in zip(segs, views)]
    captured = []
    original = matching.match_lines

    def spy(view_a, view_b, ea, eb, m, **kw):
        lm = original(view_a, view_b, ea, eb, m, **kw)
        captured.append((m, lm))
        return lm

    matching.match_lines = spy
    try:
        res = relative_pose(views[0], views[1], max_rotation_deg=60.0)
    finally:
        matching.match_lines = original
    print(f"== {config} p{pair:02d} ({renderer}): lines in families A {len(in_fam[0])}, B {len(in_fam[1])}, seen in "
          f"both {len(in_fam[0] & in_fam[1])}; answer {rotation_angle_deg(res.R @ R_gt.T):.2f} deg off, margin "
          f"{res.margin:.1f}")
    for m, lm in captured:
        if rotation_angle_deg(m.R @ R_gt.T) >= 2.0:
            continue
        right = sum(1 for a, b in lm.pairs if segs[0][a] is not None and segs[0][a] == segs[1][b])
        print(f"   right-rotation assignment {m.mapping}: {len(lm.pairs)} lines matched, {right} right; "
              f"{lm.n_inliers} of {lm.n_crossings} meeting points verified")
    # true corners under the true pose
    ea, _ = fit_view_families(views[0], exact=False)
    eb, _ = fit_view_families(views[1], exact=False)
    m = min(matching.family_matches(ea, eb, max_rotation_deg=60.0), key=lambda m: rotation_angle_deg(m.R @ R_gt.T))
    xa, la, pa = matching._crossings(views[0], ea, {k: k for k in ea})
    xb, lb, pb = matching._crossings(views[1], eb, {b: a for b, (a, _) in m.mapping.items()})
    T = R_gt @ rays_centre(va["camera"]) + t_gt - rays_centre(vb["camera"])
    T /= np.linalg.norm(T)
    floor = 0.5 * max(_rad_per_px(views[0].cam), _rad_per_px(views[1].cam))
    ends = {int(ln["index"]): np.asarray(ln["ends_W"], float) for ln in va["lines"]}
    b_of = {}
    for j, (l1, l2) in enumerate(lb):
        if segs[1][l1] is not None and segs[1][l2] is not None:
            b_of[(segs[1][l1], segs[1][l2])] = b_of[(segs[1][l2], segs[1][l1])] = j
    iso = lambda x: floor**2 * (np.eye(3) - x[:, :, None] * x[:, None, :])
    n = 0
    for i, (l1, l2) in enumerate(la):
        key = (segs[0][l1], segs[0][l2])
        j = b_of.get(key)
        if j is None or _gap(ends, *key) > 0.05:
            continue
        n += 1
        P, Q = (R_gt @ xa[i])[None], xb[j][None]
        A = np.cross(P, Q)
        A /= np.linalg.norm(A)
        W, _ = _residual_weights(P, Q, iso(P), iso(Q), floor)
        r = float(np.sqrt(_residuals2(A, T[None], 0.0, W)[0, 0]))
        _, _, pq = _depths(P, Q, T[None])
        same = [k for k in range(len(xb)) if pb[k] == pa[i]]
        rank = int(np.sum(xb[same] @ P[0] > xb[j] @ P[0]))
        print(f"   true corner: residual {r:.2f} deviations, parallax {np.degrees(np.arccos(np.clip(pq[0], -1, 1))):.1f} "
              f"deg, rank {rank} of {len(same)} candidates")
    print(f"   true corners: {n}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pairs", nargs="+", help="CONFIG:PAIR, e.g. hyperboloid:8")
    ap.add_argument("--data", type=Path, default=DATA)
    args = ap.parse_args()
    for p in args.pairs:
        config, pair = p.split(":")
        diagnose(config, int(pair), args.data)


if __name__ == "__main__":
    main()
