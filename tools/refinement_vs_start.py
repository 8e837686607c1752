"""The label path's rotation before and after the two-view refinement, next to the central baseline,
on benchmark pairs with noise (issue 8: on near-central rigs the refinement ends further from the
truth than where it starts).

    .venv/bin/python tools/refinement_vs_start.py hyperboloid 0,1,2,3,4,5 --noise 2 --draws 4

Per draw: the refined rotation's error (``exact``), that of the start (the rotation of the family
directions from each view's planes through its centre, the sign pattern nearest the truth:
``start``), and the central baseline's (``central``); medians at the end. Needs the benchmark's
datasets (render/out/relative_pose_benchmark/datasets).
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from catadioptric.dataset import Dataset
from catadioptric.pose import ViewLines, relative_pose, rotation_angle_deg
from catadioptric.pose.signs import sign_candidates
from catadioptric.validate.observations import line_pixels
from catadioptric.validate.relative_pose import _draw_pixels, central_approximation, central_model_error_px


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config")
    ap.add_argument("pairs", help="comma-separated pair indices (even: Mitsuba, odd: POV-Ray)")
    ap.add_argument("--noise", type=float, default=2.0)
    ap.add_argument("--draws", type=int, default=4)
    ap.add_argument("--data", type=Path, default=Path("render/out/relative_pose_benchmark"))
    args = ap.parse_args()
    rows = []
    with threadpool_limits(1):
        for p in (int(x) for x in args.pairs.split(",")):
            ren = "mitsuba" if p % 2 == 0 else "povray"
            ds = Dataset(str(args.data / "datasets" / f"{args.config}_{ren}"))
            va, vb = ds[f"p{p:02d}A"], ds[f"p{p:02d}B"]
            R_gt = vb["pose"].R @ va["pose"].R.T
            cams = (va["camera"], vb["camera"])
            base = [line_pixels(v, pixels="curve", min_pixels=30) for v in (va, vb)]
            uni = [central_approximation(c) for c in cams]
            model_px = max(central_model_error_px(c) for c in cams)
            for k in range(args.draws):
                rng = np.random.default_rng([p, int(args.noise * 1000), k])
                uvs = [_draw_pixels(b, rng, args.noise, 1000) for b in base]
                r = {}
                for label, cp in (("exact", cams), ("central", uni)):
                    views = [ViewLines(c, u, b.family, b.segment) for c, u, b in zip(cp, uvs, base)]
                    res = relative_pose(views[0], views[1], seed=k, max_pixels=1000,
                                        model_error_px=model_px if label == "central" else 0.0)
                    r[label] = rotation_angle_deg(res.R @ R_gt.T)
                    if label == "exact":
                        ea, eb = res.estimates
                        a = np.array([ea[f].direction for f in res.families])
                        b = np.array([eb[f].direction for f in res.families])
                        Ca = np.array([ea[f].cov for f in res.families])
                        Cb = np.array([eb[f].cov for f in res.families])
                        r["start"] = min(rotation_angle_deg(c.R @ R_gt.T) for c in sign_candidates(a, b, Ca, Cb))
                rows.append(r)
                print(f"p{p:02d} draw {k}: " + ", ".join(f"{n} {v:.3f}" for n, v in r.items()), flush=True)
    for n in ("exact", "start", "central"):
        print(f"{n}: median {np.median([r[n] for r in rows]):.3f} deg over {len(rows)} draws")


if __name__ == "__main__":
    main()
