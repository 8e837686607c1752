"""The committed benchmark report written again from the per-pair results already computed (the
label path's and the image path's, each keyed by the code that made it), without computing any:
for when one path's results were computed again with newer code and the other's still stand.

    .venv/bin/python tools/rewrite_report.py [--spec validate/relative_pose.toml] \\
        [--data render/out/relative_pose_benchmark] [--out validate/relative_pose] [--images-seconds S]

The report's command stays the one that computes everything; the report's timing keeps the label
path's from the existing ``report.json`` (``--images-seconds``: the image path's wall time of the
run that computed its results). Each pair's result names its code digest (``code``); the script
prints the digests found, so that the note can say which commit made which figures.
"""
from __future__ import annotations

import argparse
import collections
import json
import os
from pathlib import Path

from catadioptric.validate.benchmark import overlay_paths, results_folder
from catadioptric.validate.benchmark_report import write_benchmark_report
from catadioptric.validate.benchmark_spec import load_benchmark_spec, pairs_of


def _results(spec, data, kind):
    out = []
    for config in spec["configs"]:
        for p in pairs_of(spec, config):
            path = Path(results_folder(data, kind), config["name"], f"p{p.index:02d}.json")
            if not path.is_file():
                raise SystemExit(f"{path}: missing; run the benchmark first")
            out.append(json.loads(path.read_text()))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spec", default="validate/relative_pose.toml")
    ap.add_argument("--data", default="render/out/relative_pose_benchmark")
    ap.add_argument("--out", default="validate/relative_pose")
    ap.add_argument("--images-seconds", type=float, help="the image path's wall time (default: as reported)")
    args = ap.parse_args()
    spec = load_benchmark_spec(args.spec)
    old = json.loads(Path(args.out, "report.json").read_text())
    timing = dict(old["timing"])
    if args.images_seconds is not None:
        timing["images_seconds"] = args.images_seconds
    labels, images = _results(spec, args.data, "labels"), _results(spec, args.data, "images")
    for name, rs in (("labels", labels), ("images", images)):
        print(f"{name}: code digests {dict(collections.Counter(r['code'][:8] for r in rs))}")
    write_benchmark_report(spec, labels, args.out, command=old["command"], timing=timing, image_results=images,
                           overlays=overlay_paths(spec, args.data))
    print(f"wrote {os.path.join(args.out, 'report.md')}")


if __name__ == "__main__":
    main()
