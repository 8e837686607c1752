"""Why answers from two images alone come out ambiguous on the relative-pose benchmark
(docs/relative_pose.md, "What the matching finds"): each answer's candidates scored by the labels.

    .venv/bin/python tools/ambiguous_candidates.py summary [--configs sphere ...] [--cache DIR] [--seed S]
    .venv/bin/python tools/ambiguous_candidates.py show sphere:0 sphere:2 [--joint] [--cache DIR]

``summary``: every pair's answer (prior ``--prior``, default 60; families found in both views at
once not added), whether it is ambiguous, its margin and rotation error; then how many ambiguous
answers have their best candidate within 5 degrees of the truth. ``show``: per pair, the
candidates in order (score above the best, rotation error, angle from the answer, families
mapped, lines matched, meeting rays verified) and, with ``--joint``, the families that
:func:`catadioptric.detect.joint_families.joint_families` finds in both views under each
candidate's rotation (lines in A / B). ``--cache DIR``: keep each pair's detections there (the
detection takes most of the time). Needs the benchmark's datasets (README, "relative pose
benchmark").

``matching_variants/near_segments.patch`` (``git apply`` it, then run ``summary``) keeps only the
meeting rays within 20 pixels of both lines' seen arcs, ``matching_variants/appearance_gate.patch``
pairs only lines that look alike (the colours either side; ``tools/appearance_separability.py``
measures the cue): the variants measured in the docs.
"""
from __future__ import annotations

import argparse
import dataclasses
import os
import pickle

import numpy as np

from catadioptric._checks import CatadioptricError
from catadioptric.dataset import Dataset
from catadioptric.detect import detect_lines
from catadioptric.detect.joint_families import joint_families
from catadioptric.pose import rotation_angle_deg
from catadioptric.twoview import pose_from_detections
from catadioptric.validate.benchmark import dataset_folder
from catadioptric.validate.benchmark_spec import load_benchmark_spec, pairs_of

DATA = "render/out/relative_pose_benchmark"
SPEC = "validate/relative_pose.toml"


def _detections(cfg, pair, cache):
    ds = Dataset(dataset_folder(DATA, cfg["name"], pair.renderer))
    views = [ds[n] for n in pair.names]
    R_gt = views[1]["pose"].R @ views[0]["pose"].R.T
    path = os.path.join(cache, f"{cfg['name']}_p{pair.index:02d}.pkl") if cache else None
    if path and os.path.exists(path):
        with open(path, "rb") as f:
            dets = pickle.load(f)
        return [dataclasses.replace(d, cam=v["camera"]) for d, v in zip(dets, views)], R_gt
    dets = [detect_lines(v["beauty"], v["camera"]) for v in views]
    if path:
        os.makedirs(cache, exist_ok=True)
        with open(path + ".tmp", "wb") as f:  # the camera does not pickle: it is read back from the dataset
            pickle.dump([dataclasses.replace(d, cam=None) for d in dets], f)
        os.replace(path + ".tmp", path)
    return dets, R_gt


def _answer(cfg, pair, prior, cache, seed=0):
    dets, R_gt = _detections(cfg, pair, cache)
    pose = pose_from_detections(dets[0], dets[1], min_pixels=30, max_rotation_deg=prior, joint=False, seed=seed).pose
    return dets, R_gt, pose


def _mapping(c):
    return {int(b): (int(a), int(s)) for b, v in c.signs.items() if isinstance(v, tuple) for a, s in [v]}


def summary(spec, configs, prior, cache, seed=0):
    n = n_amb = n_amb_right = 0
    for cfg in spec["configs"]:
        if configs and cfg["name"] not in configs:
            continue
        for pair in pairs_of(spec, cfg):
            try:
                _, R_gt, pose = _answer(cfg, pair, prior, cache, seed)
            except CatadioptricError as exc:
                print(f"{cfg['name']}:{pair.index} error: {exc}")
                continue
            err = rotation_angle_deg(pose.R @ R_gt.T)
            n += 1
            n_amb += pose.ambiguous
            n_amb_right += pose.ambiguous and err < 5.0
            print(f"{cfg['name']}:{pair.index} {'ambiguous' if pose.ambiguous else 'decisive'} margin "
                  f"{pose.margin:.1f} rotation error {err:.2f} deg", flush=True)
    print(f"{n} pairs answered, {n_amb} ambiguous, of which {n_amb_right} with the best candidate within 5 degrees "
          "of the truth")


def show(spec, items, prior, cache, joint, seed=0):
    by_name = {c["name"]: c for c in spec["configs"]}
    for item in items:
        name, k = item.split(":")
        cfg = by_name[name]
        dets, R_gt, pose = _answer(cfg, pairs_of(spec, cfg)[int(k)], prior, cache, seed)
        da, db = dets
        std = pose.rotation_std_deg if np.isfinite(pose.rotation_std_deg) else 0.5
        print(f"{item}: {'ambiguous' if pose.ambiguous else 'decisive'}, margin {pose.margin:.1f}, rotation error "
              f"{rotation_angle_deg(pose.R @ R_gt.T):.2f} deg")
        best = pose.candidates[0].cost
        for c in pose.candidates[:8]:
            lm = c.fit
            line = (f"   +{c.cost - best:6.1f}  error {rotation_angle_deg(c.R @ R_gt.T):6.2f}  from answer "
                    f"{rotation_angle_deg(c.R @ pose.R.T):6.2f}  families {len(c.signs)}  lines "
                    f"{len(getattr(lm, 'pairs', []))}  verified {getattr(lm, 'n_inliers', '-')}/"
                    f"{getattr(lm, 'n_crossings', '-')}")
            if joint:
                m = _mapping(c)
                found = joint_families(da, db, c.R, min_pixels=30, rotation_std_deg=std,
                                       taken_a=[i for a, _ in m.values() for i in da.families[a].lines],
                                       taken_b=[i for b in m for i in db.families[b].lines],
                                       known_directions=[da.families[a].direction for a, _ in m.values()])
                line += "  joint " + (", ".join(f"{len(f.lines_a)}/{len(f.lines_b)}" for f in found) or "none")
            print(line)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("summary")
    s.add_argument("--configs", nargs="*", default=[])
    w = sub.add_parser("show")
    w.add_argument("pairs", nargs="+", help="CONFIG:PAIR")
    w.add_argument("--joint", action="store_true")
    for p in (s, w):
        p.add_argument("--prior", type=float, default=60.0)
        p.add_argument("--cache", default=None)
        p.add_argument("--seed", type=int, default=0, help="the matching's RANSAC seed")
    a = ap.parse_args()
    spec = load_benchmark_spec(SPEC)
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1):
        if a.cmd == "summary":
            summary(spec, a.configs, a.prior, a.cache, a.seed)
        else:
            show(spec, a.pairs, a.prior, a.cache, a.joint, a.seed)


if __name__ == "__main__":
    main()
