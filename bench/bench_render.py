"""Rendering benchmark: seconds per 640x480 view for each renderer (beauty + labels + float64
ground truth + files) and views per minute of a dataset rendered with --workers 1 and 2.

    .venv/bin/python bench/bench_render.py [--scene urban_street] [--views 6] [--size 640x480]
                                           [--line-images core|sampled]
    .venv/bin/python bench/bench_render.py --agreement --size 160x120   # label agreement, 24 views

Writes bench/results/render.json (render-sampled.json with --line-images sampled; commit,
versions, machine: bench/common.py). Standalone (not in bench/run.py: it needs POV-Ray
and takes about ten minutes on the 2-core machine).
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))

from common import metadata, write_json  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def _views(spec, n):
    """The spec's views, then the same positions turned about the vertical until there are n."""
    from catadioptric import RigPose
    from catadioptric.scenes import views

    base = views(spec)
    out = list(base)
    k = 0
    while len(out) < n:
        name, pose = base[k % len(base)]
        yaw = np.radians(37.0 * (k // len(base) + 1))
        Rz = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1.0]])
        Rw = Rz @ pose.R.T  # mirror axes in W, turned about W's vertical
        out.append((f"{name}_yaw{k}", RigPose.from_mirror_in_world(Rw, pose.origin_in_world)))
        k += 1
    return out[:n]


def run(scene_name="urban_street", n_views=6, size=(640, 480), renderers=("mitsuba", "povray"),
        line_images="core") -> dict:
    from catadioptric.render.common import load_quality
    from catadioptric.render.dataset import ViewTask, render_dataset, render_view_files
    from catadioptric.render.mitsuba import mitsuba_variant
    from catadioptric.render.povray import povray_version
    from catadioptric.render.tracer import scene_digest
    from catadioptric.scenes import build_scene, scene_rig

    t = time.perf_counter()
    scene = build_scene(scene_name)
    t_build = time.perf_counter() - t
    cam = scene_rig(scene.spec, width=size[0], height=size[1])
    views = _views(scene.spec, n_views)
    scene._catadioptric_digest = scene_digest(scene)
    q = load_quality("standard")
    out = {"scene": {"name": scene.name, "triangles": scene.triangle_count, "segments": int(len(scene.segments)),
                     "build_seconds": t_build},
           "image": list(size), "quality": q, "line_images": line_images, "mitsuba_variant": mitsuba_variant(), "povray": povray_version(),
           "per_view": {}, "dataset": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for r in renderers:
            rows = []
            # first view twice: the first run includes Mitsuba's kernel compilation and the BVH build
            for i, (name, pose) in enumerate([views[0]] + views[:3]):
                task = ViewTask(name, os.path.join(tmp, r, f"{i}_{name}"), r, q, cam.to_dict(), pose.to_dict(), 0,
                                "bench", scene._catadioptric_digest, line_images=line_images)
                res = render_view_files(scene, task)
                rows.append({"view": name, "seconds": res["seconds"], **res["seconds_parts"],
                             "label_differing_pixels": res["label_differing_pixels"]})
                print(f"  {r} {name}: {res['seconds']:.2f} s "
                      + " ".join(f"{k} {v:.2f}" for k, v in res["seconds_parts"].items()), flush=True)
            warm = rows[1:]
            out["per_view"][r] = {"first_view_seconds": rows[0]["seconds"],
                                  "seconds_per_view": float(np.median([x["seconds"] for x in warm])),
                                  "parts_median": {k: float(np.median([x[k] for x in warm]))
                                                   for k in ("render", "trace", "groundtruth", "files")},
                                  "views": rows}
            for workers in (1, 2):
                d = os.path.join(tmp, f"ds_{r}_{workers}")
                t = time.perf_counter()
                m = render_dataset(scene, views, cam, d, renderer=r, quality=q, workers=workers, progress=False,
                                   line_images=line_images)
                dt = time.perf_counter() - t
                out["dataset"][f"{r}_workers{workers}"] = {
                    "views": len(views), "seconds": dt, "views_per_minute": 60.0 * len(views) / dt,
                    "label_differing_pixels": m["label_agreement"]["differing_pixels"],
                    "pixels": m["label_agreement"]["pixels"]}
                print(f"  {r} dataset of {len(views)} views, --workers {workers}: {dt:.1f} s, "
                      f"{60 * len(views) / dt:.1f} views/min", flush=True)
    return out


def agreement(size=(160, 120)) -> dict:
    """Label images of both renderers against the float64 tracer on 24 views: the test street
    seen by six rigs (three views each) and the tiny_street, chessboard and urban_street specs
    (two views each). Counts differing pixels, and those off the tie pixels."""
    from catadioptric.render.mitsuba import render_mitsuba
    from catadioptric.render.povray import render_povray
    from catadioptric.render.testscene import street_scene, street_views
    from catadioptric.render.tracer import trace_rays
    from catadioptric.rigspec import load_rig
    from catadioptric.scenes import build_scene, scene_rig, views

    W, H = size
    cases = []
    street = street_scene(0)
    for rig in ("hyperboloid_9pct", "hyperboloid_central", "sphere", "ellipsoid", "paraboloid", "cone"):
        cases.append(("test_street", rig, street, load_rig(rig, width=W, height=H), street_views(rig)))
    for spec in ("tiny_street", "chessboard", "urban_street"):
        s = build_scene(spec)
        cases.append((spec, s.spec["rig"], s, scene_rig(s.spec, width=W, height=H), views(s.spec)))
    keys = ("mitsuba", "povray", "between", "mitsuba_off_ties", "povray_off_ties", "between_off_ties", "ties")
    total = dict.fromkeys(keys, 0) | {"pixels": 0, "views": 0}
    rows = []
    for name, rig, scene, cam, vs in cases:
        for vn, pose in vs:
            tr = trace_rays(scene, cam, pose)
            mi = render_mitsuba(scene, cam, pose, "draft", beauty=False).labels
            pv = render_povray(scene, cam, pose, "draft", beauty=False).labels
            tie = tr.ambiguous
            dm, dp, db = mi != tr.labels, pv != tr.labels, mi != pv
            row = {"scene": name, "rig": rig, "view": vn, "mitsuba": int(dm.sum()), "povray": int(dp.sum()),
                   "between": int(db.sum()), "mitsuba_off_ties": int((dm & ~tie).sum()),
                   "povray_off_ties": int((dp & ~tie).sum()), "between_off_ties": int((db & ~tie).sum()),
                   "ties": int(tie.sum())}
            rows.append(row)
            for k in keys:
                total[k] += row[k]
            total["pixels"] += tie.size
            total["views"] += 1
            print(f"  {name} {rig} {vn}: " + " ".join(f"{k} {row[k]}" for k in keys), flush=True)
    return {"image": [W, H], "total": total, "views": rows}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="urban_street", help="scene spec name or file (default urban_street)")
    ap.add_argument("--views", type=int, default=6, help="views in the dataset runs (default 6)")
    ap.add_argument("--size", default="640x480", help="image size WIDTHxHEIGHT (default 640x480)")
    ap.add_argument("--renderers", default="mitsuba,povray")
    ap.add_argument("--line-images", default="core", choices=["core", "sampled"])
    ap.add_argument("--agreement", action="store_true",
                    help="instead: label agreement of both renderers with the tracer on 24 views "
                         "(bench/results/render-agreement-WxH.json)")
    args = ap.parse_args()
    w, h = (int(x) for x in args.size.split("x"))
    if args.agreement:
        res = agreement((w, h))
        path = os.path.join(HERE, "results", f"render-agreement-{w}x{h}.json")
        write_json(path, {"benchmark": "render-agreement", "meta": metadata(), **res})
        print(f"wrote {os.path.relpath(path)}: {res['total']}")
        return 0
    res = run(args.scene, args.views, (w, h), tuple(args.renderers.split(",")), args.line_images)
    name = "render.json" if args.line_images == "core" else f"render-{args.line_images}.json"
    path = os.path.join(HERE, "results", name)
    write_json(path, {"benchmark": "render", "meta": metadata(), **res})
    print(f"wrote {os.path.relpath(path)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
