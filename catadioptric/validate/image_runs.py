"""``catadioptric validate image-runs``: how the image path's answers stand against what they claim:
their covariance, and the bar on the matching's margin.

    catadioptric validate image-runs RESULTS [RESULTS ...] [--off 5] [--groups 4,12,24]

``RESULTS``: folders of the image path's per-pair results (``DATA/results_images`` of
``catadioptric validate benchmark --images``; a committed report's are written back by
``catadioptric validate restore``). Each folder's runs (every motion prior) are read as they are;
nothing is computed again.

**Covariance** (docs/relative_pose.md, "The covariance of the image path"): over the answered
runs, the rotation error over the deviation the answer claims (``rotation_std_deg``) and the
error's Mahalanobis square against its covariance (``rotation_mahalanobis2``; for a right
covariance chi-square with 3 degrees of freedom: median 2.37, 90th percentile 6.25, 1 % above
11.34), with the scale of the deviations that would bring its median to 2.37 (what
``twoview.COVARIANCE_SCALE`` is measured by).

**Matching bar** (docs/relative_pose.md, "The bar on the matching"): every run by the number of
family assignments it tried; per group, how many runs, how many best candidates more than
``--off`` degrees off and the largest margin among those (what a bar must exceed; a single
assignment has no rival, its margin is infinite; the margin is the smaller of the matching's and
its margin by the RANSAC's matchings alone, where the run recorded it), and how many right answers each bar of
:data:`catadioptric.pose.MATCHING_BARS` keeps; then per bar's range of assignments, the largest
margin of a wrong answer against the bar (:func:`catadioptric.pose.matching_bar`).
"""
from __future__ import annotations

import numpy as np

__all__ = ["covariance_check", "matching_margins", "image_runs_markdown", "register_image_runs",
           "CHI2_3_MEDIAN", "CHI2_3_P90", "CHI2_3_P99"]

#: chi-square with 3 degrees of freedom: median, 90th and 99th percentiles
CHI2_3_MEDIAN, CHI2_3_P90, CHI2_3_P99 = 2.366, 6.251, 11.345


def _runs(results: dict) -> list:
    return [r for res in results.values() for r in res["runs"] if "error" not in r]


def covariance_check(results: dict) -> dict:
    """The answered runs' errors against their claimed deviation and covariance (module docstring)."""
    runs = [r for r in _runs(results) if not r["ambiguous"]]
    z = np.array([r["rotation_error_deg"] / r["rotation_std_deg"] for r in runs
                  if r.get("rotation_std_deg") is not None and np.isfinite(r["rotation_std_deg"])
                  and r["rotation_std_deg"] > 0])
    m = np.array([r["rotation_mahalanobis2"] for r in runs if r.get("rotation_mahalanobis2") is not None])
    out = {"answered": len(runs), "over_std": None, "mahalanobis2": None}
    if len(z):
        out["over_std"] = {"runs": len(z), "median": float(np.median(z)), "p90": float(np.quantile(z, 0.9)),
                           "above_5": int(np.sum(z > 5))}
    if len(m):
        out["mahalanobis2"] = {"runs": len(m), "median": float(np.median(m)), "p90": float(np.quantile(m, 0.9)),
                               "above_p99": int(np.sum(m > CHI2_3_P99)),
                               "scale_for_right_median": float(np.sqrt(np.median(m) / CHI2_3_MEDIAN))}
    return out


def matching_margins(results: dict, off_deg: float = 5.0, groups=(4, 12, 24)) -> dict:
    """Every run by the number of family assignments it tried (module docstring)."""
    from ..pose import MATCHING_BARS

    runs = _runs(results)
    bars = [b for _, b in MATCHING_BARS]

    def margin(r):
        # what the verdict holds to the bar: the smaller of the matching's margin and its margin by the
        # RANSAC's matchings alone (runs that recorded it; docs/relative_pose.md, "Without labels", 3)
        m = float("inf") if r["margin"] is None else float(r["margin"])
        return m if r.get("margin_unordered") is None else min(m, float(r["margin_unordered"]))

    rows = []
    edges = [0, *sorted(groups), None]
    for lo, hi in zip(edges[:-1], edges[1:]):
        rs = [r for r in runs if lo < r["candidates"] and (hi is None or r["candidates"] <= hi)]
        if not rs:
            continue
        wrong = [margin(r) for r in rs if r["rotation_error_deg"] > off_deg]
        right = sorted(margin(r) for r in rs if r["rotation_error_deg"] <= off_deg)
        rows.append({"from": lo + 1, "to": hi, "runs": len(rs), "wrong": len(wrong),
                     "wrong_largest_margin": max(wrong) if wrong else None,
                     "right_median_margin": right[len(right) // 2] if right else None,
                     "right_at_bar": [sum(x >= b for x in right) for b in bars]})
    ranges, lo = [], 0
    for most, bar in MATCHING_BARS:
        rs = [r for r in runs if lo < r["candidates"] and (most is None or r["candidates"] <= most)]
        wrong = [margin(r) for r in rs if r["rotation_error_deg"] > off_deg]
        ranges.append({"from": lo + 1, "to": most, "bar": bar, "runs": len(rs), "wrong": len(wrong),
                       "wrong_largest_margin": max(wrong) if wrong else None})
        lo = most if most is not None else lo
    return {"off_deg": off_deg, "bars": bars, "groups": rows, "bar_ranges": ranges}


def _f(x, digits=2):
    return "-" if x is None else f"{x:.{digits}f}"


def _span(lo, hi):
    return f"{lo}-{hi}" if hi is not None else f"{lo} or more"


def image_runs_markdown(folder: str, cov: dict, bars: dict) -> str:
    """One folder's two checks as Markdown (what the command prints)."""
    L = [f"## `{folder}`", ""]
    z, m = cov["over_std"], cov["mahalanobis2"]
    L.append(f"Covariance: {cov['answered']} answered runs; rotation error over its claimed deviation: "
             + ("-" if z is None else f"median {_f(z['median'])}, 90th percentile {_f(z['p90'])}, above 5: "
                                      f"{z['above_5']}") + ".")
    if m is not None:
        L.append(f"Mahalanobis square of the rotation error: median {_f(m['median'])} (a right covariance: "
                 f"{CHI2_3_MEDIAN:.2f}), 90th percentile {_f(m['p90'])} ({CHI2_3_P90:.2f}), above {CHI2_3_P99:.2f} "
                 f"(1 %): {m['above_p99']} of {m['runs']}; the deviations would be scaled by "
                 f"{_f(m['scale_for_right_median'])} for a right median.")
    off = bars["off_deg"]
    L += ["", f"Matching bar (a best candidate more than {off:g} degrees off is wrong):", "",
          "| family assignments tried | runs | wrong | their largest margin | right: median margin | "
          + " | ".join(f"right, margin at least {b:g}" for b in bars["bars"]) + " |",
          "|---|---|---|---|---|" + "---|" * len(bars["bars"])]
    for g in bars["groups"]:
        L.append(f"| {_span(g['from'], g['to'])} | {g['runs']} | {g['wrong']} | {_f(g['wrong_largest_margin'], 1)} | "
                 f"{_f(g['right_median_margin'], 1)} | " + " | ".join(str(n) for n in g["right_at_bar"]) + " |")
    L.append("")
    L += [f"- {_span(r['from'], r['to'])} assignments: bar {r['bar']:g}; {r['runs']} runs, {r['wrong']} wrong, won by "
          f"at most {_f(r['wrong_largest_margin'], 1)}" for r in bars["bar_ranges"]]
    return "\n".join(L) + "\n"


def _groups(text: str):
    import argparse

    try:
        g = [int(x) for x in text.split(",")]
    except ValueError:
        g = []
    if not g or any(x < 1 for x in g):
        raise argparse.ArgumentTypeError(f"expected comma-separated positive integers, got {text!r}")
    return g


def _run(args) -> int:
    from .benchmark import read_results

    for folder in args.results:
        results = read_results(folder, "RESULTS")
        print(image_runs_markdown(folder, covariance_check(results), matching_margins(results, args.off, args.groups)))
    return 0


def register_image_runs(vs) -> None:
    """Add ``validate image-runs`` to the ``validate`` subparsers ``vs``."""
    from ..cliargs import positive_float

    p = vs.add_parser("image-runs", help="the image path's answers against their covariance and the matching bar",
                      description="Read folders of the image path's per-pair results and print how its answers "
                                  "stand against the covariance they claim (the error's Mahalanobis square) and "
                                  "against the bar on the matching's margin (the largest margin of a wrong answer "
                                  "by the number of family assignments tried).")
    p.add_argument("results", metavar="RESULTS", nargs="+", help="results_images folders (DATA/results_images)")
    p.add_argument("--off", type=positive_float, default=5.0, metavar="DEG",
                   help="a best candidate this many degrees off is wrong (default 5)")
    p.add_argument("--groups", type=_groups, default=[4, 12, 24], metavar="N,N,...",
                   help="upper ends of the groups of assignment counts (default 4,12,24)")
    p.set_defaults(func=_run)
