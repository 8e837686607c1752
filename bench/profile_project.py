"""Where the time of ``cam.project`` goes: cProfile over repeated calls on the projection
benchmark's points (``hyperboloid_9pct``, N = 1e5 by default), the functions by their own time.

    .venv/bin/python bench/profile_project.py [--n 100000] [--calls 5] [--rig hyperboloid_9pct]
"""
from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))

from bench_projection import _points  # noqa: E402

from catadioptric.rigs import preset  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=100_000, help="points per call")
    ap.add_argument("--calls", type=int, default=5, help="calls profiled (after one warm-up call)")
    ap.add_argument("--rig", default="hyperboloid_9pct")
    ap.add_argument("--top", type=int, default=15, help="functions listed")
    args = ap.parse_args()
    cam = preset(args.rig)
    P = _points(cam, args.n, np.random.default_rng(0))
    cam.project(P)  # compiled code loaded, caches warm
    prof = cProfile.Profile()
    prof.enable()
    for _ in range(args.calls):
        cam.project(P)
    prof.disable()
    st = pstats.Stats(prof)
    total = sum(v[2] for v in st.stats.values())  # own time of every function
    print(f"{args.rig}, N = {args.n:,}: {total / args.calls * 1e3:.1f} ms of own time per call")
    rows = sorted(st.stats.items(), key=lambda kv: -kv[1][2])[: args.top]
    for (path, line, name), (_, _, tt, _, _) in rows:
        print(f"  {tt / args.calls * 1e3:7.2f} ms  {tt / total:6.1%}  {os.path.basename(path)}:{line}({name})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
