"""The benchmark's draws that the bar on the free fit's length changes (``pose.scale``:
``MAX_SCALE_STD``, issue 8), run again with the current code, and every cell's median rotation
error before and after.

    .venv/bin/python tools/scale_bar_change.py [validate/relative_pose/report.json] [--workers 2] [--json OUT]

A draw can change only where the report kept the free fit (``scale_held`` false) while its
baseline length's relative deviation (``scale_std``) is at or above ``MAX_SCALE_STD``: everywhere
else both rules choose the same of the same two fits. Each (configuration, pair, noise level)
holding such a draw is evaluated again as the benchmark evaluates it (its seeds, pixels and
three draws); the draws of those pairs that the bar does not touch must come out as in the
report, to the last digit, and the tool says how many did (a check that the rest of the code is
the report's). The cells are then the report's draws with the changed ones replaced: medians
before and after, the Wilcoxon signed-rank p of the change and of the exact model against the
central baseline after it. Needs the benchmark's datasets; a few minutes per changed pair.
"""
from __future__ import annotations

import argparse
import json
import sys
from multiprocessing import get_context
from pathlib import Path

import numpy as np
from scipy.stats import wilcoxon

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchmark_subset import seed_of  # noqa: E402

from catadioptric.pose.scale import MAX_SCALE_STD  # noqa: E402
from catadioptric.validate.benchmark import dataset_folder  # noqa: E402
from catadioptric.validate.benchmark_spec import load_benchmark_spec, pairs_of  # noqa: E402


def _run(job):
    from threadpoolctl import threadpool_limits

    from catadioptric.validate.relative_pose import evaluate_pair

    data, spec, config, pair, noise = job
    with threadpool_limits(1):
        r = evaluate_pair(dataset_folder(data, config, pair.renderer), pair.names, noise_levels=[noise],
                          draws=spec["draws"], seed=seed_of(spec, pair), pixels=spec["pixels"],
                          min_pixels=spec["min_pixels"], max_pixels=spec["max_pixels"])
    return config, pair.index, noise, [(d["draw"], d.get("rotation_error_deg"), d.get("scale_held"), d.get("scale_std"))
                                       for d in r["draws"]]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("report", nargs="?", default="validate/relative_pose/report.json")
    ap.add_argument("--spec", default="validate/relative_pose.toml")
    ap.add_argument("--data", default="render/out/relative_pose_benchmark")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", help="write the draws run again here")
    ap.add_argument("--from-json", help="read the draws run again from here instead of running them")
    args = ap.parse_args()
    rep = json.loads(Path(args.report).read_text())
    spec = load_benchmark_spec(args.spec)
    pairs = {(c["name"], p.index): p for c in spec["configs"] for p in pairs_of(spec, c)}
    before = {}
    touched = set()
    for p in rep["pairs"]:
        for d in p["draws"]:
            key = (p["config"], p["pair"], d["noise_px"], d["draw"])
            before[key] = (d.get("rotation_error_deg"), (d.get("central") or {}).get("rotation_error_deg"))
            if d.get("scale_held") is False and (d.get("scale_std") or 0.0) >= MAX_SCALE_STD:
                touched.add((p["config"], p["pair"], d["noise_px"]))
    print(f"{len(touched)} (configuration, pair, noise level) hold a draw the bar can change "
          f"(free fit kept, length's relative deviation >= {MAX_SCALE_STD:.3f})")
    if args.from_json:
        runs = [tuple(r) for r in json.loads(Path(args.from_json).read_text())]
    else:
        jobs = [(args.data, spec, c, pairs[(c, i)], z) for c, i, z in sorted(touched)]
        with get_context("spawn").Pool(args.workers) as pool:
            runs = list(pool.imap_unordered(_run, jobs))
        if args.json:
            Path(args.json).write_text(json.dumps(runs, indent=1))
    after = {k: v[0] for k, v in before.items()}
    same = changed = 0
    for config, pair, noise, draws in runs:
        for draw, err, held, std in draws:
            key = (config, pair, noise, draw)
            old = before[key][0]
            if err == old:
                same += 1
            else:
                changed += 1
            after[key] = err
    print(f"draws run again: {same + changed}; unchanged to the last digit: {same}; changed: {changed}")
    print("| configuration | noise (px) | exact before | exact after | p (change) | central | p (after vs central) |")
    print("|---|---|---|---|---|---|---|")
    for config in dict.fromkeys(k[0] for k in before):
        for noise in sorted({k[2] for k in before if k[0] == config}):
            keys = [k for k in before if k[0] == config and k[2] == noise]
            b = np.array([before[k][0] for k in keys], float)
            a = np.array([after[k] for k in keys], float)
            c = np.array([before[k][1] for k in keys], float)
            diff = np.any(a != b)
            p_change = wilcoxon(a, b).pvalue if diff else float("nan")
            ok = np.isfinite(a) & np.isfinite(c)
            p_c = wilcoxon(a[ok], c[ok]).pvalue if np.any(a[ok] != c[ok]) else float("nan")
            print(f"| {config} | {noise:g} | {np.nanmedian(b):.3f} | {np.nanmedian(a):.3f} | {p_change:.2g} | "
                  f"{np.nanmedian(c):.3f} | {p_c:.2g} |")


if __name__ == "__main__":
    main()
