"""Two-view refinement benchmark: seconds per draw of the exact model's relative pose on rendered
benchmark pairs, with the refinement's residuals (``--residuals``: first-order distances from
the rays, or the exact images) and its stopping tolerance ``tol_chi2`` at each value given, in
one run (the variants alternate pair by pair, so a shared machine's load falls on all of them).

    .venv/bin/python bench/bench_refinement.py [--data render/out/relative_pose_benchmark]
        [--configs hyperboloid,sphere] [--pairs 8] [--noise 2] [--tol 0.01]
        [--residuals first_order image] [--cold] [--settle]

Needs the benchmark's rendered datasets (`catadioptric validate benchmark ... --data DIR` renders
them). Same pixels, draws and seeds as the benchmark (spec validate/relative_pose.toml); the
central baseline is not run. Writes bench/results/refinement.json: per variant (residuals and a
tolerance; with the images, continued from the last step's reflection points, and with ``--cold``
also searched anew at each step, with ``--settle`` also each trial's depths re-solved) the median
seconds per draw, the summed seconds, the median rotation, translation-direction and
metric-length errors, and per pair the raw figures; the ratio of summed seconds to the first
variant's. Standalone (not in bench/run.py: it needs the rendered datasets).
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))

from common import metadata, write_json  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def _with_options(variant, fn, *args, **kw):
    """``fn(*args, **kw)`` with every two-view refinement (those of ``pose.scale.refine_far_or_free``)
    run with ``residuals``, ``tol_chi2``, ``warm_start`` and ``settle_depths`` set in its options
    as ``variant`` (a row of :func:`_variants`) says."""
    _, residuals, tol, warm, settle = variant
    from dataclasses import replace

    from catadioptric.pose import bundle, scale

    def refine(data, start, options=bundle.TwoViewOptions()):
        return bundle.refine_two_view(data, start, replace(options, residuals=residuals, tol_chi2=float(tol),
                                                           warm_start=bool(warm), settle_depths=bool(settle)))

    real = scale.refine_two_view
    scale.refine_two_view = refine
    try:
        return fn(*args, **kw)
    finally:
        scale.refine_two_view = real


def _variants(tols, residuals, cold, settle):
    """``(key, residuals, tol, warm, settle)`` of each variant: every residual at every tolerance
    (the images continued from the last step's); with the images also searched anew if ``cold``,
    also with each trial's depths re-solved if ``settle``."""
    out = [(f"{r} tol={t:g}", r, t, True, False) for r in residuals for t in tols]
    if "image" in residuals and cold:
        out += [(f"image tol={t:g} cold", "image", t, False, False) for t in tols]
    if "image" in residuals and settle:
        out += [(f"image tol={t:g} settle", "image", t, True, True) for t in tols]
    return out


def run(data, configs=("hyperboloid", "sphere"), n_pairs=8, noise=2.0, tols=(0.01,), residuals=("first_order", "image"),
        cold=False, settle=False) -> dict:
    from catadioptric.validate.benchmark import dataset_folder
    from catadioptric.validate.benchmark_spec import load_benchmark_spec, pairs_of
    from catadioptric.validate.relative_pose import evaluate_pair

    variants = _variants(tols, residuals, cold, settle)
    spec = load_benchmark_spec(os.path.join(ROOT, "validate", "relative_pose.toml"))
    by_name = {c["name"]: c for c in spec["configs"]}
    unknown = [c for c in configs if c not in by_name]
    if unknown:
        raise SystemExit(f"--configs: expected names among {sorted(by_name)}, got {unknown}")
    rows = []
    for name in configs:
        for pair in pairs_of(spec, by_name[name])[:n_pairs]:
            folder = dataset_folder(data, name, pair.renderer)
            if not os.path.isdir(folder):
                raise SystemExit(f"--data: no dataset {folder} (render the benchmark first: catadioptric validate "
                                 f"benchmark --data {data} --out DIR)")
            row = {"config": name, "pair": pair.index, "renderer": pair.renderer, "runs": {}}
            for variant in variants:
                key = variant[0]
                t0 = time.perf_counter()
                res = _with_options(variant, evaluate_pair, folder, pair.names, noise_levels=(noise,),
                                    draws=spec["draws"], seed=[spec["seed"], pair.index], pixels=spec["pixels"],
                                    min_pixels=spec["min_pixels"], max_pixels=spec["max_pixels"], central=False)
                d = res["draws"]
                row["runs"][key] = {"seconds": time.perf_counter() - t0,
                                    "seconds_per_draw": [x["seconds"] for x in d],
                                    "rotation_error_deg": [x["rotation_error_deg"] for x in d],
                                    "translation_direction_error_deg":
                                        [x["translation_direction_error_deg"] for x in d],
                                    "translation_error_m": [x["translation_error_m"] for x in d]}
            print(f"  {name} p{pair.index:02d}: " + ", ".join(
                f"{k}: {np.mean(row['runs'][k]['seconds_per_draw']):.2f} s/draw, "
                f"{np.median(row['runs'][k]['rotation_error_deg']):.3f} deg" for k, *_ in variants), flush=True)
            rows.append(row)
    summary = {}
    for key, *_ in variants:
        runs = [r["runs"][key] for r in rows]
        cat = lambda k: np.concatenate([x[k] for x in runs])
        summary[key] = {"draws": int(len(cat("seconds_per_draw"))),
                        "translation_error_m_median": float(np.median(cat("translation_error_m"))),
                        "seconds_per_draw_median": float(np.median(cat("seconds_per_draw"))),
                        "seconds_sum": float(np.sum(cat("seconds_per_draw"))),
                        "rotation_error_deg_median": float(np.median(cat("rotation_error_deg"))),
                        "translation_direction_error_deg_median":
                            float(np.median(cat("translation_direction_error_deg")))}
    base = summary[variants[0][0]]["seconds_sum"]
    for s in summary.values():
        s["time_ratio_to_first"] = s["seconds_sum"] / base
    shown = os.path.relpath(data, ROOT) if os.path.abspath(data).startswith(ROOT + os.sep) else data
    return {"data": shown, "configs": list(configs), "pairs": n_pairs, "noise_px": noise, "tols": list(tols),
            "residuals": list(residuals), "cold": cold, "settle": settle,
            "summary": summary, "rows": rows, "loadavg": list(os.getloadavg())}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=os.path.join(ROOT, "render", "out", "relative_pose_benchmark"))
    ap.add_argument("--configs", default="hyperboloid,sphere")
    ap.add_argument("--pairs", type=int, default=8, help="first N pairs of each configuration (default 8)")
    ap.add_argument("--noise", type=float, default=2.0, help="pixel noise (default 2)")
    ap.add_argument("--tol", type=float, nargs="+", default=[0.01], help="tol_chi2 values (default 0.01)")
    ap.add_argument("--residuals", nargs="+", choices=["first_order", "image"], default=["first_order", "image"],
                    help="the refinement's residuals (default both: the first the ratios' base)")
    ap.add_argument("--cold", action="store_true",
                    help="also the images at each tolerance with warm_start=False (every image searched anew)")
    ap.add_argument("--settle", action="store_true",
                    help="also the images at each tolerance with settle_depths=True (each trial's depths re-solved)")
    args = ap.parse_args()
    res = run(args.data, tuple(args.configs.split(",")), args.pairs, args.noise, tuple(args.tol),
              tuple(args.residuals), args.cold, args.settle)
    out = os.path.join(HERE, "results", "refinement.json")
    write_json(out, {"benchmark": "refinement", "meta": metadata(), **res})
    for t, s in res["summary"].items():
        print(f"{t}: {s['seconds_per_draw_median']:.2f} s per draw (median of {s['draws']}), time "
              f"{s['time_ratio_to_first']:.2f}x the first, rotation {s['rotation_error_deg_median']:.3f} deg, "
              f"translation direction {s['translation_direction_error_deg_median']:.2f} deg, "
              f"length {s['translation_error_m_median']:.3g} m")
    print(f"wrote {os.path.relpath(out)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
