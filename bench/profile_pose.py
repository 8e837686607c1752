"""Where the relative pose spends its time, by stage (issue 41, item 1): one draw of the label path
and one image pair, each profiled (``cProfile``) on a rendered pair.

The pair: ``urban_street`` rendered by POV-Ray at 640x480 (``--data`` to reuse a dataset folder of two
views A and B). The label path: :func:`catadioptric.relative_pose_from_labels` at ``--noise`` pixels
(seed 0). The image path: :func:`catadioptric.relative_pose` of the two beauty images with the
motion prior of 60 degrees (the README's example); its detection's stages come from each
detection's own clock (``DetectedLines.seconds``), the pose's from the profile.

A stage's seconds are the cumulative time of its function (the calls it makes included), so nested
stages overlap: ``refine_two_view`` runs inside ``refine_far_or_free``, projections inside both. The
rows say which contains which. Written to ``bench/results/profile-pose.json`` with the hottest
functions by their own time.

Run (about two minutes on two cores)::

    .venv/bin/python bench/profile_pose.py
    .venv/bin/python bench/profile_pose.py --data out/demo/urban_street_mitsuba --noise 2
"""
from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from common import metadata, write_json  # noqa: E402

#: (stage, module path suffix, function name, inside): the functions timed, and the stage each runs in
STAGES = [
    ("families of each view (plane fits)", "pose/families.py", "fit_view_families", "pose"),
    ("family assignments (no labels)", "pose/matching.py", "family_matches", "pose"),
    ("lines matched by their meeting points (no labels)", "pose/matching.py", "match_lines", "pose"),
    ("rotation candidates (signs)", "pose/signs.py", "sign_candidates", "pose"),
    ("translation direction from meeting rays", "pose/central.py", "translation_direction_from_crossings", "pose"),
    ("rotation and direction refined together", "pose/epipolar.py", "refine_with_crossings", "pose"),
    ("far or free scale (both fits)", "pose/scale.py", "refine_far_or_free", "pose"),
    ("two-view refinement on the pixels", "pose/bundle.py", "refine_two_view", "far or free scale"),
    ("  its residuals", "pose/two_view_rays.py", "residuals", "two-view refinement"),
    ("  its Jacobians", "pose/two_view_rays.py", "jacobian", "two-view refinement"),
    ("  its normal equations and solves", "pose/bundle.py", "_solve_step", "two-view refinement"),
    ("scale by search", "pose/scale.py", "scale_by_search", "pose"),
    ("families found in both views at once", "detect/joint_families.py", "joint_families", "image pair"),
    ("forward projection (every caller)", "catadioptric/projection.py", "project", "all"),
]


def _render(out: str) -> None:
    from catadioptric.cli import main

    if main(["render", "urban_street", "--renderer", "povray", "--resolution", "vga", "--out", out,
             "--no-progress"]) != 0:
        raise SystemExit("render failed")


def _profiled(fn):
    """``fn()``, its seconds, and the profile of every thread it ran: the far refinement runs in a
    thread of its own beside the free one (``relative_pose(threads=2)``, the default), where the
    caller's profiler does not see it; each new thread gets a profiler of its own (its first
    event starts it), and their statistics are added. A stage's seconds are then the sum over the
    threads (two refinements side by side count twice, as one after the other would)."""
    others = []

    def start(frame, event, arg):
        p = cProfile.Profile()
        others.append(p)
        p.enable()  # replaces this hook in the new thread

    prof = cProfile.Profile()
    threading.setprofile(start)
    t = time.perf_counter()
    prof.enable()
    try:
        result = fn()
    finally:
        prof.disable()
        threading.setprofile(None)
    seconds = time.perf_counter() - t
    stats = pstats.Stats(prof)
    for p in others:  # their threads have ended with the refinements' pools
        p.create_stats()
        stats.add(p)
    return result, seconds, stats


def _stages(stats: pstats.Stats, total: float) -> list[dict]:
    rows = []
    for name, suffix, func, inside in STAGES:
        cum = calls = 0
        for (path, _line, fname), (_cc, nc, _tt, ct, _callers) in stats.stats.items():
            if fname == func and path.replace(os.sep, "/").endswith(suffix):
                cum += ct
                calls += nc
        if calls:
            rows.append({"stage": name.strip(), "function": f"{suffix}:{func}", "inside": inside, "calls": calls,
                         "seconds": round(cum, 3), "share": round(cum / total, 3)})
    return rows


def _hottest(stats: pstats.Stats, n: int = 15) -> list[dict]:
    items = sorted(stats.stats.items(), key=lambda kv: -kv[1][2])[:n]
    return [{"function": f"{os.path.basename(path)}:{line}:{fname}", "own_seconds": round(tt, 3), "calls": nc}
            for (path, line, fname), (_cc, nc, tt, _ct, _callers) in items]


def _described(data: str) -> dict:
    """A dataset given with ``--data``, by what it holds (its manifest's scene, seed and digest), not
    by a path of this machine."""
    import json

    with open(os.path.join(data, "manifest.json")) as f:
        scene = json.load(f).get("scene", {})
    return {"given": "--data", "scene": scene.get("name"), "seed": scene.get("seed"), "digest": scene.get("digest")}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", help="a dataset folder with views A and B (default: render urban_street, POV-Ray, VGA)")
    ap.add_argument("--noise", type=float, default=2.0, help="pixel noise of the label path (default 2)")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "profile-pose.json"))
    args = ap.parse_args()

    import catadioptric as cd

    with tempfile.TemporaryDirectory() as tmp:
        data = args.data
        if data is None:
            data = os.path.join(tmp, "urban_street")
            _render(data)
        print("label path ...", flush=True)
        lab, lab_s, lab_stats = _profiled(lambda: cd.relative_pose_from_labels(data, "A", "B", noise_px=args.noise))
        print(f"  {lab_s:.1f} s, rotation error {lab.rotation_error_deg:.3f} deg", flush=True)
        print("image path ...", flush=True)
        imgs = [os.path.join(data, v, "beauty.png") for v in "AB"]
        img, img_s, img_stats = _profiled(lambda: cd.relative_pose(imgs[0], imgs[1], os.path.join(data, "A"),
                                                                   max_rotation_deg=60.0))
        print(f"  {img_s:.1f} s, {'ambiguous' if img.pose.ambiguous else 'decisive'}", flush=True)
    detection = {}
    for det in img.detections:
        for k, v in det.seconds.items():
            detection[k] = round(detection.get(k, 0.0) + float(v), 3)
    out = {
        "benchmark": "profile-pose", "meta": metadata(),
        "data": _described(args.data) if args.data else "urban_street, POV-Ray, 640x480",
        "label_path": {"seconds": round(lab_s, 3), "noise_px": args.noise, "model": lab.pose.model,
                       "rotation_error_deg": lab.rotation_error_deg, "stages": _stages(lab_stats, lab_s),
                       "hottest": _hottest(lab_stats)},
        "image_path": {"seconds": round(img_s, 3), "ambiguous": bool(img.pose.ambiguous),
                       "detection_seconds_both_images": detection,
                       "stages": _stages(img_stats, img_s), "hottest": _hottest(img_stats)},
        "note": "stage seconds are cumulative (nested stages overlap; 'inside' says where each runs) and summed "
                "over threads (the far refinement runs beside the free one: its seconds count as its own)",
    }
    write_json(args.out, out)
    print(f"wrote {os.path.relpath(args.out)}")
    for path in ("label_path", "image_path"):
        print(f"[{path}] {out[path]['seconds']} s")
        for r in out[path]["stages"]:
            print(f"  {r['seconds']:8.2f} s  {100 * r['share']:5.1f} %  {r['stage']} ({r['calls']} calls)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
