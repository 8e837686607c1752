"""The exact model's two-view refinement with the scene's scale held at several lengths, on the
benchmark's own draws (issue 8: on near-central rigs at 2 px the refined rotation is worse than
its start and than the central baseline; is holding the scene far, 500-750 m, the cause?).

    .venv/bin/python tools/hold_length.py hyperboloid --pairs 20 --noise 2 --draws 3 [--json OUT]

Per draw, from the refinement's own start (``pose.relative`` calls ``refine_far_or_free``; this
tool records its arguments): the free fit, the far fit (``scale.FAR``, the rule's), fits held at
baselines of fixed lengths (``--lengths``, metres) and one held at the true baseline's length
(an oracle: what the best possible hold gives), each fit's rotation error, next to the answer and
the central baseline on the same draw. Prints the median per configuration and noise level and
how many draws each hold beats the far fit. Needs the benchmark's datasets.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchmark_subset import run_rows, seed_of  # noqa: E402

from catadioptric.validate.benchmark import dataset_folder  # noqa: E402

_LENGTHS: tuple = ()


def _held_at(cam_a, cam_b, R0, t0, dirs0, points0, args, centres, length, kw):
    """The refinement from its start scaled about the centres to a baseline of ``length`` metres,
    the scale held there."""
    from catadioptric.pose import scale

    ca, cb = (np.asarray(c, float) for c in centres)
    base = R0 @ ca + np.asarray(t0, float) - cb
    f = length / float(np.linalg.norm(base))
    t, pts = f * base - R0 @ ca + cb, ca + f * (np.asarray(points0, float) - ca)
    return scale.refine_two_view(cam_a, cam_b, R0, t, dirs0, pts, *args, centres=centres, hold_scale=True,
                                 release_scale=0.0, **kw)


def _one(job):
    global _LENGTHS
    import catadioptric.pose.relative as rel
    import catadioptric.validate.relative_pose as vrp
    from catadioptric.pose import scale

    data, spec, config, pair, noise = job
    _LENGTHS = tuple(spec["hold_lengths"])
    real = scale.refine_far_or_free
    fits = []

    def spy(cam_a, cam_b, R0, t0, dirs0, points0, *args, centres, **kw):
        answer = real(cam_a, cam_b, R0, t0, dirs0, points0, *args, centres=centres, **kw)
        held = {f"{L:g} m": _held_at(cam_a, cam_b, R0, t0, dirs0, points0, args, centres, L, kw).R for L in _LENGTHS}
        free, far = scale.far_and_free_fits(cam_a, cam_b, R0, t0, dirs0, points0, *args, centres=centres, **kw)
        fits.append({"answer": answer.R, "free": free.R, "far": None if far is None else far.R, **held,
                     "_hold": lambda L: _held_at(cam_a, cam_b, R0, t0, dirs0, points0, args, centres, L, kw).R})
        return answer

    rel.refine_far_or_free = spy
    record = vrp._record

    def rec(res, R_gt, t_gt, *a):
        out = record(res, R_gt, t_gt, *a)
        fit = res.candidates[0].fit if res.candidates else None
        mine = [f for f in fits if fit is not None and np.allclose(f["answer"], fit.R, atol=1e-12)]
        if mine:
            f = mine[-1]
            out["holds"] = {k: vrp._rotation_error_deg(R, R_gt) for k, R in f.items()
                            if not k.startswith("_") and R is not None}
            out["holds"]["true length"] = vrp._rotation_error_deg(f["_hold"](float(np.linalg.norm(t_gt))), R_gt)
        fits.clear()
        return out

    vrp._record = rec
    r = vrp.evaluate_pair(dataset_folder(data, config, pair.renderer), pair.names, noise_levels=noise,
                          draws=spec["subset_draws"], seed=seed_of(spec, pair), pixels=spec["pixels"],
                          min_pixels=spec["min_pixels"], max_pixels=spec["max_pixels"])
    return [{"config": config, "pair": pair.index, "noise_px": d["noise_px"], "answer": d.get("rotation_error_deg"),
             "central": d.get("central", {}).get("rotation_error_deg"), **(d.get("holds") or {})}
            for d in r["draws"]]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("configs", help="comma-separated configuration names of the spec")
    ap.add_argument("--pairs", type=int, default=20)
    ap.add_argument("--noise", default="2")
    ap.add_argument("--draws", type=int, default=3, help="draws per pair (the spec's 3: the benchmark's own cell)")
    ap.add_argument("--lengths", default="2,5,10,20", help="comma-separated held baseline lengths (metres)")
    ap.add_argument("--spec", default="validate/relative_pose.toml")
    ap.add_argument("--data", default="render/out/relative_pose_benchmark")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", help="write every draw's row here")
    ap.add_argument("--from-json", help="print the table from these rows instead of running")
    args = ap.parse_args()
    names = args.configs.split(",")
    noise = [float(x) for x in args.noise.split(",")]
    if args.from_json:
        rows = json.loads(Path(args.from_json).read_text())
    else:
        import catadioptric.validate.benchmark_spec as bs

        load = bs.load_benchmark_spec
        lengths = [float(x) for x in args.lengths.split(",")]

        def with_lengths(path):
            spec = load(path)
            spec["hold_lengths"] = lengths
            return spec

        sys.modules["benchmark_subset"].load_benchmark_spec = with_lengths
        rows = run_rows(ap, args, names, noise, _one)
    keys = [k for k in rows[0] if k not in ("config", "pair", "noise_px")] if rows else []
    for n in names:
        for z in noise:
            cell = [r for r in rows if r["config"] == n and r["noise_px"] == z]
            if not cell:
                continue
            print(f"{n} {z:g} px ({len(cell)} draws): median rotation error, degrees (draws better than the far fit)")
            for k in keys:
                v = [r[k] for r in cell if r.get(k) is not None]
                better = sum(1 for r in cell if r.get(k) is not None and r.get("far") is not None and r[k] < r["far"])
                print(f"  {k:>12}: {np.median(v):.3f}  ({better} of {len(v)})")


if __name__ == "__main__":
    main()
