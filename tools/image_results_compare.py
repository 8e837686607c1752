"""Two runs of the benchmark's image-only path compared pair by pair, and what the label families
it misses look like (docs/relative_pose.md, "Families only both images show").

    .venv/bin/python tools/image_results_compare.py misses RESULTS
    .venv/bin/python tools/image_results_compare.py compare BASE NEW [--prior 60]
    .venv/bin/python tools/image_results_compare.py margins RESULTS [--prior 60|none] [--bars 20,33,60,rule]
    .venv/bin/python tools/image_results_compare.py assignments RESULTS [RESULTS ...] [--off 5] [--buckets 4,12,24]
    .venv/bin/python tools/image_results_compare.py calibration RESULTS [RESULTS ...]
    .venv/bin/python tools/image_results_compare.py pixel-error RESULTS [RESULTS ...]

``RESULTS``, ``BASE``, ``NEW``: ``results_images`` folders of ``catadioptric validate benchmark
--images`` (one JSON per pair; a run kept before a code change is a copy of that folder; the
benchmark computes a pair again when the package's code has changed, ``benchmark.code_digest``).

``misses``: the label families (two labelled lines of 30 pixels in both views) that the answer
with the prior does not match right, by the number of labelled lines in the sparser view.
``compare``: per prior, the pairs with the same families, all matched families right, ambiguous
and wrong unflagged in each run; the median rotation error of the answered, unambiguous pairs per
configuration in each; over every pair answered in both (the best candidate, ambiguous or not)
the median rotation error, in how many pairs it is lower and the Wilcoxon signed-rank p; then
the pairs where ``NEW`` found families in both views at once, with their rotation errors,
families all right and recall before and after. ``margins``: the ambiguous answers more than 1
degree off with their margins, and for each bar on the margin (``decisive_matching``) the pairs
it would answer, how many of those are more than 10 degrees off and the largest error.
``assignments``: every run by the number of family assignments it tried, with the largest margin
of a wrong answer in each group (what the default bar, ``catadioptric.pose.matching_bar``, rests
on). ``calibration``: the answered runs' rotation error over their own claimed deviation (what the
joint families' guard in ``catadioptric.twoview`` is scaled by). ``pixel-error``: how far the
detected pixels lie from the exact curves of the lines they match (``distance_median_px`` of
:func:`catadioptric.detect.evaluate_view`), per configuration and renderer, and the Gaussian noise
of the same median distance (median / 0.6745): the label path's noise level the image path's
pixels are comparable to. ``misses`` also gives where the
families of three or more lines were lost, the matched families scored wrong, and with ``--bound
validate/relative_pose/family_identifiability.json`` where the lost families of three or more
lines stand against what a vote could find at best. Needs the
benchmark's datasets for ``misses`` (render/out/relative_pose_benchmark/datasets).
"""
from __future__ import annotations

import argparse
import collections
import json
from pathlib import Path

import numpy as np

DATASETS = Path("render/out/relative_pose_benchmark/datasets")


def _load(folder):
    return {f"{p.parent.name}/{p.name}": json.loads(p.read_text()) for p in sorted(Path(folder).glob("*/*.json"))}


def _run(r, prior):
    runs = [x for x in r["runs"] if x["max_rotation_deg"] == prior]
    return runs[0] if runs else None


def misses(folder, prior, bound=None):
    from catadioptric.dataset import Dataset
    from catadioptric.detect.evaluate import label_curves

    labelled, missed, pairs = collections.Counter(), collections.Counter(), collections.Counter()
    for key, r in _load(folder).items():
        ds = Dataset(DATASETS / f"{r['config']}_{r['renderer']}")
        counts = [collections.Counter(t["family"] for t in label_curves(ds[v]) if len(t["uv"]) >= 30)
                  for v in r["views"]]
        run = _run(r, prior)
        if run is None or "error" in run:
            continue
        right = {m["true_a"] for m in run["matched"] if m["right"]}
        sizes = {f: min(counts[0][f], counts[1][f]) for f in r["families_label"]}
        for f in r["families_label"]:
            k = min(4, sizes[f])
            labelled[k] += 1
            missed[k] += f not in right
        pairs["evaluated"] += 1
        pairs["two"] += any(k == 2 for k in sizes.values())
        answered_right = not run["ambiguous"] and run["families_right"]
        pairs["same"] += answered_right and run["same_families"]
        pairs["only two lost"] += answered_right and all(sizes[x["family"]] == 2 for x in run["families_lost"])
    print("lines in the sparser view | label families | not matched right")
    for k in sorted(labelled):
        print(f"{'4+' if k == 4 else k} | {labelled[k]} | {missed[k]}")
    print(f"pairs: {pairs['evaluated']} evaluated, {pairs['two']} with a label family of two lines in a view; answered "
          f"with every matched family right: the same families in {pairs['same']}, and in {pairs['only two lost']} "
          "if the families of two lines they lose were found")
    causes = collections.Counter(
        x["cause"].split(": ", 1)[-1] for r in _load(folder).values() for run in [_run(r, prior)]
        if run is not None and "error" not in run for x in run["families_lost"] if x["family"] in r["families_label_3"])
    print("families of three or more lines in each view, not matched right, by where they were lost "
          "(families_lost, either view): " + ", ".join(f"{c} {n}" for c, n in causes.most_common()))
    kinds = collections.Counter()
    for r in _load(folder).values():
        run = _run(r, prior)
        if run is None or "error" in run:
            continue
        n_a = r["detection"][0]["families_detected"]  # families beyond these came from the joint vote
        for m in run["matched"]:
            kinds["joint " + ("right" if m["right"] else "wrong") if m["family_a"] >= n_a else
                  ("right" if m["right"] else "wrong")] += 1
            kinds["spurious"] += not m["right"] and (m["true_a"] is None or m["true_b"] is None)
        kinds["by direction"] += sum(not m["right"] and md["right"] for m, md in zip(run["matched"],
                                                                                     run["matched_direction"]))
    print(f"matched families: {kinds['right'] + kinds['joint right']} right, {kinds['wrong'] + kinds['joint wrong']} "
          f"wrong ({kinds['spurious']} of them with no true family holding most of their lines in a view, "
          f"{kinds['by direction']} right by their directions alone, matched_direction); from the "
          f"joint vote {kinds['joint right']} right, {kinds['joint wrong']} wrong")
    if bound is not None:
        rows = {(x["config"], x["pair"]): x for x in json.loads(Path(bound).read_text())}
        where = collections.Counter()
        for r in _load(folder).values():
            run = _run(r, prior)
            if run is None or "error" in run or (r["config"], r["pair"]) not in rows:
                continue
            b = rows[r["config"], r["pair"]]
            for x in run["families_lost"]:
                if x["family"] not in r["families_label_3"]:
                    continue
                f = x["family"]
                reach = ("one view at a time" if f in b["significant_seq"] else
                         "both views at once" if f in b["significant_joint_seq"] else
                         "only with its own lines free" if f in b["significant_own"] + b["significant_joint_own"]
                         else "beyond the bound")
                where[reach, x["cause"].split(": ", 1)[-1]] += 1
        print("those families of three or more lines against what a vote could find at best "
              "(tools/family_identifiability.py rows):")
        for reach in ("one view at a time", "both views at once", "only with its own lines free", "beyond the bound"):
            got = {c: n for (w, c), n in where.items() if w == reach}
            print(f"  {reach}: {sum(got.values())} (" + ", ".join(f"{c} {n}" for c, n in
                                                             sorted(got.items(), key=lambda t: -t[1])) + ")")


def pixel_error(folders):
    """The detected pixels' median distance to the exact curves they match, per view, summarised
    per configuration and renderer (module docstring)."""
    for folder in folders:
        rows = collections.defaultdict(list)
        for r in _load(folder).values():
            for d in r["detection"]:
                if d.get("distance_median_px") is not None:
                    rows[r["config"], r["renderer"]].append(d["distance_median_px"])
                    rows["all", r["renderer"]].append(d["distance_median_px"])
        print(f"{folder}: configuration | renderer | views | median distance (px) | as Gaussian noise (px)")
        for (cfg, ren), v in sorted(rows.items()):
            m = float(np.median(v))
            print(f"{cfg} | {ren} | {len(v)} | {m:.3f} | {m / 0.6745:.2f}")


def calibration(folders):
    """The answered runs' rotation error over the rotation deviation the answer claims
    (``rotation_std_deg``, the root of the covariance's trace: a median of 0.67-0.89 for a right
    covariance, by its shape) and, where the results have it, the error's Mahalanobis square
    against the covariance (``rotation_mahalanobis2``: chi-square of 3 degrees of freedom, median
    2.366, 90th percentile 6.25, for a right covariance) with the scale of the covariance that
    would bring its median there."""
    for folder in folders:
        runs = [r for res in _load(folder).values() for r in res["runs"] if "error" not in r and not r["ambiguous"]]
        z = np.array([r["rotation_error_deg"] / r["rotation_std_deg"] for r in runs
                      if np.isfinite(r.get("rotation_std_deg") or np.nan) and r["rotation_std_deg"] > 0])
        print(f"{folder}: {len(z)} answered runs, error over claimed deviation: median {np.median(z):.2f}, "
              f"90th percentile {np.quantile(z, 0.9):.2f}, above 5: {int(np.sum(z > 5))}")
        m = np.array([r["rotation_mahalanobis2"] for r in runs if r.get("rotation_mahalanobis2") is not None])
        if len(m):
            print(f"  rotation error's Mahalanobis square: median {np.median(m):.2f} (2.37 for a right covariance), "
                  f"90th percentile {np.quantile(m, 0.9):.2f} (6.25), above 11.34 (chi-square 3, 1 %): "
                  f"{int(np.sum(m > 11.34))} of {len(m)}; deviations to scale by "
                  f"{np.sqrt(np.median(m) / 2.366):.2f} for a right median")


def compare(base_dir, new_dir, prior):
    base, new = _load(base_dir), _load(new_dir)
    keys = sorted(set(base) & set(new))
    for p in (None, prior):
        t = collections.Counter()
        for k in keys:
            for tag, r in (("base", _run(base[k], p)), ("new", _run(new[k], p))):
                if r is None or "error" in r:
                    t[tag, "failed"] += 1
                    continue
                t[tag, "same families"] += r["same_families"]
                t[tag, "all right"] += r["families_right"]
                t[tag, "ambiguous"] += r["ambiguous"]
                t[tag, "wrong unflagged"] += (not r["ambiguous"]) and r["rotation_error_deg"] > 10
        print(f"prior {p}: " + ", ".join(f"{what} {t['base', what]} -> {t['new', what]}" for what in
                                           ("same families", "all right", "ambiguous", "wrong unflagged", "failed")))
    print(f"prior {prior}: median rotation error of the answered, unambiguous pairs (degrees), per configuration:")
    for cfg in sorted({k.split("/")[0] for k in keys}):
        med = []
        for runs in (base, new):
            e = [r["rotation_error_deg"] for k in keys if k.startswith(cfg + "/")
                 for r in [_run(runs[k], prior)] if r is not None and "error" not in r and not r["ambiguous"]]
            med.append(f"{np.median(e):.3f} ({len(e)})" if e else "- (0)")
        print(f"  {cfg}: {med[0]} -> {med[1]}")
    both = [(b["rotation_error_deg"], n["rotation_error_deg"]) for k in keys
            for b, n in [(_run(base[k], prior), _run(new[k], prior))]
            if b is not None and n is not None and "error" not in b and "error" not in n]
    if both:
        from scipy.stats import wilcoxon

        x, y = np.array(both).T
        p = wilcoxon(x, y).pvalue if np.any(x != y) else 1.0
        print(f"prior {prior}: every pair answered in both ({len(both)}, best candidate): median rotation error "
              f"{np.median(x):.3f} -> {np.median(y):.3f} deg, lower in {int(np.sum(y < x))}, higher in "
              f"{int(np.sum(y > x))}, Wilcoxon p = {p:.2g}")
    rows, better = [], 0
    for k in keys:
        b, n = _run(base[k], prior), _run(new[k], prior)
        if n is None or "error" in n or not any("both views at once" in x for x in n["notes"]) or "error" in b:
            continue
        better += n["rotation_error_deg"] < b["rotation_error_deg"]
        rows.append((k, b, n))
        print(f"  {k}: rotation {b['rotation_error_deg']:.3f} -> {n['rotation_error_deg']:.3f} deg, all right "
              f"{b['families_right']} -> {n['families_right']}, recall {b['families_recall']:.2f} -> "
              f"{n['families_recall']:.2f}")
    if rows:
        print(f"prior {prior}: families found in both views at once in {len(rows)} pairs; rotation better in {better}; "
              f"all right {sum(b['families_right'] for _, b, _ in rows)} -> {sum(n['families_right'] for _, _, n in rows)}; "
              f"recall summed {sum(b['families_recall'] for _, b, _ in rows):.1f} -> "
              f"{sum(n['families_recall'] for _, _, n in rows):.1f}")


def margins(folder, prior, bars):
    """``bars``: numbers, or ``rule`` for the default bar of the number of family assignments tried
    (:func:`catadioptric.pose.matching_bar`). What a bar would answer is read from the runs as they
    are: an answer it makes decisive would also go through the joint families' step, which is not
    rerun here."""
    from catadioptric.pose import matching_bar

    rows = [(r["margin"] if r["margin"] is not None else float("inf"), r["rotation_error_deg"], r["ambiguous"], k,
             r["candidates"])
            for k, res in _load(folder).items() for r in [_run(res, prior)] if r is not None and "error" not in r]
    print(f"prior {prior}: {len(rows)} pairs answered, {sum(a for _, _, a, _, _ in rows)} ambiguous; those more "
          "than 1 degree off (margin, error, family assignments tried):")
    for m, e, a, k, n in sorted(rows):
        if a and e > 1.0:
            print(f"  {k}: {m:.1f}, {e:.2f} deg, {n}")
    for bar in bars:
        ans = [(m, e) for m, e, _, _, n in rows if m >= (matching_bar(n) if bar == "rule" else bar)]
        worst = max((e for _, e in ans), default=float("nan"))
        print(f"bar {bar}: {len(ans)} answered, {sum(e > 10 for _, e in ans)} more than 10 deg off, "
              f"the largest error {worst:.2f} deg")


def assignments(folders, off_deg, buckets):
    """Every run (every prior) of each folder, by the number of family assignments it tried: how
    many runs, how many best candidates more than ``off_deg`` off and the largest margin among
    those (inf: a single assignment, no rival), the right ones' margins against the bars."""
    from catadioptric.pose import MATCHING_BARS

    print(f"family assignments tried | runs | more than {off_deg:g} deg off | their largest margin | "
          "margins of the rest: median, at least " + ", ".join(f"{b:g}" for _, b in MATCHING_BARS))
    edges = [0, *buckets, 10**9]
    for folder in folders:
        runs = [r for res in _load(folder).values() for r in res["runs"] if "error" not in r]
        print(folder)
        for lo, hi in zip(edges[:-1], edges[1:]):
            rs = [r for r in runs if lo < r["candidates"] <= hi]
            if not rs:
                continue
            m = [float("inf") if r["margin"] is None else r["margin"] for r in rs]
            off = [x for x, r in zip(m, rs) if r["rotation_error_deg"] > off_deg]
            rest = sorted(x for x, r in zip(m, rs) if r["rotation_error_deg"] <= off_deg)
            med = rest[len(rest) // 2] if rest else float("nan")
            print(f"{lo + 1}-{hi if hi < 10**9 else ''} | {len(rs)} | {len(off)} | {max(off, default=float('nan')):.1f} | "
                  f"{med:.1f}, " + ", ".join(str(sum(x >= b for x in rest)) for _, b in MATCHING_BARS))


def _prior(text):
    """``--prior``: a number of degrees, or ``none`` for the runs without a prior."""
    return None if text.lower() == "none" else float(text)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    m = sub.add_parser("misses")
    m.add_argument("results")
    m.add_argument("--prior", type=_prior, default=60.0, help="degrees, or none")
    m.add_argument("--bound", help="tools/family_identifiability.py --json rows: where the lost families stand")
    c = sub.add_parser("compare")
    c.add_argument("base")
    c.add_argument("new")
    c.add_argument("--prior", type=_prior, default=60.0, help="degrees, or none")
    g = sub.add_parser("margins")
    g.add_argument("results")
    g.add_argument("--prior", type=_prior, default=60.0, help="degrees, or none")
    g.add_argument("--bars", default="20,33,60,rule",
                   help="comma-separated bars on the margin; rule: the default bar of the assignments tried")
    k = sub.add_parser("calibration")
    k.add_argument("results", nargs="+")
    e = sub.add_parser("pixel-error")
    e.add_argument("results", nargs="+")
    s = sub.add_parser("assignments")
    s.add_argument("results", nargs="+")
    s.add_argument("--off", type=float, default=5.0, help="an answer this many degrees off is wrong (default 5)")
    s.add_argument("--buckets", default="4,12,24", help="upper ends of the groups of assignment counts")
    a = ap.parse_args()
    if a.cmd == "pixel-error":
        pixel_error(a.results)
    elif a.cmd == "calibration":
        calibration(a.results)
    elif a.cmd == "assignments":
        assignments(a.results, a.off, [int(x) for x in a.buckets.split(",")])
    elif a.cmd == "margins":
        margins(a.results, a.prior, [x if x == "rule" else float(x) for x in a.bars.split(",")])
    elif a.cmd == "misses":
        misses(a.results, a.prior, a.bound)
    else:
        compare(a.base, a.new, a.prior)


if __name__ == "__main__":
    main()
