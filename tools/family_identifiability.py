"""Which of the label path's families one image can tell apart by direction at all (issue 9: the
image path recovers the label path's families in 14 of the benchmark's 100 pairs).

A line's image fixes the plane holding its rays; its direction is only known to lie in that
plane. A line whose plane holds the direction of another family of the scene as well (a
horizontal line near the rig's height lies in a nearly horizontal plane, which holds every
horizontal direction; a marking straight ahead along the rig's path lies in a vertical plane,
which holds the vertical too) agrees with both, and no grouping by direction can say which it
belongs to: the detector leaves such lines unassigned (docs/detect.md), or they blend two
families. This tool takes every labelled line of the benchmark's views (the exact curve's
pixels, as the label path's), fits its plane (``linefit.planes``, first-order covariance at
``--sigma`` pixels, the detector's typical distance to the label curve), and tests it against
the direction of every true family the view has labelled lines of, as the detector's vote does
(``detect.families``: chi-square ``(n . s)^2 / (s^T C s + sin(0.1 deg)^2) <= 9``). A line
*identifies* its family when it agrees with it and with no other. A family of the label path
(two or more lines of ``--min-pixels`` in each view, ``families_label`` of the benchmark) is
*identifiable* in a view when at least ``--lines`` of its lines identify it there.

    .venv/bin/python tools/family_identifiability.py [--configs sphere,...] [--pairs 20] [--json OUT]

Prints per configuration: label families, those identifiable in both views, the pairs whose
every label family is (an upper bound for the image path's "same families" by any grouping by
direction, one view at a time), and the lines that agree with two or more families. Labels and
geometry only: no detection, a few seconds per view. Needs the benchmark's datasets.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from catadioptric._io import atomic_write_json
from catadioptric.dataset import Dataset
from catadioptric.detect.evaluate import label_curves
from catadioptric.linefit.planes import pixel_rays_with_jacobian, plane_covariance, refine_plane
from catadioptric.validate.benchmark_spec import load_benchmark_spec, pairs_of


def view_lines(view, min_pixels: int, sigma: float, chi2_max: float = 9.0, floor_deg: float = 0.1) -> list[dict]:
    """Each labelled line of at least ``min_pixels`` pixels: its family and the true families it
    agrees with."""
    dirs = {int(f["index"]): np.asarray(f["direction_M"], float) for f in view["families"]}
    lines = [t for t in label_curves(view) if len(t["uv"]) >= min_pixels]
    present = sorted({t["family"] for t in lines})
    S = np.array([dirs[f] for f in present])
    floor2 = np.sin(np.radians(floor_deg)) ** 2
    out = []
    for t in lines:
        rays = pixel_rays_with_jacobian(view["camera"], t["uv"])
        if rays.ok.sum() < 3:
            continue
        n = refine_plane(rays)
        C = plane_covariance(n, rays, sigma)
        chi2 = (S @ n) ** 2 / (np.einsum("hi,ij,hj->h", S, C, S) + floor2)
        out.append({"segment": t["segment"], "family": t["family"], "pixels": len(t["uv"]),
                    "agrees": [f for f, c in zip(present, chi2) if c <= chi2_max],
                    "chi2_own": float(chi2[present.index(t["family"])])})
    return out


def pair_row(ds, names, min_pixels, sigma, need) -> dict:
    per_view = [view_lines(ds[n], min_pixels, sigma) for n in names]
    count = [{} for _ in names]
    ident = [{} for _ in names]
    for k, lines in enumerate(per_view):
        for ln in lines:
            count[k][ln["family"]] = count[k].get(ln["family"], 0) + 1
            if ln["agrees"] == [ln["family"]]:
                ident[k][ln["family"]] = ident[k].get(ln["family"], 0) + 1
    label = sorted(f for f in count[0] if count[0][f] >= 2 and count[1].get(f, 0) >= 2)
    ok = [f for f in label if all(ident[k].get(f, 0) >= need for k in range(2))]
    shared = [sum(1 for ln in lines if len(ln["agrees"]) > 1) for lines in per_view]
    own_off = [sum(1 for ln in lines if ln["family"] not in ln["agrees"]) for lines in per_view]
    return {"families_label": label, "identifiable": ok,
            "not_identifiable": {str(f): [ident[k].get(f, 0) for k in range(2)] for f in label if f not in ok},
            "lines": [len(v) for v in per_view], "lines_agreeing_with_several": shared,
            "lines_off_own_family": own_off}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--configs", default="sphere,ellipsoid,hyperboloid,hyperboloid_central,hyperboloid_9pct")
    ap.add_argument("--pairs", type=int, default=20)
    ap.add_argument("--spec", default="validate/relative_pose.toml")
    ap.add_argument("--data", default="render/out/relative_pose_benchmark")
    ap.add_argument("--sigma", type=float, default=0.5, help="pixel noise of each line's plane fit")
    ap.add_argument("--lines", type=int, default=2, help="lines that must identify a family in each view")
    ap.add_argument("--json", help="write the rows here")
    ap.add_argument("--from-json", help="print the table from these rows instead of computing them")
    args = ap.parse_args()
    if args.from_json:
        rows = json.loads(Path(args.from_json).read_text())
    else:
        spec = load_benchmark_spec(args.spec)
        rows = []
        for c in spec["configs"]:
            if c["name"] not in args.configs.split(","):
                continue
            for p in pairs_of(spec, c)[:args.pairs]:
                ds = Dataset(str(Path(args.data) / "datasets" / f"{c['name']}_{p.renderer}"))
                r = pair_row(ds, p.names, spec["min_pixels"], args.sigma, args.lines)
                rows.append({"config": c["name"], "pair": p.index, "renderer": p.renderer, **r})
        if args.json:
            atomic_write_json(args.json, rows)
    print(f"| configuration | pairs | label families | identifiable in both views | pairs with every label family "
          f"identifiable | lines agreeing with 2+ families (share) |")
    print("|---|---|---|---|---|---|")
    for name in dict.fromkeys(r["config"] for r in rows):
        cell = [r for r in rows if r["config"] == name]
        nl = sum(len(r["families_label"]) for r in cell)
        ni = sum(len(r["identifiable"]) for r in cell)
        npairs = sum(len(r["identifiable"]) == len(r["families_label"]) for r in cell)
        sh = sum(sum(r["lines_agreeing_with_several"]) for r in cell)
        tot = sum(sum(r["lines"]) for r in cell)
        print(f"| {name} | {len(cell)} | {nl} | {ni} | {npairs} | {sh} of {tot} ({sh / max(tot, 1):.0%}) |")
    nl = sum(len(r["families_label"]) for r in rows)
    ni = sum(len(r["identifiable"]) for r in rows)
    npairs = sum(len(r["identifiable"]) == len(r["families_label"]) for r in rows)
    print(f"| all | {len(rows)} | {nl} | {ni} | {npairs} | |")


if __name__ == "__main__":
    main()
