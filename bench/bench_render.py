"""Rendering benchmark: seconds per 640x480 view for each renderer (beauty + labels + float64
ground truth + files) and views per minute of a dataset rendered with --workers 1 and 2.

    .venv/bin/python bench/bench_render.py [--scene urban_street] [--views 6] [--size 640x480]
                                           [--line-images core|sampled]

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


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="urban_street", help="scene spec name or file (default urban_street)")
    ap.add_argument("--views", type=int, default=6, help="views in the dataset runs (default 6)")
    ap.add_argument("--size", default="640x480", help="image size WIDTHxHEIGHT (default 640x480)")
    ap.add_argument("--renderers", default="mitsuba,povray")
    ap.add_argument("--line-images", default="core", choices=["core", "sampled"])
    args = ap.parse_args()
    w, h = (int(x) for x in args.size.split("x"))
    res = run(args.scene, args.views, (w, h), tuple(args.renderers.split(",")), args.line_images)
    name = "render.json" if args.line_images == "core" else f"render-{args.line_images}.json"
    path = os.path.join(HERE, "results", name)
    write_json(path, {"benchmark": "render", "meta": metadata(), **res})
    print(f"wrote {os.path.relpath(path)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
