"""How well the colours either side of a detected line tell the same line of two views from another
line of its family (docs/relative_pose.md, "What the matching finds"). Needs
``tools/matching_variants/appearance_gate.patch`` applied (``git apply``: it adds
``catadioptric/detect/appearance.py`` and ``DetectedLines.sides``) and the benchmark's datasets.

    .venv/bin/python tools/appearance_separability.py sphere:2 sphere:4 [--cache DIR]

Each detected line of 30 pixels or more is identified by the labelled segment that holds most of
its pixels (the labels score it only); for every line of A and line of B of the same true family,
the colour distance of their sides (``catadioptric.pose.matching.side_distance``) is counted as a
true pair (the same segment) or a false one. Prints, per threshold, the share of each kept.
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from ambiguous_candidates import DATA, SPEC, _detections  # noqa: E402

from catadioptric.dataset import Dataset  # noqa: E402
from catadioptric.detect.evaluate import _match_lines, label_curves  # noqa: E402
from catadioptric.validate.benchmark import dataset_folder  # noqa: E402
from catadioptric.validate.benchmark_spec import load_benchmark_spec, pairs_of  # noqa: E402

try:
    from catadioptric.pose.matching import side_distance
except ImportError:
    sys.exit("catadioptric.pose.matching has no side_distance: git apply tools/matching_variants/appearance_gate.patch "
             "first")

def pair_distances(cfg, pair, cache, min_pixels=30):
    dets, _ = _detections(cfg, pair, cache)
    if any(getattr(d, "sides", None) is None for d in dets):
        raise SystemExit("the detections carry no sides: apply tools/matching_variants/appearance_gate.patch "
                         "(and use a cache made with it)")
    ds = Dataset(dataset_folder(DATA, cfg["name"], pair.renderer))
    ids = []
    for d, name in zip(dets, pair.names):
        truth = label_curves(ds[name])
        m, _ = _match_lines([np.asarray(u) for u in d.uv], truth, 1.5, 0.5)
        ids.append([(truth[k]["segment"], truth[k]["family"]) if k >= 0 and len(d.uv[i]) >= min_pixels else None
                    for i, k in enumerate(m)])
    true, false = [], []
    for i, a in enumerate(ids[0]):
        for j, b in enumerate(ids[1]):
            if a is None or b is None or a[1] != b[1]:
                continue
            (true if a[0] == b[0] else false).append(float(side_distance(dets[0].sides[i], dets[1].sides[j])))
    return np.array(true), np.array(false)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("pairs", nargs="+", help="CONFIG:PAIR")
    ap.add_argument("--cache", default=None)
    a = ap.parse_args()
    spec = load_benchmark_spec(SPEC)
    by_name = {c["name"]: c for c in spec["configs"]}
    T, F = [], []
    for item in a.pairs:
        name, k = item.split(":")
        t, f = pair_distances(by_name[name], pairs_of(spec, by_name[name])[int(k)], a.cache)
        print(f"{item}: {len(t)} true pairs, {len(f)} false; median distance {np.median(t):.1f} / {np.median(f):.1f}",
              flush=True)
        T.append(t)
        F.append(f)
    T, F = np.concatenate(T), np.concatenate(F)
    for thr in (5, 10, 15, 20, 30, 40, 50):
        print(f"distance <= {thr:2d}: true pairs kept {np.mean(T <= thr):.2f}, false pairs kept {np.mean(F <= thr):.2f}")


if __name__ == "__main__":
    main()
