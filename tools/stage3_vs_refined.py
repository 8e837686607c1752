"""The exact model's rotation before its two-view refinement (stage 3: directions and meeting rays
through each view's centre) and after it, next to the central baseline, on the benchmark's own
draws (issue 8: on near-central rigs the refinement ended worse than its start).

    .venv/bin/python tools/stage3_vs_refined.py hyperboloid --pairs 20 --noise 2 --draws 3

Per configuration: the medians of the refined rotation's error (the answer), of the start of the
refinement that gave it, and of the central baseline, and how many draws the refinement improved.
Needs the benchmark's datasets (render/out/relative_pose_benchmark).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchmark_subset import run_rows, seed_of  # noqa: E402


def _one(args):
    data, spec, config, pair, noise = args
    import catadioptric.pose.relative as rel
    from catadioptric.pose import rotation_angle_deg
    from catadioptric.validate.benchmark import dataset_folder
    from catadioptric.validate.relative_pose import evaluate_pair

    calls = []
    real = rel._noncentral_candidate

    def spy(cand, *a, **k):
        fit, n = real(cand, *a, **k)
        calls.append((cand.R.copy(), None if fit is None else fit.R.copy()))
        return fit, n

    rel._noncentral_candidate = spy
    r = evaluate_pair(dataset_folder(data, config, pair.renderer), pair.names, noise_levels=noise,
                      draws=spec["subset_draws"], seed=seed_of(spec, pair), pixels=spec["pixels"],
                      min_pixels=spec["min_pixels"], max_pixels=spec["max_pixels"])
    R_gt = np.asarray(r["R_gt"])
    rows = []
    for d in r["draws"]:
        R = np.asarray(d["R"])
        start = [s for s, f in calls if f is not None and np.allclose(f, R, atol=1e-12)]
        rows.append({"config": config, "pair": pair.index, "noise_px": d["noise_px"],
                     "refined": d.get("rotation_error_deg"),
                     "stage3": rotation_angle_deg(start[-1] @ R_gt.T) if start else None,
                     "central": d.get("central", {}).get("rotation_error_deg")})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("configs", help="comma-separated configuration names of the spec")
    ap.add_argument("--pairs", type=int, default=20, help="the first N pairs of each configuration")
    ap.add_argument("--noise", type=float, default=2.0)
    ap.add_argument("--draws", type=int, default=3, help="draws per pair (the spec's 3: the benchmark's own cell)")
    ap.add_argument("--spec", default="validate/relative_pose.toml")
    ap.add_argument("--data", default="render/out/relative_pose_benchmark")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", help="write every draw's errors here")
    args = ap.parse_args()
    names = args.configs.split(",")
    rows = run_rows(ap, args, names, [args.noise], _one)
    print("config | draws | refined | stage 3 | central | refinement better (median rotation errors, degrees)")
    for n in names:
        sel = [r for r in rows if r["config"] == n and r["stage3"] is not None]
        med = lambda k: float(np.median([r[k] for r in sel if r[k] is not None]))
        better = sum(r["refined"] < r["stage3"] for r in sel)
        print(f"{n} | {len(sel)} | {med('refined'):.3f} | {med('stage3'):.3f} | {med('central'):.3f} | {better}/{len(sel)}")


if __name__ == "__main__":
    main()
