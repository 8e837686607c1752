"""The label families the image path found in both views but left out of its answer ("not
matched" in ``families_lost``), and why (issue 9; docs/relative_pose.md, "What the images could
give").

    .venv/bin/python tools/not_matched.py [--results render/out/relative_pose_benchmark/results_images] \\
        [--prior 60] [--workers 2]

For every such family of the committed results (the run with ``--prior``), both views are
detected again and the pose estimated as the benchmark does (:func:`catadioptric.twoview.
pose_from_detections`). For each detected family that is the true family by its lines in A and in
B (``members_family`` of :func:`catadioptric.detect.evaluate_view`), prints: whether the estimator
could fit it (``fit_view_families``: a family with fewer than two lines that fit is not used), the
angle between A's direction turned by the *true* rotation and B's, against the tolerance the
family matching allows (``pose.matching``: 3 standard deviations of each, with its 0.3-degree
floor, plus a degree), and the candidates of the answer that map B's family to A's, with their
rotation error and cost against the answer's. Needs the benchmark's datasets.
"""
from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np


def _cases(results, prior):
    out = []
    for p in sorted(Path(results).glob("*/p*.json")):
        r = json.loads(p.read_text())
        run = next((x for x in r["runs"] if x["max_rotation_deg"] == prior), None)
        for x in (run or {}).get("families_lost", []):
            if x["cause"] == "not matched":
                out.append((str(Path(results).parent), r["config"], r["pair"], r["renderer"], x["family"], r["views"]))
    return out


def _case(args):
    from threadpoolctl import threadpool_limits

    from catadioptric.dataset import Dataset
    from catadioptric.detect import detect_lines, evaluate_view
    from catadioptric.pose import rotation_angle_deg
    from catadioptric.pose.families import fit_view_families
    from catadioptric.pose.matching import _floored, _sd
    from catadioptric.twoview import pose_from_detections

    data, config, pair, renderer, fam, names, prior = args
    ds = Dataset(Path(data, "datasets", f"{config}_{renderer}"))
    va, vb = ds[names[0]], ds[names[1]]
    R_gt = vb["pose"].R @ va["pose"].R.T
    out = [f"{config} p{pair:02d} {renderer}, true family {fam}"]
    with threadpool_limits(1):
        dets = [detect_lines(v["beauty"], v["camera"]) for v in (va, vb)]
        res = pose_from_detections(dets[0], dets[1], max_rotation_deg=prior).pose
        # the families as the first estimate sees them (the detections before any joint family)
        members = [[m["members_family"] for m in evaluate_view(d, v)["families_detected"]]
                   for d, v in zip(dets, (va, vb))]
        fits = [fit_view_families(d.to_view_lines(min_pixels=30), seed=0, exact=False) for d in dets]
    ia = [i for i, t in enumerate(members[0]) if t == fam]
    ib = [i for i, t in enumerate(members[1]) if t == fam]
    out.append(f"  the answer: {rotation_angle_deg(res.R @ R_gt.T):.3f} deg off, "
               f"{'ambiguous' if res.ambiguous else 'decisive'}, margin {res.margin:.1f}; detected families that are "
               f"it by their lines: A {ia}, B {ib}")
    fl = np.radians(0.3)
    for a in ia:
        for b in ib:
            ea, eb = fits[0][0].get(a), fits[1][0].get(b)
            if ea is None or eb is None:
                why = fits[0][1].get(a) if ea is None else fits[1][1].get(b)
                out.append(f"  A{a} / B{b}: not used by the estimator ({why})")
                continue
            ang = np.degrees(np.arccos(min(1.0, abs((R_gt @ ea.direction) @ eb.direction))))
            tol = np.degrees(3 * (_sd(_floored(ea.cov, ea.direction, fl)) + _sd(_floored(eb.cov, eb.direction, fl)))) + 1
            cands = [(k, c) for k, c in enumerate(res.candidates) if c.signs.get(str(b), (None,))[0] == str(a)]
            best = "; ".join(f"candidate {k}: {rotation_angle_deg(c.R @ R_gt.T):.2f} deg off, cost "
                             f"{c.cost - res.candidates[0].cost:+.1f} over the answer's" for k, c in cands[:2])
            out.append(f"  A{a} ({len(dets[0].families[a].lines)} lines) / B{b} ({len(dets[1].families[b].lines)} "
                       f"lines): {ang:.2f} deg apart under the true rotation, tolerance {tol:.2f}; "
                       f"{len(cands)} of {len(res.candidates)} candidates map them" + (f" ({best})" if best else ""))
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", default="render/out/relative_pose_benchmark/results_images")
    ap.add_argument("--prior", type=float, default=60.0)
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args()
    cases = [(*c, args.prior) for c in _cases(args.results, args.prior)]
    print(f"{len(cases)} label families found in both views and not matched (prior {args.prior:g})")
    with ProcessPoolExecutor(args.workers) as ex:
        for text in ex.map(_case, cases):
            print(text, flush=True)


if __name__ == "__main__":
    main()
