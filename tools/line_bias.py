"""How far the detected lines' planes are off their true family's direction, against their own
covariance, and what the lines far off look like (docs/detect.md, "A line's own rms as its
systematic error").

    .venv/bin/python tools/line_bias.py [--every 5] [--workers 2] [--data render/out/relative_pose_benchmark]

The first view of every ``--every``-th pair of the benchmark's committed image-path results is
detected again (default options); each detected line matched to a labelled line
(``detect.evaluate``'s matching) gets the chi-square of its plane against its labelled line's
family direction as the family vote computes it (``detect.families``: its covariance plus the
0.1-degree floor). Prints that chi-square's median and 90th percentile by line length (a right
covariance gives 0.45 and 2.7), then the lines beyond 9 (the vote's bar) against those within 1:
their length, their pixels' rms about their own plane (``DetectedLines.rms``) and the share of
their pixels within 1.5 px of the labelled line's exact curve. Needs the benchmark's datasets.
"""
from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np


def _view(args):
    from scipy.spatial import cKDTree
    from threadpoolctl import threadpool_limits

    from catadioptric.dataset import Dataset
    from catadioptric.detect import detect_lines
    from catadioptric.detect.evaluate import _match_lines, label_curves

    data, path = args
    r = json.loads(Path(path).read_text())
    view = Dataset(Path(data, "datasets", f"{r['config']}_{r['renderer']}"))[r["views"][0]]
    with threadpool_limits(1):
        det = detect_lines(view["beauty"], view["camera"])
    truth = label_curves(view)
    match, _ = _match_lines([np.asarray(u) for u in det.uv], truth, 1.5, 0.5)
    dirs = {int(f["index"]): np.asarray(f["direction_M"], float) for f in view["families"]}
    floor2 = np.sin(np.radians(det.options["angle_floor_deg"])) ** 2
    rows = []
    for i, k in enumerate(match):
        if k < 0:
            continue
        s, n, C = dirs[truth[k]["family"]], det.normal[i], det.normal_cov[i]
        near, _ = cKDTree(truth[k]["uv"]).query(det.uv[i])
        rows.append((len(det.uv[i]), float((n @ s) ** 2 / (s @ C @ s + floor2)), float(det.rms[i]),
                     float(np.mean(near <= 1.5))))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="render/out/relative_pose_benchmark")
    ap.add_argument("--every", type=int, default=5, help="one pair in this many")
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args()
    paths = sorted(Path(args.data, "results_images").glob("*/p*.json"))[::args.every]
    with ProcessPoolExecutor(args.workers) as ex:
        a = np.array([row for rows in ex.map(_view, [(args.data, p) for p in paths]) for row in rows])
    print(f"{len(paths)} views, {len(a)} lines matched to a labelled line")
    print("length (px) | lines | chi-square median | 90th percentile")
    for lo, hi in ((20, 40), (40, 80), (80, 160), (160, 10**6)):
        x = a[(a[:, 0] >= lo) & (a[:, 0] < hi), 1]
        print(f"{lo}-{hi if hi < 10**6 else ''} | {len(x)} | {np.median(x):.2f} | {np.percentile(x, 90):.2f}")
    far, near = a[:, 1] > 9.0, a[:, 1] <= 1.0
    print(f"beyond 9: {int(far.sum())} lines; within 1: {int(near.sum())}")
    print("medians (beyond 9 / within 1): " + ", ".join(
        f"{name} {np.median(a[far, k]):.2f} / {np.median(a[near, k]):.2f}"
        for name, k in (("length", 0), ("rms px", 2), ("share within 1.5 px of the label", 3))))


if __name__ == "__main__":
    main()
