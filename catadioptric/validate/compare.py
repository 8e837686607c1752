"""``catadioptric validate compare``: two runs of the benchmark's image path, pair by pair.

    catadioptric validate compare BASE NEW [--prior 60|none]

``BASE``, ``NEW``: folders of per-pair results of the image path (``DATA/results_images`` of
``catadioptric validate benchmark --images`` or ``--images-only``; a run kept before a change is
a copy of that folder; a committed report's are written back by ``catadioptric validate
restore``). Only the pairs both hold are compared, and each must be the same view pair in both
(the same true pose): two runs of one benchmark with different code, detector options or render
quality (docs/detect.md, "Render quality and denoising").

Prints, for the runs with the prior: a table of both runs (pairs answered, ambiguous, failed,
wrong by more than 10 degrees and not flagged; the pairs whose matched families are the label
path's, also counting only families of three lines or more; those whose matched families are all
right; the labelled pixels recovered and the recall of families of three lines or more, means
over the views; the median rotation error of the answered pairs); the answered pairs without a
prior; the median rotation error per configuration; and, over the pairs both runs answer (the
best candidate, ambiguous or not), the median rotation error of each, in how many pairs the new
one is lower and higher, and the two-sided Wilcoxon signed-rank p-value.
"""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError

__all__ = ["compare_runs", "compare_markdown", "register_compare"]

#: an answer this far off and not flagged ambiguous is wrong (the benchmark's count)
WRONG_DEG = 10.0


def _run(result: dict, prior):
    """The run of one pair's result with the motion prior ``prior`` (None: without)."""
    for r in result["runs"]:
        if r.get("max_rotation_deg") == prior:
            return r
    return None


def _mean(x):
    x = [v for v in x if v is not None]
    return float(np.mean(x)) if x else None


def _summary(results: dict, keys: list, prior) -> dict:
    runs = [_run(results[k], prior) for k in keys]
    ok = [r for r in runs if r is not None and "error" not in r]
    answered = [r for r in ok if not r["ambiguous"]]
    views = [v for k in keys for v in results[k].get("detection", [])]
    med = [r["rotation_error_deg"] for r in answered]
    return {"pairs": len(keys), "answered": len(answered), "ambiguous": len(ok) - len(answered),
            "failed": len(keys) - len(ok),
            "wrong_unflagged": sum(r["rotation_error_deg"] > WRONG_DEG for r in answered),
            "same_families": sum(bool(r.get("same_families")) for r in ok),
            "same_families_3": sum(bool(r.get("same_families_3")) for r in ok),
            "families_right": sum(bool(r.get("families_right")) for r in ok),
            "recovered": _mean(v.get("recovered_fraction") for v in views),
            "family_recall_3": _mean(v.get("family_recall_3") for v in views),
            "rotation_deg": float(np.median(med)) if med else None}


def _check_same_pairs(base: dict, new: dict, keys: list) -> None:
    for k in keys:
        a, b = base[k], new[k]
        if "R_gt" in a and "R_gt" in b and not (np.allclose(a["R_gt"], b["R_gt"], atol=1e-9)
                                                and np.allclose(a["t_gt"], b["t_gt"], atol=1e-9)):
            raise CatadioptricError(f"NEW: {k} is another view pair than in BASE (its true pose differs): the two "
                                    "folders are not runs of one benchmark")


def compare_runs(base: dict, new: dict, prior=60.0) -> dict:
    """Two runs' per-pair results (``{"<config>/pNN.json": result}``, as
    :func:`catadioptric.validate.benchmark.read_results` reads them) over the pairs both hold: each
    run's summary with ``prior`` and without one, per configuration, and the paired comparison.
    ``prior``: degrees, or None for the runs without a prior."""
    keys = sorted(set(base) & set(new))
    if not keys:
        raise CatadioptricError("NEW: no pair in common with BASE (both are folders of <config>/pNN.json)")
    _check_same_pairs(base, new, keys)
    priors = sorted({r.get("max_rotation_deg") for res in (base, new) for k in keys for r in res[k]["runs"]},
                    key=lambda p: -1.0 if p is None else p)
    if prior not in priors:
        raise CatadioptricError(f"--prior: the results hold runs with the priors "
                                f"{['none' if p is None else f'{p:g}' for p in priors]}, got "
                                f"{'none' if prior is None else f'{prior:g}'}")
    out = {"pairs": keys, "prior": prior,
           "runs": {tag: _summary(res, keys, prior) for tag, res in (("base", base), ("new", new))},
           "no_prior": {tag: _summary(res, keys, None) for tag, res in (("base", base), ("new", new))}
           if prior is not None and None in priors else None,
           "per_config": {}}
    for cfg in sorted({base[k]["config"] for k in keys}):
        ks = [k for k in keys if base[k]["config"] == cfg]
        out["per_config"][cfg] = {tag: _summary(res, ks, prior) for tag, res in (("base", base), ("new", new))}
    both = [(b["rotation_error_deg"], n["rotation_error_deg"]) for k in keys
            for b, n in [(_run(base[k], prior), _run(new[k], prior))]
            if b is not None and n is not None and "error" not in b and "error" not in n]
    paired = {"pairs": len(both), "base_median_deg": None, "new_median_deg": None, "lower": 0, "higher": 0,
              "wilcoxon_p": None}
    if both:
        x, y = np.array(both).T
        paired.update(base_median_deg=float(np.median(x)), new_median_deg=float(np.median(y)),
                      lower=int(np.sum(y < x)), higher=int(np.sum(y > x)))
        if np.any(x != y):
            from scipy.stats import wilcoxon

            paired["wilcoxon_p"] = float(wilcoxon(x, y).pvalue)
    out["paired"] = paired
    return out


def _f(x, digits=3):
    return "-" if x is None else f"{x:.{digits}f}"


def compare_markdown(cmp: dict, base_name: str, new_name: str) -> str:
    """The comparison as Markdown tables (what the command prints)."""
    p = "no prior" if cmp["prior"] is None else f"the prior {cmp['prior']:g} degrees"
    L = [f"{len(cmp['pairs'])} pairs in both runs; {p}:", "",
         "| run | pairs | answered | ambiguous | failed | wrong, unflagged | same families | same families (3+ lines) "
         "| matched families all right | recovered | family recall (3+ lines) | rotation error (deg, answered) |",
         "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for tag, name in (("base", base_name), ("new", new_name)):
        s = cmp["runs"][tag]
        L.append(f"| {tag}: `{name}` | {s['pairs']} | {s['answered']} | {s['ambiguous']} | {s['failed']} | "
                 f"{s['wrong_unflagged']} | {s['same_families']} | {s['same_families_3']} | {s['families_right']} | "
                 f"{_f(s['recovered'])} | {_f(s['family_recall_3'])} | {_f(s['rotation_deg'])} |")
    if cmp["no_prior"]:
        a, b = cmp["no_prior"]["base"], cmp["no_prior"]["new"]
        L += ["", f"Without a prior: answered {a['answered']} -> {b['answered']}, wrong and unflagged "
                  f"{a['wrong_unflagged']} -> {b['wrong_unflagged']}."]
    L += ["", "Median rotation error of the answered pairs per configuration (degrees; pairs answered):", "",
          "| configuration | base | new |", "|---|---|---|"]
    for cfg, e in cmp["per_config"].items():
        L.append(f"| {cfg} | {_f(e['base']['rotation_deg'])} ({e['base']['answered']}) | "
                 f"{_f(e['new']['rotation_deg'])} ({e['new']['answered']}) |")
    q = cmp["paired"]
    L.append("")
    if q["pairs"]:
        pv = "no pair differs" if q["wilcoxon_p"] is None else f"Wilcoxon signed-rank p = {q['wilcoxon_p']:.2g}"
        L.append(f"Over the {q['pairs']} pairs both runs answer (the best candidate, ambiguous or not): median "
                 f"rotation error {_f(q['base_median_deg'])} -> {_f(q['new_median_deg'])} degrees, lower in "
                 f"{q['lower']} pairs and higher in {q['higher']} ({pv}).")
    else:
        L.append("No pair is answered by both runs.")
    return "\n".join(L) + "\n"


def _prior(text: str):
    """``--prior``: degrees, or ``none`` for the runs without a prior."""
    import argparse
    import math

    if text.strip().lower() == "none":
        return None
    try:
        v = float(text)
    except ValueError:
        v = float("nan")
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"expected degrees > 0 or none, got {text!r}")
    return v


def _run_cli(args) -> int:
    from .benchmark import read_results

    cmp = compare_runs(read_results(args.base, "BASE"), read_results(args.new, "NEW"), args.prior)
    print(compare_markdown(cmp, args.base, args.new), end="")
    return 0


def register_compare(vs) -> None:
    """Add ``validate compare`` to the ``validate`` subparsers ``vs``."""
    p = vs.add_parser("compare", help="two runs of the benchmark's image path compared pair by pair",
                      description="Two folders of the image path's per-pair results (DATA/results_images of "
                                  "`validate benchmark --images`, or a copy kept from a run before a change) "
                                  "compared over the pairs both hold: answered, ambiguous, wrong, families right, "
                                  "pixels recovered, rotation error, and the Wilcoxon signed-rank test over the "
                                  "pairs both answer.")
    p.add_argument("base", metavar="BASE", help="the first run's results_images folder")
    p.add_argument("new", metavar="NEW", help="the second run's results_images folder")
    p.add_argument("--prior", type=_prior, default=60.0, metavar="DEG",
                   help="the runs with this motion prior (degrees), or none (default 60)")
    p.set_defaults(func=_run_cli)
