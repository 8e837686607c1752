"""The label path of the relative-pose benchmark on a few of its pairs, at the noise levels asked:
the exact model's and the central baseline's median rotation and translation-direction errors,
without writing results (for comparing two versions of the code on the same draws).

    .venv/bin/python tools/benchmark_subset.py hyperboloid,sphere --pairs 20 --noise 2 [--json OUT]

The pairs, their seeds and the pixels are the benchmark's (validate/relative_pose.toml, one draw
per pair and noise level unless ``--draws N``, every pixel of each line; with the spec's
``draws`` and ``--pairs 20`` a cell is the benchmark's own, draw for draw); it needs the benchmark's rendered datasets
(``render/out/relative_pose_benchmark``, made by ``catadioptric validate benchmark``). To compare
two commits, run it from the main checkout on the library of each (``git worktree add /tmp/old
COMMIT``, then ``PYTHONPATH=/tmp/old .venv/bin/python tools/benchmark_subset.py ...``: the
package on ``PYTHONPATH`` comes first, in the workers too) and compare the medians, or the
``--json`` rows pair by pair.
"""
from __future__ import annotations

import argparse
import json
from multiprocessing import get_context

import numpy as np

from catadioptric.validate.benchmark import dataset_folder
from catadioptric.validate.benchmark_spec import load_benchmark_spec, pairs_of


def _one(args):
    data, spec, config, pair, noise = args
    from catadioptric.validate.relative_pose import evaluate_pair

    r = evaluate_pair(dataset_folder(data, config, pair.renderer), pair.names, noise_levels=noise,
                      draws=spec.get("subset_draws", 1),
                      seed=seed_of(spec, pair), pixels=spec["pixels"], min_pixels=spec["min_pixels"],
                      max_pixels=spec["max_pixels"])
    rows = []
    for d in r["draws"]:
        c = d.get("central", {})
        rows.append({"config": config, "pair": pair.index, "noise_px": d["noise_px"],
                     "exact_deg": d.get("rotation_error_deg"), "central_deg": c.get("rotation_error_deg"),
                     "exact_t_dir_deg": d.get("translation_direction_error_deg"),
                     "central_t_dir_deg": c.get("translation_direction_error_deg"),
                     "exact_ambiguous": d.get("ambiguous"), "central_ambiguous": c.get("ambiguous"),
                     "scale_held": d.get("scale_held"), "far_gap": d.get("far_gap"), "scale_std": d.get("scale_std"), "seconds": d.get("seconds")})
    return rows


def seed_of(spec, pair) -> list:
    """The noise seed of a pair's draws: the benchmark's (``[spec seed, pair index]``), or with
    ``--reseed K`` (stored as ``spec["reseed"]``) other draws of the same pairs and pixels."""
    return [spec["seed"], pair.index] + ([spec["reseed"]] if spec.get("reseed") is not None else [])


def _median(rows, key):
    x = np.array([r[key] for r in rows if r[key] is not None], float)
    return float(np.median(x)) if len(x) else float("nan")


def run_rows(ap, args, names, noise, one) -> list:
    """``one`` over the first ``args.pairs`` pairs of each configuration in ``names`` (checked
    against ``args.spec``), at the noise levels ``noise``, on ``args.workers`` spawned processes:
    the rows, sorted by configuration, noise and pair, written to ``args.json`` when given."""
    spec = load_benchmark_spec(args.spec)
    spec["reseed"] = getattr(args, "reseed", None)
    spec["far_from_free"] = bool(getattr(args, "far_from_free", False))
    spec["subset_draws"] = int(getattr(args, "draws", 1))
    known = [c["name"] for c in spec["configs"]]
    unknown = [n for n in names if n not in known]
    if unknown:
        ap.error(f"configs: expected names among {known}, got {unknown}")
    tasks = [(args.data, spec, c["name"], p, noise) for c in spec["configs"] if c["name"] in names
             for p in pairs_of(spec, c)[:args.pairs]]
    with get_context("spawn").Pool(args.workers) as pool:
        rows = [r for rr in pool.imap_unordered(one, tasks) for r in rr]
    rows.sort(key=lambda r: (r["config"], r["noise_px"], r["pair"]))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("configs", help="comma-separated configuration names of the spec")
    ap.add_argument("--pairs", type=int, default=20, help="the first N pairs of each configuration")
    ap.add_argument("--noise", default="2", help="comma-separated noise levels (px)")
    ap.add_argument("--spec", default="validate/relative_pose.toml")
    ap.add_argument("--data", default="render/out/relative_pose_benchmark")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", help="write every draw's errors here")
    ap.add_argument("--reseed", type=int, help="other noise draws than the benchmark's (seed [spec seed, pair, K])")
    ap.add_argument("--draws", type=int, default=1,
                    help="draws per pair and noise level above 0 (the spec's draws give the benchmark's own cells)")
    args = ap.parse_args()
    if args.draws < 1:
        ap.error(f"--draws: expected a positive integer, got {args.draws}")
    names = args.configs.split(",")
    noise = [float(x) for x in args.noise.split(",")]
    rows = run_rows(ap, args, names, noise, _one)
    from scipy.stats import wilcoxon

    print("config | noise px | draws | exact rotation | central rotation | exact better | Wilcoxon p | "
          "exact t direction | central t direction (medians, degrees)")
    for name in names:
        for nz in noise:
            sel = [r for r in rows if r["config"] == name and r["noise_px"] == nz]
            both = [r for r in sel if r["exact_deg"] is not None and r["central_deg"] is not None]
            better = sum(r["exact_deg"] < r["central_deg"] for r in both)
            diff = [r["exact_deg"] - r["central_deg"] for r in both]
            p = wilcoxon(diff).pvalue if len(diff) >= 6 and any(diff) else float("nan")
            print(f"{name} | {nz:g} | {len(sel)} | {_median(sel, 'exact_deg'):.3f} | {_median(sel, 'central_deg'):.3f} | "
                  f"{better}/{len(both)} | {p:.2g} | {_median(sel, 'exact_t_dir_deg'):.2f} | "
                  f"{_median(sel, 'central_t_dir_deg'):.2f}")


if __name__ == "__main__":
    main()
