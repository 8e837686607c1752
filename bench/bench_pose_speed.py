"""The relative pose's seconds on benchmark pairs, and against another revision of the code
(issue 41: "ratios against the current code measured in the same run").

Four measurements, each on the pairs of the relative-pose benchmark's datasets (rendered by
``catadioptric validate benchmark``, default ``render/out/relative_pose_benchmark``):

* ``labels``: :func:`catadioptric.pose.relative_pose` of each pair's labelled lines at ``--noise``
  pixels, one draw per ``--seeds`` (the pixels sampled beforehand, as the benchmark does), at most
  ``--max-pixels`` of each line fitted (default: the library's 40; the benchmark's draws: 1000,
  every pixel);
* ``images``: :func:`catadioptric.relative_pose` of each pair's two beauty images, prior 60 degrees;
* ``images-no-prior``: the same without a motion prior (the default; every family assignment a
  rotation allows is matched and scored);
* ``detection``: :func:`catadioptric.detect.detect_lines` of each view's beauty image.

Each measurement runs in a fresh process (``--measure``), which also writes a digest of every
result (rotations, margins, lines) so that two revisions can be checked to give the same bits.
With ``--compare REV`` the same measurement runs from a temporary ``git worktree`` of ``REV`` and
from this checkout, alternately, ``--rounds`` times each (one process at a time: the machine's own
drift between runs is of the size of small gains, and two processes side by side share its cores),
and the ratio of the medians is reported, with each pair's median seconds (the issue's bars are per
configuration). Written to ``bench/results/pose-speed.json``.

Run (about a minute a round on two cores)::

    .venv/bin/python bench/bench_pose_speed.py
    .venv/bin/python bench/bench_pose_speed.py --compare 35e3db4 --rounds 3
    .venv/bin/python bench/bench_pose_speed.py --what labels --max-pixels 1000 --out bench/results/pose-speed-every-pixel.json
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from common import metadata, write_json  # noqa: E402

#: (dataset of the benchmark, pair): one pair per configuration and renderer's kind
PAIRS = ["sphere_povray:p01", "sphere_mitsuba:p02", "ellipsoid_mitsuba:p04", "ellipsoid_povray:p03",
         "hyperboloid_povray:p07", "hyperboloid_mitsuba:p10", "hyperboloid_9pct_mitsuba:p08",
         "hyperboloid_central_mitsuba:p06"]
WHAT = ("labels", "images", "images-no-prior", "detection")


def _measure(data: str, pairs: list, seeds: list, noise: float, what: str, max_pixels: int = 40) -> dict:
    """Seconds of each item of ``what`` (module docstring) and a digest of the results."""
    import numpy as np

    import catadioptric as cd
    from catadioptric.dataset import Dataset
    from catadioptric.observations import line_pixels
    from catadioptric.pose import ViewLines, relative_pose

    digest = hashlib.sha256()
    seconds = []
    jobs = []
    for item in pairs:
        name, pair = item.split(":")
        folder = os.path.join(data, name)
        ds = Dataset(folder)
        va, vb = ds.view_pair((pair + "A", pair + "B"))
        if what == "labels":
            for seed in seeds:
                rng = np.random.default_rng(seed)
                lines = [line_pixels(v, noise_px=noise, rng=rng) for v in (va, vb)]
                views = [ViewLines(v["camera"], b.uv, b.family, b.segment) for v, b in zip((va, vb), lines)]
                jobs.append(lambda views=views, seed=seed: relative_pose(views[0], views[1], seed=seed,
                                                                         max_pixels=max_pixels))
        elif what in ("images", "images-no-prior"):
            a, b = (os.path.join(folder, pair + s, "beauty.png") for s in "AB")
            prior = 60.0 if what == "images" else None
            jobs.append(lambda a=a, b=b, rig=os.path.join(folder, pair + "A"), prior=prior:
                        cd.relative_pose(a, b, rig, max_rotation_deg=prior).pose)
        else:
            from catadioptric.detect import detect_lines

            for v in (va, vb):
                jobs.append(lambda img=v["beauty"], cam=v["camera"]: detect_lines(img, cam))
    jobs[0]()  # imports and compiled kernels, outside the clock
    for job in jobs:
        t = time.perf_counter()
        res = job()
        seconds.append(time.perf_counter() - t)
        if what == "detection":
            digest.update(np.ascontiguousarray(res.normal).tobytes() + np.asarray(res.family).tobytes())
        else:
            digest.update(np.ascontiguousarray(res.R).tobytes() + np.float64(res.margin).tobytes())
    return {"seconds": seconds, "total": float(sum(seconds)), "median": float(np.median(seconds)),
            "digest": digest.hexdigest()}


def _by_pair(rounds: list, pairs: list) -> dict:
    """Each pair's median seconds over its items (the label path's seeds, the image pair, the two
    views' detections) and the rounds: the issue's bars are per configuration."""
    import numpy as np

    out = {}
    for x in rounds:
        per = len(x["seconds"]) // len(pairs)
        for i, pair in enumerate(pairs):
            out.setdefault(pair, []).extend(x["seconds"][i * per:(i + 1) * per])
    return {pair: float(np.median(v)) for pair, v in out.items()}


def _run(code: str, args, what: str) -> dict:
    """One measurement in a fresh process with the package of ``code`` (a checkout's root)."""
    env = dict(os.environ, PYTHONPATH=code)
    cmd = [sys.executable, os.path.join(HERE, "bench_pose_speed.py"), "--measure", what, "--data", args.data,
           "--noise", str(args.noise), "--max-pixels", str(args.max_pixels), "--seeds", *map(str, args.seeds),
           "--pairs", *args.pairs]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"measurement {what} with {code} failed:\n{p.stderr[-2000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def _worktree(rev: str, where: str) -> str:
    path = os.path.join(where, "code")
    p = subprocess.run(["git", "-C", ROOT, "worktree", "add", "--detach", path, rev], capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"--compare: git cannot check out {rev!r}: {p.stderr.strip()}")
    return path


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=os.path.join(ROOT, "render", "out", "relative_pose_benchmark", "datasets"),
                    help="the benchmark's datasets folder (catadioptric validate benchmark --data D: D/datasets)")
    ap.add_argument("--pairs", nargs="+", default=PAIRS, metavar="DATASET:PAIR")
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1], help="label path: one draw per seed")
    ap.add_argument("--noise", type=float, default=2.0, help="label path: pixel noise (default 2)")
    ap.add_argument("--max-pixels", type=int, default=40,
                    help="label path: pixels fitted per line (default 40, the library's; 1000: the benchmark's)")
    ap.add_argument("--what", nargs="+", choices=WHAT, default=list(WHAT))
    ap.add_argument("--compare", metavar="REV", help="a git revision to time against, alternately")
    ap.add_argument("--rounds", type=int, default=1, help="runs of each code (default 1)")
    ap.add_argument("--measure", choices=WHAT, help=argparse.SUPPRESS)
    ap.add_argument("--out", default=os.path.join(HERE, "results", "pose-speed.json"))
    args = ap.parse_args()
    if args.measure:
        print(json.dumps(_measure(args.data, args.pairs, args.seeds, args.noise, args.measure, args.max_pixels)))
        return 0
    if not os.path.isdir(args.data):
        raise SystemExit(f"--data: {args.data!r} is not a folder; render the benchmark first "
                         f"(catadioptric validate benchmark --out DIR, then --data DIR/datasets)")
    with tempfile.TemporaryDirectory() as tmp:
        codes = {"current": ROOT}
        if args.compare:
            codes = {args.compare: _worktree(args.compare, tmp), "current": ROOT}
        try:
            runs = {w: {c: [] for c in codes} for w in args.what}
            for r in range(args.rounds):
                for w in args.what:
                    for c, code in codes.items():
                        res = _run(code, args, w)
                        runs[w][c].append(res)
                        print(f"round {r + 1} {w:15s} {c:10s} {res['total']:7.2f} s (median {res['median']:.3f} s)",
                              flush=True)
        finally:
            if args.compare:
                subprocess.run(["git", "-C", ROOT, "worktree", "remove", "--force", os.path.join(tmp, "code")],
                               capture_output=True)
    import numpy as np

    out = {"benchmark": "pose-speed", "meta": metadata(), "pairs": args.pairs, "seeds": args.seeds,
           "noise_px": args.noise, "max_pixels": args.max_pixels, "rounds": args.rounds, "compare": args.compare,
           "results": {}}
    for w, by_code in runs.items():
        row = {c: {"total_seconds": [x["total"] for x in xs], "median_item_seconds": [x["median"] for x in xs],
                   "median_seconds_by_pair": _by_pair(xs, args.pairs),
                   "digest": xs[0]["digest"], "same_digest_every_round": len({x["digest"] for x in xs}) == 1}
               for c, xs in by_code.items()}
        if args.compare:
            base, cur = (float(np.median(row[c]["total_seconds"])) for c in (args.compare, "current"))
            row["ratio"] = base / cur
            row["same_results"] = row[args.compare]["digest"] == row["current"]["digest"]
            print(f"{w:15s} {args.compare} {base:.2f} s -> current {cur:.2f} s: {base / cur:.2f}x, "
                  f"results {'identical' if row['same_results'] else 'DIFFER'}")
        for pair in args.pairs:
            print(f"  {w:15s} {pair:34s} " + "  ".join(f"{c} {row[c]['median_seconds_by_pair'][pair]:.2f} s"
                                                  for c in by_code))
        out["results"][w] = row
    write_json(args.out, out)
    print(f"wrote {os.path.relpath(args.out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
