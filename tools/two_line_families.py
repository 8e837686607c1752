"""Why the image path misses the families of two lines (docs/relative_pose.md, "Families only both
images show"): under a right answer's rotation, how many sets of two free lines in each view agree
on one direction by chance, against those that are one labelled family.

    .venv/bin/python tools/two_line_families.py [--data render/out/relative_pose_benchmark] \\
        [--only sphere:3,ellipsoid:1] [--workers 2]

For each pair of ``--only`` (``CONFIG:PAIR``; default every pair whose committed image-path result
lost a family of two lines in the sparser view), each view's lines are detected again, the pose is
estimated with the prior 60 and without the joint families (:func:`catadioptric.twoview.
pose_from_detections`), and the lines of 30 pixels or more in no matched family are taken (the
joint vote's lines). Every two such lines of A fix a direction ``s`` (planes at least 5 degrees
apart); every two lines of B whose planes, turned into A's frame by the answer's rotation (their
covariances grown by its deviation), agree with ``s`` (chi-square at most 9, the vote's test) make a
2+2 set. A set is *true* when its four lines are lines of one labelled family (labels used only
here, to score). A set passes the *same-segment* test when its lines pair off (A's first with one
of B's, A's second with the other) so that each pair has the same polarity (light band, dark band,
step) and the rays of each line's ends meet the other view's plane in front of the rig, the two
3-D intervals overlapping by at least a fifth of the shorter: one segment seen twice, by the
answer's translation (a direction for a central rig: the test does not depend on the scale).
With ``tools/matching_variants/appearance_gate.patch`` applied (``git apply``: each detected line
carries the colours either side of it, ``DetectedLines.sides``), the same-segment sets are also
counted by how alike their two pairs of lines look (the larger of the two pairs' colour distances,
``catadioptric.pose.matching.side_distance``), per bound D: the sets kept, those of one labelled
family, those whose two pairs are each one labelled segment seen twice, the pairs with a set kept
and those whose kept sets are all of one labelled family.
"""
from __future__ import annotations

import argparse
import itertools
import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np


def _ends(det, i):
    from catadioptric.projection import backproject

    rays = backproject(det.cam, np.array([det.uv[i][0], det.uv[i][-1]]))
    return rays.origins, rays.directions


def _same_segment(da, i, db, j, R, t, min_overlap=0.2) -> bool:
    """Line ``i`` of A and ``j`` of B as one 3-D segment (module docstring)."""
    if da.polarity[i] != db.polarity[j]:
        return False
    oa, ua = _ends(da, i)
    ob, ub = _ends(db, j)
    ob, ub = (ob - t) @ R, ub @ R  # B's rays in A's frame (x_B = R x_A + t)
    na, nb = da.normal[i], db.normal[j] @ R
    ca, cb = float(np.mean(oa @ na)), float(np.mean(ob @ nb))
    with np.errstate(divide="ignore", invalid="ignore"):
        la, lb = (cb - oa @ nb) / (ua @ nb), (ca - ob @ na) / (ub @ na)
    u = np.cross(na, nb)
    if not (np.all(la > 0) and np.all(lb > 0)) or np.linalg.norm(u) < 1e-6:
        return False
    u /= np.linalg.norm(u)
    a = np.sort((oa + la[:, None] * ua) @ u)
    b = np.sort((ob + lb[:, None] * ub) @ u)
    return min(a[1], b[1]) - max(a[0], b[0]) >= min_overlap * min(a[1] - a[0], b[1] - b[0])


def _pair(args):
    data, config, index = args
    from catadioptric.dataset import Dataset
    from catadioptric.detect import detect_lines
    from catadioptric.detect.evaluate import _match_lines, label_curves
    from catadioptric.twoview import pose_from_detections

    r = json.loads(Path(data, "results_images", config, f"p{index:02d}.json").read_text())
    ds = Dataset(Path(data, "datasets", f"{config}_{r['renderer']}"))
    views = [ds[v] for v in r["views"]]
    dets = [detect_lines(v["beauty"], v["camera"]) for v in views]
    res = pose_from_detections(dets[0], dets[1], max_rotation_deg=60.0, joint=False)
    out = {"pair": f"{config}:{index}", "renderer": r["renderer"]}
    if res.pose.ambiguous or res.pose.t is None:
        return out | {"skipped": "ambiguous" if res.pose.ambiguous else "no translation"}
    R, t = res.pose.R, np.asarray(res.pose.t, float)
    da, db = dets
    taken = [{i for a, _ in res.family_map.values() for i in da.families[a].lines},
             {i for b in res.family_map for i in db.families[b].lines}]
    free, fam, segment = [], [], []
    for side, (d, v) in enumerate(zip(dets, views)):
        truth = label_curves(v)
        m, _ = _match_lines([np.asarray(u) for u in d.uv], truth, 1.5, 0.5)
        f = [i for i in range(len(d)) if i not in taken[side] and len(d.uv[i]) >= 30]
        free.append(f)
        fam.append({i: truth[m[i]]["family"] if m[i] >= 0 else None for i in f})
        segment.append({i: truth[m[i]]["segment"] if m[i] >= 0 else None for i in f})
    floor2 = np.sin(np.radians(0.1)) ** 2
    na = da.normal[free[0]]
    nb = db.normal[free[1]] @ R
    cb = np.einsum("ji,njk,kl->nil", R, db.normal_cov[free[1]], R)
    cb = cb + np.radians(res.pose.rotation_std_deg) ** 2 * (np.eye(3)[None] - nb[:, :, None] * nb[:, None, :])
    same = {}

    def seg(i, j):
        if (i, j) not in same:
            same[i, j] = _same_segment(da, free[0][i], db, free[1][j], R, t)
        return same[i, j]

    n = dict.fromkeys(("sets", "true", "same_segment", "same_segment_true"), 0)
    found = set()
    looks = []  # per same-segment set: (true, both pairs one labelled segment, the larger side distance)

    def look(i, j):
        if getattr(da, "sides", None) is None:
            return float("nan")  # the appearance patch is not applied
        from catadioptric.pose.matching import side_distance

        return float(side_distance(da.sides[free[0][i]], db.sides[free[1][j]]))

    def one_segment(i, j):
        a, b = segment[0][free[0][i]], segment[1][free[1][j]]
        return a is not None and a == b

    for i, k in itertools.combinations(range(len(na)), 2):
        s = np.cross(na[i], na[k])
        if np.linalg.norm(s) < np.sin(np.radians(5.0)):
            continue
        s /= np.linalg.norm(s)
        x2 = (nb @ s) ** 2 / (np.einsum("i,nij,j->n", s, cb, s) + floor2)
        for j, l in itertools.combinations(np.flatnonzero(x2 <= 9.0), 2):
            f = {fam[0][free[0][i]], fam[0][free[0][k]], fam[1][free[1][j]], fam[1][free[1][l]]}
            true = len(f) == 1 and None not in f
            pairings = [p for p in (((i, j), (k, l)), ((i, l), (k, j))) if seg(*p[0]) and seg(*p[1])]
            ok = bool(pairings)
            if ok:
                dist = min(max(look(*p[0]), look(*p[1])) for p in pairings)
                looks.append((bool(true), any(one_segment(*p[0]) and one_segment(*p[1]) for p in pairings),
                              dist if np.isfinite(dist) else 1e9))
            n["sets"] += 1
            n["true"] += true
            n["same_segment"] += ok
            n["same_segment_true"] += ok and true
            if true:
                found |= f
    return out | n | {"free_lines": [len(free[0]), len(free[1])], "true_families": sorted(found), "looks": looks}


def _default_pairs(data):
    """The pairs whose committed result (prior 60) lost a label family of two lines in a view."""
    from catadioptric.dataset import Dataset
    from catadioptric.detect.evaluate import label_curves

    out = []
    for p in sorted(Path(data, "results_images").glob("*/*.json")):
        r = json.loads(p.read_text())
        run = next((x for x in r["runs"] if x["max_rotation_deg"] == 60.0), None)
        if run is None or "error" in run or run["ambiguous"] or not run["families_lost"]:
            continue
        ds = Dataset(Path(data, "datasets", f"{r['config']}_{r['renderer']}"))
        counts = [[t["family"] for t in label_curves(ds[v]) if len(t["uv"]) >= 30] for v in r["views"]]
        if any(min(c.count(x["family"]) for c in counts) == 2 for x in run["families_lost"]):
            out.append((r["config"], int(r["pair"])))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="render/out/relative_pose_benchmark")
    ap.add_argument("--only", help="CONFIG:PAIR,... (default: the pairs that lost a family of two lines)")
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args()
    pairs = ([(c, int(p)) for c, p in (x.split(":") for x in args.only.split(","))] if args.only
             else _default_pairs(args.data))
    total = dict.fromkeys(("pairs", "sets", "true", "same_segment", "same_segment_true"), 0)
    looks_by_pair = {}
    print("pair | renderer | free lines A/B | 2+2 sets | of one labelled family | same-segment sets | of one "
          "labelled family")
    with ProcessPoolExecutor(args.workers) as ex:
        for r in ex.map(_pair, [(args.data, c, p) for c, p in pairs]):
            if "skipped" in r:
                print(f"{r['pair']} | {r['renderer']} | {r['skipped']}")
                continue
            print(f"{r['pair']} | {r['renderer']} | {r['free_lines'][0]}/{r['free_lines'][1]} | {r['sets']} | "
                  f"{r['true']} | {r['same_segment']} | {r['same_segment_true']}", flush=True)
            total["pairs"] += 1
            looks_by_pair[r["pair"]] = r["looks"]
            for k in ("sets", "true", "same_segment", "same_segment_true"):
                total[k] += r[k]
    print(f"total over {total['pairs']} pairs: {total['sets']} sets agree, {total['true']} of one labelled family; "
          f"{total['same_segment']} pass the same-segment test, {total['same_segment_true']} of one labelled family")
    if not any(d < 1e9 for lk in looks_by_pair.values() for *_, d in lk):
        return
    print("same-segment sets whose two pairs of lines also look alike (the larger of their two side distances, "
          "pose.matching.side_distance, at most D grey levels; needs tools/matching_variants/appearance_gate.patch):")
    print("D | sets kept | of one labelled family | both pairs one labelled segment | pairs with a set kept | "
          "pairs whose kept sets are all of one labelled family")
    for D in (5, 10, 15, 20, 30, 1e9):
        kept = [(t, g) for lk in looks_by_pair.values() for t, g, d in lk if d <= D]
        with_set = [lk for lk in looks_by_pair.values() if any(d <= D for _, _, d in lk)]
        clean = [lk for lk in with_set if all(t for t, _, d in lk if d <= D)]
        print(f"{'any' if D == 1e9 else D} | {len(kept)} | {sum(t for t, _ in kept)} | {sum(g for _, g in kept)} | "
              f"{len(with_set)} | {len(clean)}")


if __name__ == "__main__":
    main()
