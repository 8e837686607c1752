"""The benchmark's views of one renderer rendered again at another quality preset, into a data
folder of their own, the other renderer's datasets linked from the benchmark's: the image-only path
can then be run on them (``tools/image_path_options.py --data DATA --renderer R``) and set beside
the benchmark's run (``tools/image_results_compare.py compare``).

    .venv/bin/python tools/render_quality.py --quality high --renderer mitsuba \\
        --data render/out/relative_pose_benchmark_high [--spec validate/relative_pose.toml] [--workers 2]

The views are the spec's (same poses, scene, resolution and rig); only the beauty image changes
with the preset (the label pass is exact in every preset: catadioptric/data/quality.toml). Views
already rendered are kept (a rerun resumes). Prints the render seconds per view.
"""
from __future__ import annotations

import argparse
import os
import time

from catadioptric.cliargs import parse_resolution
from catadioptric.render.dataset import render_dataset
from catadioptric.rigspec import load_rig
from catadioptric.validate.benchmark import benchmark_scene, dataset_folder
from catadioptric.validate.benchmark_spec import load_benchmark_spec, pairs_of


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quality", required=True, help="a preset of catadioptric/data/quality.toml")
    ap.add_argument("--renderer", choices=("mitsuba", "povray"), default="mitsuba")
    ap.add_argument("--data", required=True, help="the new data folder (datasets/ goes into it)")
    ap.add_argument("--base", default="render/out/relative_pose_benchmark",
                    help="the benchmark's data folder, whose other renderer's datasets are linked")
    ap.add_argument("--spec", default="validate/relative_pose.toml")
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args()
    spec = load_benchmark_spec(args.spec)
    w, h = parse_resolution(spec["resolution"], "resolution")
    scene = benchmark_scene(spec)
    os.makedirs(os.path.join(args.data, "datasets"), exist_ok=True)
    seconds, views_done = 0.0, 0
    for config in spec["configs"]:
        for other in set(spec["renderers"]) - {args.renderer}:
            src = os.path.abspath(dataset_folder(args.base, config["name"], other))
            dst = dataset_folder(args.data, config["name"], other)
            if not os.path.lexists(dst):
                if not os.path.isdir(src):
                    ap.error(f"--base: expected the benchmark's dataset {src}, which does not exist")
                os.symlink(src, dst)
        views = [v for p in pairs_of(spec, config) if p.renderer == args.renderer for v in zip(p.names, p.poses)]
        if not views:
            continue
        folder = dataset_folder(args.data, config["name"], args.renderer)
        print(f"[{config['name']} / {args.renderer} / {args.quality}] {len(views)} views -> {folder}", flush=True)
        t = time.perf_counter()
        manifest = render_dataset(scene, views, load_rig(config["rig"], width=w, height=h), folder,
                                  renderer=args.renderer, quality=args.quality, workers=args.workers,
                                  rig={"name": config["rig"]})
        n = len(manifest["run"]["rendered"])
        seconds += time.perf_counter() - t
        views_done += n
    if views_done:
        print(f"rendered {views_done} views in {seconds:.0f} s wall ({seconds / views_done:.2f} s per view, "
              f"{args.workers} workers)")


if __name__ == "__main__":
    main()
