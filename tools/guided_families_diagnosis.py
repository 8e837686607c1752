"""What the families completed across the views are (docs/relative_pose.md, "A family of one view
completed in the other"): each family :func:`guided_families` completes under a pair's first
answer, scored by the labels, with the figures of the one-view family it starts from.

Needs ``tools/matching_variants/guided_families.patch`` applied (in a worktree, say:
``git worktree add WT HEAD && git -C WT apply tools/matching_variants/guided_families.patch``, then
``PYTHONPATH=WT``) and the benchmark's datasets.

    PYTHONPATH=WT .venv/bin/python tools/guided_families_diagnosis.py \\
        [--only sphere:0,sphere:1,...] [--data render/out/relative_pose_benchmark] [--workers 2] [--json OUT]

Default pairs: those whose image-path result in ``--results`` (default the data folder's
``results_images``, which must then hold the patch's run) says a family was completed. For each
pair: both views detected, the pose with the prior 60 and no families added (the first answer),
then the completion as the patch runs it. Each completed family is *right* when its direction is
within 1.5 degrees of a true family's (A's frame); printed with its significance, its lines in
each view (their true families), the nearest matched direction, and its one-view source family's
deviation, mean and largest chi-square of its lines, lines, pixels and longest line, and how many
of its lines in A (in B) have a line in the other view that could be one segment seen twice with
them (``same_segment_a``, ``same_segment_b``: ``_same_segment`` of tools/two_line_families.py under
the answer's translation), and the largest share of its lines in the other view that one family
of that view's own detection held (``other_in_one_family``); then the range of each figure over the right and the wrong ones.
"""
from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

FIGURES = ("log_nfa", "src_std_deg", "src_chi2_mean", "src_chi2_max", "src_lines", "src_pixels", "src_longest",
           "near_matched_deg", "same_segment_a", "same_segment_b", "other_in_one_family")


def _pair(args):
    data, config, index = args
    from catadioptric.dataset import Dataset
    from catadioptric.detect import detect_lines
    from catadioptric.detect.evaluate import _match_lines, label_curves
    from catadioptric.detect.families import _chi2
    from catadioptric.twoview import _finite_std, pose_from_detections
    from two_line_families import _same_segment

    try:
        from catadioptric.detect.joint_families import guided_families
    except ImportError:
        raise SystemExit("guided_families is not in this package: apply tools/matching_variants/guided_families.patch "
                         "(module docstring)") from None
    renderer = "mitsuba" if index % 2 == 0 else "povray"
    ds = Dataset(str(Path(data, "datasets", f"{config}_{renderer}")))
    views = [ds[f"p{index:02d}A"], ds[f"p{index:02d}B"]]
    dets = [detect_lines(v["beauty"], v["camera"]) for v in views]
    res = pose_from_detections(dets[0], dets[1], max_rotation_deg=60.0, joint=False)
    out = {"pair": f"{config}:{index}", "families": []}
    if res.pose.ambiguous:
        return out | {"skipped": "ambiguous"}
    fam_of = []
    for d, v in zip(dets, views):
        truth = label_curves(v)
        m, _ = _match_lines([np.asarray(u) for u in d.uv], truth, 1.5, 0.5)
        fam_of.append([truth[j]["family"] if j >= 0 else None for j in m])
    da, db = dets
    fmap = res.family_map
    known = np.array([da.families[a].direction for a, _ in fmap.values()])
    found = guided_families(da, db, res.pose.R, taken_a=[i for a, _ in fmap.values() for i in da.families[a].lines],
                            taken_b=[i for b in fmap for i in db.families[b].lines], min_pixels=30,
                            rotation_std_deg=_finite_std(res.pose), known_directions=known)
    true_dir = {int(f["index"]): np.asarray(f["direction_M"], float) for f in views[0]["families"]}
    floor2 = np.sin(np.radians(0.1)) ** 2
    for f in found:
        src = None  # the one-view family whose lines the completed family holds in its own view
        for d, lines in ((da, f.lines_a), (db, f.lines_b)):
            ks = {int(d.family[i]) for i in lines}
            if len(ks) == 1 and -1 not in ks and set(lines) <= set(d.families[next(iter(ks))].lines):
                src = (d, d.families[next(iter(ks))])
                break
        off = min(np.degrees(np.arccos(min(1.0, abs(float(t @ f.direction))))) for t in true_dir.values())
        row = {"right": bool(off < 1.5), "off_true_deg": float(off),
               "log_nfa": getattr(f, "log_nfa", None),
               "lines_a": [fam_of[0][i] for i in f.lines_a], "lines_b": [fam_of[1][i] for i in f.lines_b],
               "near_matched_deg": float(np.degrees(np.arccos(np.clip(np.max(np.abs(known @ f.direction)), 0, 1))))}
        if src is not None:
            d, fam = src
            x2 = _chi2(d.normal[fam.lines], d.normal_cov[fam.lines], fam.direction[None], floor2)[0]
            px = [len(d.uv[i]) for i in fam.lines]
            row |= {"src_std_deg": float(fam.std_deg), "src_chi2_mean": float(np.mean(x2)),
                    "src_chi2_max": float(np.max(x2)), "src_lines": len(fam.lines), "src_pixels": int(sum(px)),
                    "src_longest": int(max(px))}
        # the completed lines of the other view: the largest share of them that one detected family
        # of that view held (1: the other view had found the family too, the answer left it out)
        d_other, lines_other = (db, f.lines_b) if src is not None and src[0] is da else (da, f.lines_a)
        ks = [int(d_other.family[i]) for i in lines_other if d_other.family[i] >= 0]
        row["other_in_one_family"] = max(ks.count(k) for k in set(ks)) / len(lines_other) if ks else 0.0
        if res.pose.t is not None:
            # lines of A with a line of B that could be the same segment seen twice, and of B with one
            # of A (tools/two_line_families.py: same polarity, in front, overlapping along the line)
            t = np.asarray(res.pose.t, float)
            same = np.array([[_same_segment(da, i, db, j, res.pose.R, t) for j in f.lines_b] for i in f.lines_a])
            row |= {"same_segment_a": int(same.any(axis=1).sum()), "same_segment_b": int(same.any(axis=0).sum())}
        out["families"].append(row)
    return out


def _default_pairs(results):
    out = []
    for p in sorted(Path(results).glob("*/*.json")):
        r = json.loads(p.read_text())
        run = next((x for x in r["runs"] if x["max_rotation_deg"] == 60.0), None)
        if run and "error" not in run and any("completed in the other" in n for n in run["notes"]):
            out.append((r["config"], int(r["pair"])))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="render/out/relative_pose_benchmark")
    ap.add_argument("--results", help="results_images folder of the patch's run (default DATA/results_images)")
    ap.add_argument("--only", help="CONFIG:PAIR,...")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--json", help="write the rows there")
    a = ap.parse_args()
    data = str(Path(a.data).resolve())
    pairs = ([(c, int(p)) for c, p in (x.split(":") for x in a.only.split(","))] if a.only
             else _default_pairs(a.results or Path(data, "results_images")))
    if not pairs:
        raise SystemExit("no pairs: give --only, or --results of a run with the patch applied")
    rows = []
    with ProcessPoolExecutor(a.workers) as ex:
        for r in ex.map(_pair, [(data, c, p) for c, p in pairs]):
            rows.append(r)
            for f in r["families"]:
                figs = " ".join(f"{k}={f[k]:.3g}" for k in FIGURES if f.get(k) is not None)
                print(f"{r['pair']} {'right' if f['right'] else 'WRONG'} (off {f['off_true_deg']:.1f} deg) A "
                      f"{f['lines_a']} B {f['lines_b']} {figs}", flush=True)
    fams = [f for r in rows for f in r["families"]]
    right = [f for f in fams if f["right"]]
    print(f"{len(fams)} families completed in {sum(bool(r['families']) for r in rows)} pairs: {len(right)} right "
          f"(direction within 1.5 degrees of a true one), {len(fams) - len(right)} wrong")
    for k in FIGURES:
        rng = []
        for group in (right, [f for f in fams if not f["right"]]):
            v = [f[k] for f in group if f.get(k) is not None]
            rng.append(f"{min(v):.3g} to {max(v):.3g}" if v else "-")
        print(f"{k}: right {rng[0]}, wrong {rng[1]}")
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
