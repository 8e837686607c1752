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

**Significance.** Two lines that identify a family are not yet a family a vote can find: any two
planes meet along some direction, so the detector's vote (``detect.families``) asks that a family's
lines be unlikely to agree by chance, a-contrario: ``log NFA <= -4`` over the lines still free, with
three lines or more it can assign (agreeing with that family alone, a band of agreement at most 2
degrees wide); the joint vote of the two views (``detect.joint_families``) asks ``log NFA <= -6``
over *distinct* planes (a segment seen in both views counts once: its two planes nearly coincide)
and two such lines in each view. This tool gives that vote every advantage: the labelled lines
whole (every line of 20 pixels or more, the detector's search lines), the true directions as its
hypotheses, no other edges; every line that agrees with a direction counts for it, whatever its
family (the vote cannot tell). ``own``: each family with only the lines that agree with it free
(no vote can do better); ``seq``: the vote's sequence, every labelled line free at first, the
most significant family taken first and the lines that agree with it taken out, then the joint
vote over the lines of no family found in both views. A pair counts when every label family (or every one with three
lines or more in each view, ``families_label_3``) is found one view at a time or both at once. The
bars can be changed (``--max-log-nfa``, ``--joint-max-log-nfa``) to see what a laxer vote, which
also finds more families that are not there, could reach; ``--systematic 0.15`` adds the
detector's error that does not average out along a line.

    .venv/bin/python tools/family_identifiability.py [--configs sphere,...] [--pairs 20] [--json OUT]

Prints per configuration: label families, those identifiable in both views, the pairs whose
every label family is (an upper bound for the image path's "same families" by any grouping by
direction, one view at a time), and the lines that agree with two or more families; then the
significance table. Labels and geometry only: no detection, a few seconds per view. Needs the
benchmark's datasets.
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


def view_lines(view, min_pixels: int, sigma: float, chi2_max: float = 9.0, floor_deg: float = 0.1,
               systematic_px: float = 0.0) -> list[dict]:
    """Each labelled line of at least ``min_pixels`` pixels: its family, the true families it
    agrees with, and the width of its band of agreement about each family's direction
    (``bands``, radians: ``sqrt(chi2_max (s^T C s + floor^2))``, the detector's vote, ``detect.families``).
    ``systematic_px``: the detector's error that does not average out along a line
    (``detect.curves.line_covariance``)."""
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
        if systematic_px > 0:
            C = C + plane_covariance(n, rays, systematic_px) * (int(rays.ok.sum()) / 2.0)
        var = np.einsum("hi,ij,hj->h", S, C, S) + floor2
        chi2 = (S @ n) ** 2 / var
        out.append({"segment": t["segment"], "family": t["family"], "pixels": len(t["uv"]),
                    "agrees": [f for f, c in zip(present, chi2) if c <= chi2_max],
                    "chi2_own": float(chi2[present.index(t["family"])]),
                    "bands": {f: float(np.sqrt(chi2_max * v)) for f, v in zip(present, var)}})
    return out


def pair_row(ds, names, min_pixels, sigma, need, search_pixels=20, systematic_px=0.0) -> dict:
    per_view = [view_lines(ds[n], search_pixels, sigma, systematic_px=systematic_px) for n in names]
    long_ = [[ln for ln in lines if ln["pixels"] >= min_pixels] for lines in per_view]
    count = [{} for _ in names]
    ident = [{} for _ in names]
    for k, lines in enumerate(long_):
        for ln in lines:
            count[k][ln["family"]] = count[k].get(ln["family"], 0) + 1
            if ln["agrees"] == [ln["family"]]:
                ident[k][ln["family"]] = ident[k].get(ln["family"], 0) + 1
    label = sorted(f for f in count[0] if count[0][f] >= 2 and count[1].get(f, 0) >= 2)
    label_3 = [f for f in label if min(count[0][f], count[1][f]) >= 3]
    ok = [f for f in label if all(ident[k].get(f, 0) >= need for k in range(2))]
    shared = [sum(1 for ln in lines if len(ln["agrees"]) > 1) for lines in long_]
    own_off = [sum(1 for ln in lines if ln["family"] not in ln["agrees"]) for lines in long_]
    return {"families_label": label, "families_label_3": label_3, "identifiable": ok,
            "not_identifiable": {str(f): [ident[k].get(f, 0) for k in range(2)] for f in label if f not in ok},
            "lines": [len(v) for v in long_], "lines_agreeing_with_several": shared,
            "lines_off_own_family": own_off, **significance(per_view, label)}


def _assignable(lines, f) -> int:
    """Lines of family ``f`` that its vote's last step would give it: agreeing with it alone, within
    a band of at most 2 degrees."""
    return sum(1 for ln in lines if ln["family"] == f and ln["agrees"] == [f] and ln["bands"][f] <= _MAX_BAND)


def _one_view(lines, f, free):
    """Family ``f`` in one view as the detector's vote sees it at best: the log NFA of the free lines
    that agree with its direction (whatever their family: the vote cannot tell) among ``free`` lines
    (at least those), and whether it keeps enough lines to assign."""
    from catadioptric.detect.families import log_nfa as _log_nfa

    vote = [ln for ln in lines if f in ln["agrees"] and ln["free"]]
    eps = np.minimum([ln["bands"][f] for ln in vote], 1.0)
    return _log_nfa(np.asarray(eps, float), max(free, len(vote))), _assignable(lines, f) >= 3


def _vote(lines, label, pool):
    """The label families one view's vote could find, by the true directions: ``pool`` ``"own"``:
    each family with only its own lines free (no vote can do better); ``"seq"``: the vote's
    sequence, every labelled line free at first, the most significant family taken first and the
    lines that agree with it taken out."""
    for ln in lines:
        ln["free"] = True
    if pool == "own":
        return [f for f in label if _one_view(lines, f, 0)[0] <= _ONE_VIEW_LOG_NFA and _one_view(lines, f, 0)[1]]
    found, left = [], list(label)
    while left:
        n_free = sum(ln["free"] for ln in lines)
        scored = sorted((_one_view(lines, f, n_free)[0], f) for f in left)
        lg, f = scored[0]
        if lg > _ONE_VIEW_LOG_NFA:
            break
        left.remove(f)
        if _one_view(lines, f, n_free)[1]:
            found.append(f)
        for ln in lines:
            if f in ln["agrees"]:
                ln["free"] = False
    return found


def significance(per_view, label) -> dict:
    """Whether each label family could be significant to the vote (module docstring, "Significance")."""
    from catadioptric.detect.families import log_nfa as _log_nfa

    out = {}
    for pool in ("own", "seq"):
        found = [set(_vote(lines, label, pool)) for lines in per_view]
        one = [f for f in label if all(f in x for x in found)]
        joint = []
        for f in label:
            if f in one:
                continue
            # in both views at once: a segment seen in both counts once (its two planes nearly coincide)
            # the joint vote's lines (seq): those of no family found in both views
            def in_joint(ln):
                return pool == "own" or not any(g in one for g in ln["agrees"])

            band = {}
            for lines in per_view:
                for ln in lines:
                    if f in ln["agrees"] and in_joint(ln):
                        band[ln["segment"]] = min(band.get(ln["segment"], 1.0), ln["bands"][f])
            free = {ln["segment"] for lines in per_view for ln in lines if pool == "seq" and in_joint(ln)}
            lg = _log_nfa(np.minimum(list(band.values()), 1.0), max(len(free), len(band)))
            if lg <= _JOINT_LOG_NFA and min(_assignable(lines, f) for lines in per_view) >= 2:
                joint.append(f)
        out[f"significant_{pool}"] = one
        out[f"significant_joint_{pool}"] = joint
    return out


#: the detector's bars (``detect.families.group_families``, ``detect.joint_families``)
_MAX_BAND = np.radians(2.0)
_ONE_VIEW_LOG_NFA = -4.0
_JOINT_LOG_NFA = -6.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--configs", default="sphere,ellipsoid,hyperboloid,hyperboloid_central,hyperboloid_9pct")
    ap.add_argument("--pairs", type=int, default=20)
    ap.add_argument("--spec", default="validate/relative_pose.toml")
    ap.add_argument("--data", default="render/out/relative_pose_benchmark")
    ap.add_argument("--sigma", type=float, default=0.5, help="pixel noise of each line's plane fit")
    ap.add_argument("--lines", type=int, default=2, help="lines that must identify a family in each view")
    ap.add_argument("--max-log-nfa", type=float, default=-4.0, help="the one-view vote's bar (the detector's: -4)")
    ap.add_argument("--joint-max-log-nfa", type=float, default=-6.0, help="the joint vote's bar (twoview's: -6)")
    ap.add_argument("--systematic", type=float, default=0.0,
                    help="pixel error that does not average out along a line (the detector's: 0.15)")
    ap.add_argument("--json", help="write the rows here")
    ap.add_argument("--from-json", help="print the table from these rows instead of computing them")
    args = ap.parse_args()
    global _ONE_VIEW_LOG_NFA, _JOINT_LOG_NFA
    _ONE_VIEW_LOG_NFA, _JOINT_LOG_NFA = args.max_log_nfa, args.joint_max_log_nfa
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
                r = pair_row(ds, p.names, spec["min_pixels"], args.sigma, args.lines, systematic_px=args.systematic)
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
    if "significant_own" not in rows[0]:
        return
    print()
    print("Significance to the vote, at best (own: only the family's lines free; seq: the vote's sequence over "
          "every labelled line); pairs whose every label family / every family of 3+ lines could be found:")
    print("| configuration | pairs | label families | one view at a time (own / seq) | or both views at once "
          "(own / seq) | pairs, every family (own / seq) | pairs, every family of 3+ lines (own / seq) |")
    print("|---|---|---|---|---|---|---|")
    for name in [*dict.fromkeys(r["config"] for r in rows), None]:
        cell = [r for r in rows if name is None or r["config"] == name]
        nl = sum(len(r["families_label"]) for r in cell)
        one = [sum(len(r[f"significant_{p}"]) for r in cell) for p in ("own", "seq")]
        both = [sum(len(r[f"significant_{p}"]) + len(r[f"significant_joint_{p}"]) for r in cell) for p in ("own", "seq")]

        def every(r, p, fams):
            got = set(r[f"significant_{p}"]) | set(r[f"significant_joint_{p}"])
            return set(fams) <= got

        pall = [sum(every(r, p, r["families_label"]) for r in cell) for p in ("own", "seq")]
        p3 = [sum(every(r, p, r.get("families_label_3", [])) for r in cell) for p in ("own", "seq")]
        print(f"| {name or 'all'} | {len(cell)} | {nl} | {one[0]} / {one[1]} | {both[0]} / {both[1]} | "
              f"{pall[0]} / {pall[1]} | {p3[0]} / {p3[1]} |")


if __name__ == "__main__":
    main()
