"""Both fits of the exact model's refinement on benchmark draws, the scene held far and the scale
free (``pose.refine_far_or_free``), and what each way of choosing between them would give (issue 8:
the exact model's rotation on near-central rigs).

    .venv/bin/python tools/scale_choice.py ellipsoid,hyperboloid,hyperboloid_9pct,sphere --pairs 20 --noise 1,2,3 [--reseed K] --json OUT

Per draw: the rotation error of the free fit, of the far fit (the scene held 1e4 mirror sizes
away) and of the central baseline; the far fit's robust-stage cost minus the free one's (``gap``,
chi-square units, the rule of commit 9495095); the same on common ground (``common_gap``:
both fits scored on every pixel with one truncated loss, ``pose.scale.common_gap``, the rule
``refine_far_or_free`` applies); the free fit's relative deviation of its baseline length and
both fits' pixel noise estimates. Then the median rotation error per configuration and noise
level of each rule: always free (the code before ``refine_far_or_free``), always far, the
robust-stage gap, that gap with the free length also known to 5 %, that gap with the free fit's
noise estimate also below the far fit's, the common-ground gap, and the better of the two by the
truth (an oracle, to show what a perfect choice would give). The pairs, seeds and pixels are the
benchmark's (``tools/benchmark_subset.py``; ``--reseed K``: other noise draws of the same pairs);
it needs the benchmark's rendered datasets. With ``--from-json`` the table is printed from an
earlier run's rows.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchmark_subset import _median, run_rows, seed_of  # noqa: E402

from catadioptric.validate.benchmark import dataset_folder  # noqa: E402


_FAR_FROM_FREE = False  # set per worker from the spec (--far-from-free)


def far_from_free_fit(free, cam_a, cam_b, line_family, uv_a, owner_a, uv_b, owner_b, *, centres, **kw):
    """The scene held far, started from the free fit's end: its rotation, directions and lines
    scaled about the centres until the baseline is FAR mirror sizes (a lead, docs/relative_pose.md)."""
    from catadioptric.pose import scale

    t_far, points_far = scale.far_start(cam_a, cam_b, free.R, free.t, free.points, centres=centres)
    return scale.refine_two_view(cam_a, cam_b, free.R, t_far, free.directions, points_far, line_family, uv_a, owner_a,
                                 uv_b, owner_b, centres=centres, hold_scale=True, release_scale=0.0, **kw)


def _both(cam_a, cam_b, R0, t0, dirs0, points0, line_family, uv_a, owner_a, uv_b, owner_b, *, centres, **kw):
    """refine_far_or_free's two fits; the far one returned, both kept on it for the record."""
    from dataclasses import replace

    from catadioptric.pose import scale

    pix = (uv_a, owner_a, uv_b, owner_b)
    free, held = scale.far_and_free_fits(cam_a, cam_b, R0, t0, dirs0, points0, line_family, *pix, centres=centres, **kw)
    ca, cb = (np.asarray(c, float) for c in centres)
    noise = min(1.0, free.sigma / kw.get("sigma_cost", 1.0))
    _, _, std = scale._baseline(free, ca, cb)
    out = replace(held, scale_held=True, far_gap=(held.cost - free.cost) / max(noise, 1e-12) ** 2, scale_std=std)
    out.both = (free.R, held.R)
    out.sigmas = (free.sigma, held.sigma)
    out.common_gap = scale.common_gap(free, held, cam_a, cam_b, *pix, sigma=kw.get("pixel_sigma"))
    out.far_from_free_R = (far_from_free_fit(free, cam_a, cam_b, line_family, *pix, centres=centres, **kw).R
                           if _FAR_FROM_FREE else None)
    return out


def _one(args):
    global _FAR_FROM_FREE
    import catadioptric.pose.relative as rel
    import catadioptric.validate.relative_pose as vrp

    rel.refine_far_or_free = _both
    record = vrp._record

    def rec(res, R_gt, *a):
        out = record(res, R_gt, *a)
        fit = res.candidates[0].fit if res.candidates else None
        if hasattr(fit, "both"):
            out["free_deg"], out["far_deg"] = (vrp._rotation_error_deg(R, R_gt) for R in fit.both)
            out["free_sigma"], out["far_sigma"] = fit.sigmas
            out["common_gap"] = fit.common_gap
            if fit.far_from_free_R is not None:
                out["far_from_free_deg"] = vrp._rotation_error_deg(fit.far_from_free_R, R_gt)
        return out

    vrp._record = rec
    data, spec, config, pair, noise = args
    _FAR_FROM_FREE = bool(spec.get("far_from_free"))
    r = vrp.evaluate_pair(dataset_folder(data, config, pair.renderer), pair.names, noise_levels=noise, draws=1,
                          seed=seed_of(spec, pair), pixels=spec["pixels"], min_pixels=spec["min_pixels"],
                          max_pixels=spec["max_pixels"])
    return [{"config": config, "pair": pair.index, "noise_px": d["noise_px"], "free_deg": d.get("free_deg"),
             "far_deg": d.get("far_deg"), "central_deg": d.get("central", {}).get("rotation_error_deg"),
             "gap": d.get("far_gap"), "scale_std": d.get("scale_std"), "free_sigma": d.get("free_sigma"),
             "far_sigma": d.get("far_sigma"), "common_gap": d.get("common_gap"),
             "far_from_free_deg": d.get("far_from_free_deg")} for d in r["draws"]]


RULES = {
    "always free": lambda r: r["free_deg"],
    "always far": lambda r: r["far_deg"],
    "robust-stage gap > TAU (commit 9495095)": lambda r: r["free_deg"] if r["gap"] > 6.63 else r["far_deg"],
    "gap > TAU and length to 5 %": lambda r: r["free_deg"] if r["gap"] > 6.63 and r["scale_std"] < 0.05 else r["far_deg"],
    "gap > TAU and the free fit's noise estimate the lower": lambda r: (
        r["free_deg"] if r["gap"] > 6.63 and (r.get("free_sigma") or 0.0) < (r.get("far_sigma") or 0.0) else r["far_deg"]),
    "common-ground gap > TAU (refine_far_or_free)": lambda r: (
        r["free_deg"] if (r.get("common_gap") if r.get("common_gap") is not None else -1.0) > 6.63 else r["far_deg"]),
    "common-ground gap > TAU and the length told (scale_std < MAX_SCALE_STD, the rule since the bar)": lambda r: (
        r["free_deg"] if (r.get("common_gap") if r.get("common_gap") is not None else -1.0) > 6.63
        and (r.get("scale_std") if r.get("scale_std") is not None else float("inf")) < 1.0 / np.sqrt(6.63)
        else r["far_deg"]),
    "always far, started from the free fit's end (--far-from-free)": lambda r: r.get("far_from_free_deg"),
    "oracle (the better by the truth)": lambda r: min(r["free_deg"], r["far_deg"]),
    "central baseline": lambda r: r["central_deg"],
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("configs", help="comma-separated configuration names of the spec")
    ap.add_argument("--pairs", type=int, default=20)
    ap.add_argument("--noise", default="2")
    ap.add_argument("--spec", default="validate/relative_pose.toml")
    ap.add_argument("--data", default="render/out/relative_pose_benchmark")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", help="write every draw's row here")
    ap.add_argument("--from-json", help="print the table from these rows instead of running")
    ap.add_argument("--reseed", type=int, help="other noise draws than the benchmark's (seed [spec seed, pair, K])")
    ap.add_argument("--far-from-free", action="store_true",
                    help="a third fit per draw: held far, started from the free fit's end (a lead)")
    ap.add_argument("--pool", metavar="REPORT_JSON",
                    help="also pool these rows (the common-ground rule) with the draws of a benchmark report "
                         "(exact and central) and print medians and Wilcoxon p-values over both")
    args = ap.parse_args()
    names = args.configs.split(",")
    noise = [float(x) for x in args.noise.split(",")]
    if args.from_json:
        rows = json.loads(Path(args.from_json).read_text())
    else:
        rows = run_rows(ap, args, names, noise, _one)
    cells = [(n, z) for n in names for z in noise]
    print("rule | " + " | ".join(f"{n} {z:g} px" for n, z in cells) + "  (median rotation error, degrees)")
    for rule, f in RULES.items():
        med = []
        for n, z in cells:
            sel = [r for r in rows if r["config"] == n and r["noise_px"] == z and r["free_deg"] is not None]
            med.append(_median([{"x": f(r)} for r in sel], "x"))
        print(rule + " | " + " | ".join(f"{m:.3f}" for m in med))
    known = [r for r in rows if r["scale_std"] is not None and r["noise_px"] > 0]
    print(f"free fits with their baseline length known to 5 % (from 1 px): {sum(r['scale_std'] < 0.05 for r in known)} "
          f"of {len(known)}; far fit's cost the lower: {sum(r['gap'] <= 0 for r in known)}")
    for n in names:
        picked = [r for r in known if r["config"] == n and r["gap"] > 6.63]
        print(f"{n}: the robust-stage gap rule picks the free fit in {len(picked)} draws from 1 px; its rotation is the better "
              f"in {sum(r['free_deg'] < r['far_deg'] for r in picked)}")
    if args.pool:
        _pooled(rows, json.loads(Path(args.pool).read_text()), cells)


def _pooled(rows, report, cells):
    """Per cell, the benchmark report's draws (exact, central) and these rows under the common-ground
    rule together: medians, draws where the exact model is the better, Wilcoxon signed-rank p."""
    from scipy.stats import wilcoxon

    rule = RULES["common-ground gap > TAU (refine_far_or_free)"]
    print("pooled with the report's draws | draws | exact | central | exact better | p  (rotation, degrees)")
    for n, z in cells:
        pairs = [(d["rotation_error_deg"], d["central"]["rotation_error_deg"]) for p in report["pairs"]
                 if p["config"] == n for d in p["draws"] if d["noise_px"] == z and "rotation_error_deg" in d
                 and "rotation_error_deg" in d.get("central", {})]
        pairs += [(rule(r), r["central_deg"]) for r in rows if r["config"] == n and r["noise_px"] == z
                  and r["free_deg"] is not None and r["central_deg"] is not None]
        e, c = (np.array(x, float) for x in zip(*pairs)) if pairs else (np.zeros(0), np.zeros(0))
        p = wilcoxon(e, c).pvalue if len(e) and np.any(e != c) else float("nan")
        print(f"{n} {z:g} px | {len(e)} | {np.median(e):.3f} | {np.median(c):.3f} | {int(np.sum(e < c))} | {p:.2g}")


if __name__ == "__main__":
    main()
