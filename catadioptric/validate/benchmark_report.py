"""The relative-pose benchmark's report: aggregates per configuration and noise level, Markdown
tables, plots, and the list of failures and ambiguous draws (written atomically)."""
from __future__ import annotations

import io
import os

import numpy as np

from .._io import atomic_write_bytes, atomic_write_json, jsonable
from .report import md_table
from ..linefit._common import HALF_NORMAL_MEDIAN as _HALF_NORMAL_MEDIAN
from .benchmark_spec import quality_text

__all__ = ["aggregate", "aggregate_images", "write_benchmark_report", "write_images_report", "benchmark_markdown",
           "images_markdown", "median_interval", "median_difference_interval"]

PAPER_FROBENIUS_2PX = 0.0446  # Miraldo, Eiras, Ramalingam, CVPR 2018, Sec. 5.4 (one POV-Ray pair, 2 px)


def _q(x):
    x = np.asarray([v for v in x if v is not None and np.isfinite(v)], float)
    if len(x) == 0:
        return {"n": 0, "median": None, "q1": None, "q3": None, "max": None}
    return {"n": int(len(x)), "median": float(np.median(x)), "q1": float(np.percentile(x, 25)),
            "q3": float(np.percentile(x, 75)), "max": float(np.max(x))}


def median_interval(per_pair, *, level: float = 0.95, n_boot: int = 2000, seed: int = 0) -> dict:
    """The median of every value of ``per_pair`` (one sequence of values per pair; None or nan:
    missing) and its percentile bootstrap interval at ``level``, resampling *pairs* with all their
    values: the draws of one pair share its scene, views and lines, so resampling them one by one
    would claim more precision than the pairs give. Seeded (``seed``): the same values give the
    same interval. ``{"median", "lo", "hi", "pairs"}`` (None without values)."""
    groups = [np.asarray([v for v in g if v is not None and np.isfinite(v)], float) for g in per_pair]
    groups = [g for g in groups if len(g)]
    if not groups:
        return {"median": None, "lo": None, "hi": None, "pairs": 0}
    rng = np.random.default_rng(seed)
    meds = np.array([np.median(np.concatenate([groups[i] for i in rng.integers(0, len(groups), len(groups))]))
                     for _ in range(n_boot)])
    lo, hi = np.percentile(meds, [50.0 * (1.0 - level), 50.0 * (1.0 + level)])
    return {"median": float(np.median(np.concatenate(groups))), "lo": float(lo), "hi": float(hi),
            "pairs": len(groups)}


def median_difference_interval(per_pair_a, per_pair_b, *, level: float = 0.95, n_boot: int = 2000,
                               seed: int = 0) -> dict:
    """The difference of two methods' medians on the same pairs, ``median(a) - median(b)`` over every
    value of ``per_pair_a`` and of ``per_pair_b`` (one sequence of values per pair, the pairs in the
    same order; None or nan: missing), and its percentile bootstrap interval at ``level``, resampling
    *pairs* with all the values both methods have on them (as :func:`median_interval`: the pairs are
    what is drawn from the world; the two methods see the same pairs). ``verdict``: ``"lower"`` when
    the interval lies below 0, ``"higher"`` above, ``"unresolved"`` when it holds 0.
    ``{"difference", "lo", "hi", "pairs", "verdict"}`` (None without values)."""
    def clean(g):
        return np.asarray([v for v in g if v is not None and np.isfinite(v)], float)

    both = [(clean(a), clean(b)) for a, b in zip(per_pair_a, per_pair_b, strict=True)]
    both = [(a, b) for a, b in both if len(a) and len(b)]
    if not both:
        return {"difference": None, "lo": None, "hi": None, "pairs": 0, "verdict": None}

    def diff(idx):
        return float(np.median(np.concatenate([both[i][0] for i in idx]))
                     - np.median(np.concatenate([both[i][1] for i in idx])))

    rng = np.random.default_rng(seed)
    boots = np.array([diff(rng.integers(0, len(both), len(both))) for _ in range(n_boot)])
    lo, hi = (float(x) for x in np.percentile(boots, [50.0 * (1.0 - level), 50.0 * (1.0 + level)]))
    verdict = "lower" if hi < 0 else "higher" if lo > 0 else "unresolved"
    return {"difference": diff(range(len(both))), "lo": lo, "hi": hi, "pairs": len(both), "verdict": verdict}


def _model_rows(draws, key):
    rows = [d if key == "exact" else d.get("central", {}) for d in draws]
    ok = [r for r in rows if "error" not in r and r]
    return rows, ok


def aggregate(spec: dict, results: list) -> dict:
    """Per configuration and noise level, for the exact model and the central baseline: rotation
    error (degrees and Frobenius), translation error (metres; direction in degrees), counts of
    failures, ambiguous draws and draws more than 10 degrees off, time per draw."""
    out = {}
    for config in spec["configs"]:
        name = config["name"]
        pairs = [r for r in results if r["config"] == name]
        per_noise = {}
        for noise in spec["noise_px"]:
            draws = [d for r in pairs for d in r["draws"] if abs(d["noise_px"] - noise) < 1e-12]
            entry = {}
            for key in ("exact", "central"):
                rows, ok = _model_rows(draws, key)
                clear = [r for r in ok if not r["ambiguous"]]
                entry[key] = {
                    "draws": len(rows), "failed": len(rows) - len(ok), "ambiguous": sum(r["ambiguous"] for r in ok),
                    "rotation_deg": _q([r["rotation_error_deg"] for r in clear]),
                    "frobenius": _q([r["frobenius_error"] for r in clear]),
                    "translation_m": _q([r["translation_error_m"] for r in clear]),
                    "translation_direction_deg": _q([r["translation_direction_error_deg"] for r in clear]),
                    "over_10deg_unflagged": sum(r["rotation_error_deg"] > 10 for r in clear),
                    "seconds": _q([r["seconds"] for r in ok]),
                    # the rotation's median with its 95 % interval, the pairs resampled
                    "rotation_median_interval_deg": median_interval(
                        [[m["rotation_error_deg"] for m in _model_rows(
                            [d for d in r["draws"] if abs(d["noise_px"] - noise) < 1e-12], key)[1]
                          if not m["ambiguous"]] for r in pairs]),
                }
            sel = [d["selected"] for d in draws if d.get("selected")]
            clear = [r for r in sel if not r["ambiguous"]]
            entry["selected"] = {"draws": len(sel), "central_chosen": sum(r["model"] == "central" for r in clear),
                                 "rotation_deg": _q([r["rotation_error_deg"] for r in clear]),
                                 "frobenius": _q([r["frobenius_error"] for r in clear])}
            entry["paired"] = _paired(draws)
            told = [d for d in draws if "scale_held" in d and "error" not in d]
            entry["scale"] = {"draws": len(told), "held": sum(d["scale_held"] for d in told),
                              "held_rotation_deg": _q([d["rotation_error_deg"] for d in told if d["scale_held"]]),
                              "free_rotation_deg": _q([d["rotation_error_deg"] for d in told if not d["scale_held"]])}
            per_noise[str(noise)] = entry
        seen = [v for r in pairs for v in r.get("seen", {}).values()]
        out[name] = {
            "rig": config["rig"], "pairs": len(pairs),
            "renderers": sorted({r["renderer"] for r in pairs}),
            "baseline_m": _q([r["baseline_m"] for r in pairs]),
            "seen": {k: _q([s[k] for s in seen]) for k in ("families", "lines", "pixels")},
            "families_in_both": _q([r["families_in_both"] for r in pairs]),
            "seconds_per_pair": _q([r["seconds"] for r in pairs]),
            "noise": per_noise,
        }
    return out


def _paired(draws) -> dict:
    """The exact model against the central baseline on the same draws (both answered, neither
    ambiguous): how often the exact model's rotation error is the smaller, the median difference
    (exact minus central, degrees) and the two-sided Wilcoxon signed-rank p-value; and per model
    the median of the rotation error over its own predicted deviation (``rotation_std_deg``),
    about 0.89 for an estimator whose covariance is right (isotropic case)."""
    ok = lambda m: bool(m) and "error" not in m and not m["ambiguous"]
    both = [(d["rotation_error_deg"], d["central"]["rotation_error_deg"]) for d in draws
            if ok(d) and ok(d.get("central", {}))]
    out = {"n": len(both), "exact_better": None, "median_difference_deg": None, "wilcoxon_p": None}
    if both:
        e, c = np.array(both).T
        out["exact_better"] = int(np.sum(e < c))
        out["median_difference_deg"] = float(np.median(e - c))
        if np.any(e != c):
            from scipy.stats import wilcoxon

            out["wilcoxon_p"] = float(wilcoxon(e, c).pvalue)
    for key in ("exact", "central"):
        rows = [d if key == "exact" else d.get("central", {}) for d in draws]
        ratio = [m["rotation_error_deg"] / m["rotation_std_deg"] for m in rows
                 if ok(m) and m.get("rotation_std_deg") and np.isfinite(m["rotation_std_deg"])
                 and m["rotation_std_deg"] > 0]
        out[f"{key}_error_over_predicted"] = _q(ratio)
    return out


#: the bins of the table by baseline and turn (metres, degrees; the last bin of each is closed)
BASELINE_BINS_M = (0.0, 8.0, 25.0, float("inf"))
TURN_BINS_DEG = (0.0, 30.0, 90.0, 150.0, 180.0)


def _bin(x, edges):
    for k in range(len(edges) - 1):
        if edges[k] <= x < edges[k + 1] or (k == len(edges) - 2 and x <= edges[-1]):
            return k
    return len(edges) - 2


def _bin_name(edges, k, unit):
    hi = edges[k + 1]
    return f"{edges[k]:g}+ {unit}" if not np.isfinite(hi) else f"{edges[k]:g}-{hi:g} {unit}"


def by_baseline_and_turn(results: list) -> dict:
    """The label path's draws binned by the pair's baseline (:data:`BASELINE_BINS_M`) and the turn
    between its views (the angle of ``R_gt``, :data:`TURN_BINS_DEG`), every configuration together,
    per model (``exact``, ``central``): ``{model: {"baseline bin|turn bin": {"pairs", "draws",
    "failed", "ambiguous", "over_10deg_unflagged", "rotation_deg"}}}`` (the rotation error of the
    answered draws, the ambiguous ones left out)."""
    from ..pose import rotation_angle_deg

    out = {}
    for key in ("exact", "central"):
        cells: dict = {}
        for r in results:
            turn = rotation_angle_deg(np.asarray(r["R_gt"], float))
            name = (_bin_name(BASELINE_BINS_M, _bin(r["baseline_m"], BASELINE_BINS_M), "m") + "|"
                    + _bin_name(TURN_BINS_DEG, _bin(turn, TURN_BINS_DEG), "deg"))
            rows, ok = _model_rows(r["draws"], key)
            rows = [x for x in rows if x]
            if not rows:
                continue
            c = cells.setdefault(name, {"pairs": 0, "draws": 0, "failed": 0, "ambiguous": 0,
                                        "over_10deg_unflagged": 0, "_err": []})
            c["pairs"] += 1
            c["draws"] += len(rows)
            c["failed"] += len(rows) - len(ok)
            c["ambiguous"] += sum(bool(x["ambiguous"]) for x in ok)
            clear = [x for x in ok if not x["ambiguous"]]
            c["over_10deg_unflagged"] += sum(x["rotation_error_deg"] > 10 for x in clear)
            c["_err"] += [x["rotation_error_deg"] for x in clear]
        for c in cells.values():
            c["rotation_deg"] = _q(c.pop("_err"))
        out[key] = cells
    return out


def _baseline_turn_markdown(table: dict) -> list:
    L = ["## By baseline and turn", "",
         "Every configuration's draws together, binned by the pair's baseline (rows) and the turn between its views "
         "(columns). Per cell: draws, how many ambiguous, how many answered more than 10 degrees off without a flag, "
         "and the median rotation error of the answered draws (degrees).", ""]
    for key in ("exact", "central"):
        cells = table.get(key, {})
        rows = []
        for i in range(len(BASELINE_BINS_M) - 1):
            b = _bin_name(BASELINE_BINS_M, i, "m")
            row = [b]
            for j in range(len(TURN_BINS_DEG) - 1):
                c = cells.get(b + "|" + _bin_name(TURN_BINS_DEG, j, "deg"))
                if not c:
                    row.append("-")
                    continue
                med = c["rotation_deg"]["median"]
                row.append(f"{c['draws']} draws ({c['pairs']} pairs): ambiguous {c['ambiguous']}, wrong "
                           f"{c['over_10deg_unflagged']}" + (f", {med:.3g} deg" if med is not None else "")
                           + (f", failed {c['failed']}" if c["failed"] else ""))
            rows.append(row)
        L += [f"*{key}*", "", md_table(["baseline"] + [_bin_name(TURN_BINS_DEG, j, "deg")
                                                       for j in range(len(TURN_BINS_DEG) - 1)], rows), ""]
    return L


def _fmt(q, digits=3):
    if not q or q.get("median") is None:
        return "-"
    return f"{q['median']:.{digits}g} [{q['q1']:.{digits}g}, {q['q3']:.{digits}g}]"


def _issues(results) -> list[list]:
    rows = []
    for r in results:
        for d in r["draws"]:
            for key in ("exact", "central"):
                m = d if key == "exact" else d.get("central", {})
                if not m:
                    continue
                if "error" in m:
                    rows.append([r["config"], r["pair"], r["renderer"], d["noise_px"], d["draw"], key, "failed",
                                 m["error"][:160]])
                elif m["ambiguous"]:
                    cands = ", ".join(f"{c['rotation_error_deg']:.1f}" for c in m.get("candidates", []))
                    rows.append([r["config"], r["pair"], r["renderer"], d["noise_px"], d["draw"], key, "ambiguous",
                                 f"margin {m['margin']:.1f}; candidates' rotation errors (deg): {cands}"])
                elif m["rotation_error_deg"] > 10:
                    rows.append([r["config"], r["pair"], r["renderer"], d["noise_px"], d["draw"], key,
                                 "WRONG, not flagged", f"{m['rotation_error_deg']:.1f} deg"])
    return rows


def benchmark_markdown(spec: dict, agg: dict, results: list, command: str, timing: dict) -> str:
    noises = spec["noise_px"]
    L = [f"# Relative pose benchmark `{spec['name']}`", "",
         f"Scene `{spec['scene']}`, {spec['pairs']} view pairs per configuration, {spec['resolution']} "
         f"(quality {quality_text(spec)}), renderers {', '.join(spec['renderers'])} (pairs alternate); line pixels "
         f"`{spec['pixels']}` (lines with at least {spec['min_pixels']} pixels, at most {spec['max_pixels']} per line "
         f"and view used), Gaussian noise {noises} px, {spec['draws']} draws each (one at 0 px: the same pixels in "
         "every draw). Families and line "
         "correspondences come from the labels; which end of each family is which is **searched** (not given). "
         "Frames and conventions: docs/relative_pose.md.", "",
         "Errors are median [first quartile, third quartile] over the draws that were answered (not ambiguous). "
         "*Exact*: the non-central model (two-view refinement, metric translation). *Central*: the fair central "
         "baseline, the same pixels and estimator through the best central approximation of the rig (exact for "
         "the central rig); its translation is a direction. *Selected*: per draw, the rotation of whichever of "
         "the two claims the smaller deviation (`pose.choose_model`: its own covariance, the central one with its "
         "model error; never an ambiguous answer, nor two answers more than 5 deviations apart); the labels are "
         "not used to choose. How often the central one is chosen: section 'Selected model'.", "",
         "## What each rig sees (per view, median [quartiles] over the views)", "",
         md_table(["configuration", "rig", "pairs", "baseline (m)", "families", "lines", "pixels",
                   "families in both views"],
                  [[n, a["rig"], a["pairs"], _fmt(a["baseline_m"]), _fmt(a["seen"]["families"]),
                    _fmt(a["seen"]["lines"]), _fmt(a["seen"]["pixels"]), _fmt(a["families_in_both"])]
                   for n, a in agg.items()]), ""]
    for title, field, digits in (("Rotation error (degrees)", "rotation_deg", 3),
                                 ("Rotation error (Frobenius norm of R - R_gt)", "frobenius", 3),
                                 ("Translation error of the exact model (metres)", "translation_m", 3),
                                 ("Translation direction error (degrees)", "translation_direction_deg", 3)):
        models = {"translation_m": ("exact",), "translation_direction_deg": ("exact", "central")}.get(
            field, ("exact", "central", "selected"))
        rows = []
        for n, a in agg.items():
            for m in models:
                rows.append([n, m] + [_fmt(a["noise"][str(x)][m][field], digits) for x in noises])
        L += [f"## {title}", "", md_table(["configuration", "model"] + [f"{x:g} px" for x in noises], rows), ""]
    rows = []
    for n, a in agg.items():
        for m in ("exact", "central"):
            cells = [a["noise"][str(x)][m].get("rotation_median_interval_deg") or {} for x in noises]
            rows.append([n, m] + ["-" if c.get("median") is None else f"{c['median']:.3g} [{c['lo']:.3g}, {c['hi']:.3g}]"
                                  for c in cells])
    L += ["## How precisely the medians are known", "",
          "Median rotation error (degrees) and its 95 % bootstrap interval, resampling the pairs with all their "
          "draws (the draws of one pair share its scene, views and lines; seeded, 2,000 resamples). Two medians "
          "whose intervals overlap widely are not told apart by this benchmark; the paired test of section "
          "'Exact against central, draw by draw' is the sharper comparison.", "",
          md_table(["configuration", "model"] + [f"{x:g} px" for x in noises], rows), ""]
    rows = []
    for n, a in agg.items():
        for m in ("exact", "central"):
            c = [a["noise"][str(x)][m] for x in noises]
            rows.append([n, m, sum(e["draws"] for e in c), sum(e["failed"] for e in c), sum(e["ambiguous"] for e in c),
                         sum(e["over_10deg_unflagged"] for e in c), _fmt(_merge([e["seconds"] for e in c]), 2)])
    chosen = [[n] + [f"{a['noise'][str(x)]['selected']['central_chosen']}/{a['noise'][str(x)]['selected']['draws']}"
                     for x in noises] for n, a in agg.items()]
    L += ["## Selected model", "",
          "Per cell: the draws whose rotation comes from the central baseline, of the draws both models answered.",
          "", md_table(["configuration"] + [f"{x:g} px" for x in noises], chosen), ""]
    L += ["## Draws: failures, ambiguous answers, wrong answers", "",
          md_table(["configuration", "model", "draws", "failed", "ambiguous", "> 10 deg off, not flagged",
                    "seconds per draw"], rows), ""]
    noisy = [x for x in noises if x > 0]
    rows = []
    for n, a in agg.items():
        cells = []
        for x in noisy:
            p = a["noise"][str(x)].get("paired", {})
            if not p.get("n"):
                cells.append("-")
                continue
            pv = "-" if p["wilcoxon_p"] is None else f"{p['wilcoxon_p']:.2g}"
            cells.append(f"{p['exact_better']}/{p['n']}, {p['median_difference_deg']:+.3f}, p {pv}")
        rows.append([n] + cells)
    L += ["## Exact against central, draw by draw", "",
          "Per cell: in how many draws the exact model's rotation error is the smaller, the median difference "
          "(exact minus central, degrees; negative: the exact model is better) and the two-sided Wilcoxon "
          "signed-rank p-value (small: the difference is not the luck of these draws).", "",
          md_table(["configuration"] + [f"{x:g} px" for x in noisy], rows), ""]
    rows = []
    for n, a in agg.items():
        for m in ("exact", "central"):
            rows.append([n, m] + [_fmt(a["noise"][str(x)].get("paired", {}).get(f"{m}_error_over_predicted"), 2)
                                  for x in noisy])
    L += ["## Errors against the predicted deviation", "",
          "Rotation error over the estimator's own predicted deviation (`rotation_std_deg`, the root of the trace "
          "of its rotation covariance), median [quartiles] over the draws. An estimator whose covariance is right "
          "gives about 0.89 (isotropic case); above that, its errors exceed what it claims.", "",
          md_table(["configuration", "model"] + [f"{x:g} px" for x in noisy], rows), ""]
    rows = [[n] + [f"{a['noise'][str(x)]['scale']['held']}/{a['noise'][str(x)]['scale']['draws']}"
                   for x in noises] for n, a in agg.items() if any(a["noise"][str(x)]["scale"]["draws"] for x in noises)]
    if rows:
        L += ["## The scale: held far, or told by the pixels", "",
              "Per cell: in how many of the exact model's metric draws the pixels did not tell the scene's scale, "
              "so that the rotation is that of the refinement with the scene held far (the rig's central limit) "
              "and the baseline's length the free refinement's (`pose.refine_far_or_free`; docs/relative_pose.md).",
              "", md_table(["configuration"] + [f"{x:g} px" for x in noises], rows), ""]
    two = [x for x in noises if abs(x - 2.0) < 1e-9]
    if two:
        rows = [[n, _fmt(a["noise"][str(two[0])]["exact"]["frobenius"]),
                 _fmt(a["noise"][str(two[0])]["central"]["frobenius"])] for n, a in agg.items()]
        L += ["## Against the paper", "",
              f"The paper reports a Frobenius error of {PAPER_FROBENIUS_2PX} for its one POV-Ray pair (non-central "
              "ellipsoidal rig, 2 px, ends of the families matched by hand). Here, at 2 px:", "",
              md_table(["configuration", "exact (Frobenius)", "central (Frobenius)"], rows), ""]
    L += _baseline_turn_markdown(by_baseline_and_turn(results))
    issues = _issues(results)
    L += ["## Failed, ambiguous and wrong draws", ""]
    L += [md_table(["configuration", "pair", "renderer", "noise (px)", "draw", "model", "what", "detail"], issues)
          if issues else "None.", ""]
    L += ["## Time", "", f"Rendering {_seconds(timing, 'render_seconds')} (resumed views are not "
          f"counted again), evaluation {_seconds(timing, 'evaluate_seconds')} in this run; per pair "
          "(all noise levels and draws, both models): "
          + ", ".join(f"{n} {_fmt(a['seconds_per_pair'], 3)} s" for n, a in agg.items()) + ".", "",
          "Plots: `rotation.png` (rotation error against noise), `translation.png` (translation error).", "",
          f"Reproduce: `{command}`", "", code_line(results, "label path"), ""]
    return "\n".join(L)


def _seconds(timing: dict, key: str) -> str:
    """A run's wall time for the report, ``not measured`` when the timing does not hold it (a report
    written again from stored results, with no earlier report to take it from)."""
    x = timing.get(key)
    return "not measured" if x is None or not np.isfinite(x) else f"{x:.0f} s"


def code_line(results: list, what: str) -> str:
    """Which code computed the per-pair results (``benchmark.code_digest``, first 8 digits, with
    how many pairs each): results are read back while the code is unchanged, so one report may
    hold results of several runs."""
    count: dict = {}
    for r in results:
        key = str(r.get("code") or "unknown")[:8]
        count[key] = count.get(key, 0) + 1
    return (f"The {what}'s per-pair results were computed by the package code of digest "
            + ", ".join(f"`{k}` ({n} pairs)" for k, n in sorted(count.items())) + " (`benchmark.code_digest`).")


def _prior_key(p) -> str:
    return "none" if p is None else f"{float(p):g}"


def _share(runs, key):
    """The fraction of ``runs`` whose ``key`` is true (None without runs, or for results written before
    the key existed)."""
    x = [r[key] for r in runs if key in r]
    return float(np.mean(x)) if x else None


def aggregate_images(spec: dict, results: list, image_results: list) -> dict:
    """The image-only path per configuration and renderer (and both renderers): detection scores
    (means over the views), family matching (fractions of pairs), rotation and translation errors
    per motion prior (answered draws), ambiguous and wrong-unflagged counts, and the label path's
    rotation error on the same pairs at each noise level."""
    out = {}
    for config in spec["configs"]:
        name = config["name"]
        for renderer in [*spec["renderers"], "all"]:
            ims = [r for r in image_results if r["config"] == name and renderer in ("all", r["renderer"])]
            labs = [r for r in results if r["config"] == name and renderer in ("all", r["renderer"])]
            if not ims:
                continue
            det = [v for r in ims for v in r["detection"]]

            def mean(k, det=det):
                x = [v[k] for v in det if v.get(k) is not None]
                return float(np.mean(x)) if x else None

            e = {"pairs": len(ims), "recovered": mean("recovered_fraction"),
                 "family_precision": mean("family_precision"), "family_recall": mean("family_recall"),
                 "family_recall_3": mean("family_recall_3"), "seconds_per_pair": _q([r["seconds"] for r in ims]),
                 # the detected pixels' median distance to the exact curves they match, per view
                 "pixel_distance_px": _q([v["distance_median_px"] for v in det
                                          if v.get("distance_median_px") is not None]),
                 "turn_deg_max": float(max(r["turn_deg"] for r in ims)),
                 "priors": {}}
            for k, prior in enumerate((None, *spec["images"]["max_rotation_deg"])):
                runs = [r["runs"][k] for r in ims if k < len(r["runs"])]
                ok = [x for x in runs if "error" not in x]
                clear = [x for x in ok if not x["ambiguous"]]
                e["priors"][_prior_key(prior)] = {
                    "runs": len(runs), "failed": len(runs) - len(ok), "ambiguous": sum(x["ambiguous"] for x in ok),
                    "same_families": float(np.mean([x["same_families"] for x in ok])) if ok else None,
                    "families_right": float(np.mean([x["families_right"] for x in ok])) if ok else None,
                    "same_families_3": _share(ok, "same_families_3"),
                    "same_families_direction": _share(ok, "same_families_direction"),
                    "families_right_direction": _share(ok, "families_right_direction"),
                    "families_recall": _q([x["families_recall"] for x in ok]),
                    "rotation_deg": _q([x["rotation_error_deg"] for x in clear]),
                    "rotation_deg_all": _q([x["rotation_error_deg"] for x in ok]),
                    "translation_m": _q([x["translation_error_m"] for x in clear]),
                    "translation_direction_deg": _q([x["translation_direction_error_deg"] for x in clear]),
                    # the images' look's own direction (catadioptric.look.translation_by_look; older records lack it)
                    "translation_direction_look_deg": _q([x.get("translation_direction_error_look_deg")
                                                          for x in clear]),
                    "translation_reversed": sum(x["translation_direction_error_deg"] is not None
                                                and x["translation_direction_error_deg"] > 90.0 for x in clear),
                    # the answered runs whose translation's sign or direction the look decided (older records lack it)
                    "translation_from_look": sum(x.get("look_translation_taken") is not None for x in clear),
                    "over_10deg_unflagged": sum(x["rotation_error_deg"] > 10 for x in clear),
                    **_geometry_alone(ok), **_by_look(ok)}
            e["labels_rotation_deg"] = {
                str(n): _q([d["rotation_error_deg"] for r in labs for d in r["draws"]
                            if abs(d["noise_px"] - n) < 1e-12 and "error" not in d and not d["ambiguous"]])
                for n in spec["noise_px"]}
            out[f"{name}/{renderer}"] = e
    return out


def _geometry_alone(ok: list) -> dict:
    """The same runs had the lines' appearance not been used (their ``margin_geometry_alone``
    against the same bar, or the lines seen again deciding as they did): answered, and of those more
    than 10 degrees off; None when the runs carry no such margin (no appearance, or older results)."""
    # recorded: the error of the candidate the geometry alone ranks first; a margin of null is infinite
    # (JSON has no infinity: a single assignment has no rival)
    geo = [x for x in ok if x.get("rotation_error_geometry_alone_deg") is not None and x.get("matching_bar") is not None]
    if not ok or len(geo) < len(ok):
        return {"answered_geometry_alone": None, "over_10deg_unflagged_geometry_alone": None}

    def margin(x, key):
        return np.inf if x.get(key) is None else x[key]

    answered = [x for x in geo if x["turned_in_place"] or min(
        margin(x, "margin_geometry_alone"), margin(x, "margin_geometry_alone_unordered")) >= x["matching_bar"]]
    return {"answered_geometry_alone": len(answered), "over_10deg_unflagged_geometry_alone": sum(
        (x["rotation_error_deg"] if x["turned_in_place"] else x["rotation_error_geometry_alone_deg"]) > 10
        for x in answered)}


def _by_look(ok: list) -> dict:
    """The runs the images' look decided (:func:`catadioptric.look.settle_by_look`), and of those
    more than 10 degrees off; the runs the geometry decided and the look left ambiguous
    (:func:`catadioptric.look.check_by_look`), and of those how many the geometry had answered more
    than 10 degrees off; None when the runs carry no record of it (older results)."""
    if not ok or any("look_decided" not in x for x in ok):
        return {"answered_by_look": None, "over_10deg_by_look": None, "ambiguous_by_look": None,
                "ambiguous_by_look_over_10deg": None}
    by = [x for x in ok if x["look_decided"]]
    out = {"answered_by_look": len(by), "over_10deg_by_look": sum(x["rotation_error_deg"] > 10 for x in by),
           "ambiguous_by_look": None, "ambiguous_by_look_over_10deg": None}
    if all("look_contradicts" in x for x in ok):
        vetoed = [x for x in ok if x["look_contradicts"]]
        out |= {"ambiguous_by_look": len(vetoed),
                "ambiguous_by_look_over_10deg": sum(x["rotation_error_deg"] > 10 for x in vetoed)}
    return out


def _comparable_level(e: dict, prior: str, noises) -> tuple:
    """The smallest noise level of ``noises`` at least the image path's pixel noise (the detected
    pixels' median distance over the half-normal median), and the image path's median rotation
    error over the label path's there; ``(None, None)`` when either is unknown."""
    dist = (e.get("pixel_distance_px") or {}).get("median")
    im = e["priors"][prior]["rotation_deg"]
    if dist is None or im is None or im.get("median") is None:
        return None, None
    above = [n for n in noises if n >= dist / _HALF_NORMAL_MEDIAN]
    if not above:
        return None, None
    lab = e["labels_rotation_deg"][str(above[0])]
    if lab is None or not lab.get("median"):
        return None, None
    return above[0], im["median"] / lab["median"]


def images_markdown(spec: dict, agg_im: dict, overlays: dict, *, labels: bool = True) -> str:
    """The report's section on the image-only path (``labels``: with the label path's rotation error
    on the same pairs beside it)."""
    priors = [_prior_key(p) for p in (None, *spec["images"]["max_rotation_deg"])]
    noises = spec["noise_px"]
    L = ["## From the images alone (no labels)", "",
         "The same pairs through `catadioptric relative-pose IMAGE_A IMAGE_B` (catadioptric.twoview): lines and "
         "families detected in each beauty image (docs/detect.md), families and lines matched across the views "
         "and the pose estimated without any label; the labels only score it "
         "(catadioptric.validate.image_pairs). *Detection*: means over the views of the labelled pixels recovered "
         "and of the detected families' precision and recall (a detected family counts when its direction is "
         "within max(1 degree, 3 standard errors) of a true one). *Same families*: the pairs whose matched "
         "families are all right (same true family, right end) and cover every family the label path uses (two "
         "labelled lines of the minimum length in each view); *3+ lines*: every matched family right and every "
         "family with three or more labelled lines in each view matched (the families one image can single out "
         "among its other lines; a family of two lines per view is found only with the other view, docs/"
         "relative_pose.md); which true family a detected family is: that of "
         "most of its lines; *directions too*: and its direction within the detection's tolerance. Each prior "
         "`max_rotation_deg` rules out candidates that turn by more (the views here turn by at most "
         f"{max(e['turn_deg_max'] for e in agg_im.values()):.1f} degrees); `none`: no prior.", "",
         md_table(["configuration / renderer", "pairs", "recovered", "family precision", "family recall",
                   "seconds per pair"],
                  [[k, e["pairs"], e["recovered"], e["family_precision"], e["family_recall"],
                    _fmt(e["seconds_per_pair"], 3)] for k, e in agg_im.items()]), ""]
    rows = []
    for k, e in agg_im.items():
        for p in priors:
            q = e["priors"][p]
            rows.append([k, p, q["runs"], q["failed"], q["ambiguous"], q["over_10deg_unflagged"],
                         *("-" if q.get(c) is None else f"{q[c]:.2f}"
                           for c in ("same_families", "same_families_3", "families_right", "same_families_direction",
                                     "families_right_direction")),
                         _fmt(q["rotation_deg"]), _fmt(q["translation_m"]), _fmt(q["translation_direction_deg"]),
                         q.get("translation_reversed", "-"), q.get("translation_from_look", "-"),
                         _fmt(q.get("translation_direction_look_deg"))])
    L += ["### Pose from the images", "", "Errors over the answered (not ambiguous) pairs. *Translation (m)*: the "
          "metric answers only. *Translation direction*: the answer's own, and how many of the answered pairs have it "
          "more than 90 degrees off; *taken from the look*: in how many the look decided it (where the lines' lay "
          "more than 90 degrees from the look's: a central direction turned round, a metric translation replaced by "
          "the look's direction); *the look*: the direction in which the images agree best under the "
          "answer's rotation with the scene at one distance (`pose.json`'s `evidence.look_translation`, "
          "docs/relative_pose.md \"The translation's direction by the look\").", "",
          md_table(["configuration / renderer", "prior (deg)", "pairs", "failed", "ambiguous",
                    "> 10 deg off, not flagged", "same families", "same families (3+ lines)",
                    "matched families all right",
                    "same families (directions too)", "all right (directions too)", "rotation (deg)",
                    "translation (m)", "translation direction (deg)", "of those reversed (> 90 deg)",
                    "taken from the look", "translation direction, the look (deg)"],
                   rows), ""]
    rows = [[k, p, q["runs"] - q["failed"], q["runs"] - q["failed"] - q["ambiguous"], q["over_10deg_unflagged"],
             *(["-", "-"] if q.get("answered_by_look") is None else [q["answered_by_look"], q["over_10deg_by_look"]]),
             *(["-", "-"] if q.get("ambiguous_by_look") is None else
               [q["ambiguous_by_look"], q["ambiguous_by_look_over_10deg"]]),
             q["answered_geometry_alone"], q["over_10deg_unflagged_geometry_alone"]]
            for k, e in agg_im.items() for p in priors
            for q in [e["priors"][p]] if q.get("answered_geometry_alone") is not None]
    if rows:
        L += ["### What the lines' appearance and the images' look decided", "",
              "The same runs: how many pairs were answered, of those how many the images' look decided (an answer "
              "the geometry left ambiguous by its margin, docs/relative_pose.md \"The images' look\"), and each "
              "family assignment also scored by the geometry alone (its lines matched again with their sides "
              "ignored, no look; `pose.json`'s `evidence`) held to the same bar: how many pairs each would answer, "
              "and how many of those more than 10 degrees off. *Contradicted by the look*: answers the geometry "
              "decided that the look left ambiguous (another answer agreeing better by the look's bar and two "
              "standard errors, docs/relative_pose.md), and how many of those the geometry had more than 10 "
              "degrees off.", "",
              md_table(["configuration / renderer", "prior (deg)", "pairs run", "answered", "> 10 deg off",
                        "answered by the look", "> 10 deg off, by the look", "contradicted by the look",
                        "of those > 10 deg off", "answered, geometry alone", "> 10 deg off, geometry alone"],
                       rows), ""]
    if labels:
        rows = []
        for k, e in agg_im.items():
            level, ratio = _comparable_level(e, priors[-1], noises)
            dist = (e.get("pixel_distance_px") or {}).get("median")
            rows.append([k, _fmt(e["priors"][priors[-1]]["rotation_deg"])]
                        + [_fmt(e["labels_rotation_deg"][str(n)]) for n in noises]
                        + ["-" if dist is None else f"{dist:.3f}",
                           "-" if ratio is None else f"{ratio:.2f} ({level:g} px)"])
        L += ["### Next to the label path on the same pairs (rotation error, degrees)", "",
              "*Pixels*: the detected pixels' median distance to the exact curves of the lines they match (median "
              "over the views; pixels within 1.5 px of a curve, so a lower bound of their error); Gaussian noise of standard deviation sigma puts pixels a median 0.674 sigma from "
              "their curve. *Ratio*: the image path's median over the label path's at the smallest noise level "
              "of at least the pixels' own (their distance / 0.674): the label path with pixels no better than "
              "the detector's.", "",
              md_table(["configuration / renderer", f"images (prior {priors[-1]})"]
                       + [f"labels, {n:g} px" for n in noises] + ["pixels (px)", "ratio (level)"], rows), ""]
    if overlays:
        L += ["### Overlays (first pair of each configuration)", "",
              "Detected lines coloured by family; B's families in the colour of the family of A they were matched "
              "to (grey: unmatched or unassigned); rings: the matched families' vanishing points.", ""]
        L += [f"![{n}](images_{n}.png)" for n in overlays] + [""]
    return "\n".join(L)


def _merge(qs):
    ns = [q for q in qs if q and q.get("median") is not None]
    if not ns:
        return None
    return {"median": float(np.median([q["median"] for q in ns])), "q1": float(min(q["q1"] for q in ns)),
            "q3": float(max(q["q3"] for q in ns))}


def _plot(agg, spec, field, ylabel, models, fname_title):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(agg)
    fig, axes = plt.subplots(1, len(names), figsize=(3.3 * len(names), 3.2), dpi=110, squeeze=False)
    x = np.array(spec["noise_px"], float)
    colors = {"exact": "tab:blue", "central": "tab:orange", "selected": "tab:green"}
    for ax, n in zip(axes[0], names):
        for m in models:
            q = [agg[n]["noise"][str(v)][m][field] for v in spec["noise_px"]]
            med = np.array([np.nan if e["median"] is None else e["median"] for e in q])
            lo = np.array([np.nan if e["q1"] is None else e["q1"] for e in q])
            hi = np.array([np.nan if e["q3"] is None else e["q3"] for e in q])
            if m == "selected":  # between the other two: its median only
                ax.plot(x, med, "s--", color=colors[m], label=m, ms=3, lw=1)
                continue
            ax.plot(x, med, "o-", color=colors[m], label=m, ms=4)
            ax.fill_between(x, lo, hi, color=colors[m], alpha=0.2, lw=0)
        ax.set_title(n, fontsize=9)
        ax.set_xlabel("pixel noise (px)", fontsize=8)
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
        if np.nanmax([v for v in ax.get_ylim()]) > 0:
            ax.set_ylim(bottom=0)
    axes[0][0].set_ylabel(ylabel, fontsize=8)
    axes[0][0].legend(fontsize=7)
    fig.suptitle(fname_title + " (median, band: quartiles)", fontsize=9)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return buf.getvalue()


def _copy_overlays(overlays, out) -> dict:
    shown = {}
    for name, path in (overlays or {}).items():
        if os.path.isfile(path):
            with open(path, "rb") as f:
                atomic_write_bytes(os.path.join(out, f"images_{name}.png"), f.read())
            shown[name] = path
    return shown


def _relative_source(spec: dict) -> dict:
    """A committed report names the spec relative to where it was run, not the machine."""
    if spec.get("source"):
        rel = os.path.relpath(spec["source"])
        spec = spec | {"source": rel if not rel.startswith("..") else os.path.basename(rel)}
    return spec


def write_images_report(spec: dict, image_results: list, out: str, *, command: str, timing: dict,
                        overlays: dict | None = None) -> dict:
    """The image-only path's report alone (``catadioptric validate benchmark --images-only``):
    ``images.md``, ``images.json`` (spec, aggregate, every pair's result) and ``images_<config>.png``
    from ``overlays`` (``{config: PNG path}``) into ``out``; the label path's figures are not
    there (its report, ``report.md``, sets both side by side). Returns the aggregate."""
    agg_im = aggregate_images(spec, [], image_results)
    os.makedirs(out, exist_ok=True)
    spec = _relative_source(spec)
    shown = _copy_overlays(overlays, out)
    md = "\n".join([f"# Relative-pose benchmark `{spec['name']}`: the images alone", "",
                     f"Spec: `{spec.get('source', spec['name'])}` (seed {spec['seed']}, {spec['pairs']} pairs per "
                     f"configuration, {spec['resolution']}, quality {quality_text(spec)}). Per-pair results computed "
                     f"in {_seconds(timing, 'images_seconds')} (pairs already computed with the same "
                     "code are read back).", "", f"Reproduce: `{command}`", "", code_line(image_results, "image path"),
                     "",
                     images_markdown(spec, agg_im, shown, labels=False)])
    atomic_write_bytes(os.path.join(out, "images.md"), md.encode())
    atomic_write_json(os.path.join(out, "images.json"),
                      jsonable({"spec": spec, "command": command, "timing": timing, "images_aggregate": agg_im,
                                "images_pairs": image_results}), indent=None)
    return agg_im


def write_benchmark_report(spec: dict, results: list, out: str, *, command: str, timing: dict,
                           image_results: list | None = None, overlays: dict | None = None) -> dict:
    """Write ``report.json`` (spec, aggregates, every pair's draws), ``report.md``, ``rotation.png``,
    ``translation.png`` into ``out`` (and, with ``image_results``, the image-only section and
    ``images_<config>.png`` from ``overlays``: ``{config: PNG path}``); returns the aggregate."""
    agg = aggregate(spec, results)
    os.makedirs(out, exist_ok=True)
    spec = _relative_source(spec)
    md = benchmark_markdown(spec, agg, results, command, timing)
    agg_im = None
    if image_results is not None:
        agg_im = aggregate_images(spec, results, image_results)
        md += "\n" + images_markdown(spec, agg_im, _copy_overlays(overlays, out)) + "\n" + code_line(
            image_results, "image path") + "\n"
    try:
        atomic_write_bytes(os.path.join(out, "rotation.png"),
                           _plot(agg, spec, "rotation_deg", "rotation error (deg)", ("exact", "central", "selected"),
                                 "Relative rotation error"))
        atomic_write_bytes(os.path.join(out, "translation.png"),
                           _plot(agg, spec, "translation_direction_deg", "translation direction error (deg)",
                                 ("exact", "central"), "Translation direction error"))
    except ImportError:
        md += "\n(plots not written: matplotlib is not installed; `pip install 'catadioptric[plot]'`)\n"
    atomic_write_bytes(os.path.join(out, "report.md"), md.encode())
    # on one line: every pair's draws of the full benchmark take 5.3 MB indented, 4.1 MB without
    atomic_write_json(os.path.join(out, "report.json"),
                      jsonable({"spec": spec, "command": command, "timing": timing, "aggregate": agg,
                                "by_baseline_and_turn": by_baseline_and_turn(results), "pairs": results, "images_aggregate": agg_im, "images_pairs": image_results}),
                      indent=None)
    return agg
