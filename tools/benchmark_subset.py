"""The label path of the relative-pose benchmark on a few of its pairs, at the noise levels asked:
the exact model's and the central baseline's median rotation and translation-direction errors,
without writing results (for comparing two versions of the code on the same draws).

    .venv/bin/python tools/benchmark_subset.py hyperboloid,sphere --pairs 20 --noise 2 [--json OUT]

The pairs, their seeds and the pixels are the benchmark's (validate/relative_pose.toml, one draw
per pair and noise level unless ``--draws N``, every pixel of each line; with the spec's
``draws`` and ``--pairs 20`` a cell is the benchmark's own, draw for draw, and ``--against
validate/relative_pose/report.json`` sets each cell beside the committed report's draws;
``--from-json ROWS`` prints from rows written by ``--json``); it needs the benchmark's rendered datasets
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
        rows.append({"config": config, "pair": pair.index, "noise_px": d["noise_px"], "draw": d["draw"],
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
    ap.add_argument("--from-json", help="print the table from rows written by --json instead of computing them")
    ap.add_argument("--against", help="a benchmark report.json: each cell's exact model before (the report's draws) "
                                      "and after (these rows), draw by draw")
    args = ap.parse_args()
    if args.draws < 1:
        ap.error(f"--draws: expected a positive integer, got {args.draws}")
    names = args.configs.split(",")
    noise = [float(x) for x in args.noise.split(",")]
    if args.from_json:
        with open(args.from_json) as f:
            rows = json.load(f)
    else:
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
    if args.against:
        against(rows, args.against, names, noise)


def _draw_keys(rows) -> list:
    """``(config, pair, noise, draw)`` of each row; rows written before the ``draw`` field count their
    draws in the order they come within a pair and level (``evaluate_pair``'s order)."""
    seen, keys = {}, []
    for r in rows:
        k = (r["config"], r["pair"], r["noise_px"])
        i = r["draw"] if "draw" in r else seen.get(k, 0)
        seen[k] = seen.get(k, 0) + 1
        keys.append(k + (i,))
    return keys


def against(rows, report_path, names, noise) -> None:
    """Each cell's exact-model rotation before (the draws of ``report_path``, a benchmark report)
    and after (``rows``) on the same draws: medians, draws better after, Wilcoxon signed-rank p,
    and the draws whose scale was held far in each."""
    from scipy.stats import wilcoxon

    with open(report_path) as f:
        rep = json.load(f)
    before = {(p["config"], p["pair"], d["noise_px"], d["draw"]): d for p in rep["pairs"] for d in p["draws"]}
    after = dict(zip(_draw_keys(rows), rows))
    print(f"against {report_path}: config | noise px | draws | before | after | after better | Wilcoxon p | "
          "held far before / after (median rotation errors, degrees)")
    for name in names:
        for nz in noise:
            ks = [k for k in after if k[0] == name and k[2] == nz and k in before
                  and after[k]["exact_deg"] is not None and before[k].get("rotation_error_deg") is not None]
            if not ks:
                continue
            b = np.array([before[k]["rotation_error_deg"] for k in ks])
            a = np.array([after[k]["exact_deg"] for k in ks])
            p = wilcoxon(a - b).pvalue if len(ks) >= 6 and np.any(a != b) else float("nan")
            held_b = sum(bool(before[k].get("scale_held")) for k in ks)
            held_a = sum(bool(after[k].get("scale_held")) for k in ks)
            print(f"{name} | {nz:g} | {len(ks)} | {np.median(b):.3f} | {np.median(a):.3f} | {int(np.sum(a < b))}/{len(ks)} | "
                  f"{p:.2g} | {held_b} / {held_a}")


if __name__ == "__main__":
    main()
