"""A lead for the scale's choice (issue 8): a third refinement, the scene held far but started from
the free fit's end (its rotation, directions and lines, scaled about the centres until the
baseline is ``FAR`` mirror sizes), next to the free fit, the far fit started from the search's
start, and the answer ``relative_pose`` gives, on the box-scene pairs of
``tests/test_relative_pose.py``.

    .venv/bin/python tools/far_from_free.py

Prints the rotation error (degrees) of each per pair. The fits are those of the last candidate
``relative_pose`` refined (the answer's, where one candidate is refined).
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from scale_choice import far_from_free_fit  # noqa: E402
from test_relative_pose import _pair  # noqa: E402

from catadioptric.pose import relative_pose, rotation_angle_deg  # noqa: E402
from catadioptric.pose import scale as sm  # noqa: E402

CASES = [("hyperboloid", 1.0, 4), ("hyperboloid", 1.0, 1), ("hyperboloid", 2.0, 4), ("hyperboloid", 2.0, 5),
         ("sphere", 2.0, 4), ("sphere", 1.0, 4), ("hyperboloid_9pct", 2.0, 4), ("ellipsoid", 2.0, 4)]


def main() -> None:
    fits = {}
    real = sm.far_and_free_fits

    def with_far_from_free(cam_a, cam_b, R0, t0, dirs0, points0, line_family, uv_a, owner_a, uv_b, owner_b, *,
                           centres, far=sm.FAR, **kw):
        free, held = real(cam_a, cam_b, R0, t0, dirs0, points0, line_family, uv_a, owner_a, uv_b, owner_b,
                          centres=centres, far=far, **kw)
        fits["all"] = (free, held, far_from_free_fit(free, cam_a, cam_b, line_family, uv_a, owner_a, uv_b, owner_b,
                                                     centres=centres, **kw))
        return free, held

    sm.far_and_free_fits = with_far_from_free
    print("rig | noise px | seed | answer | free | far | far from free  (rotation error, degrees)")
    for name, noise, seed in CASES:
        va, vb, R_gt, _ = _pair(name, noise=noise, seed=seed)
        res = relative_pose(va, vb)
        err = [rotation_angle_deg(R @ R_gt.T) for R in (res.R, *(f.R for f in fits["all"]))]
        print(f"{name} | {noise:g} | {seed} | " + " | ".join(f"{e:.3f}" for e in err), flush=True)


if __name__ == "__main__":
    main()
