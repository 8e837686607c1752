"""Line detection's time on real photographs (issue 41): the four Mei images of ``../shared/real/mei``
(1280x1024 grey, its OpenCV omnidir calibration) and the OCamCalib room of ``tests/data/ocamcalib``
(1920x1080 colour, its ``calib_results.txt``), each detected once per repeat in a fresh process
(the package imported before the clock starts), the best of ``--repeat`` kept.

With ``--baseline DIR`` (another checkout of the project, e.g. ``git worktree add /tmp/base COMMIT``),
the same images go through that code too, in the same run, alternating with this one: the ratios
are then measured on one machine at one time. Each detection's result is hashed (pixels, planes,
families), so the report also says whether the two codes detect the same lines to the last bit.

Written to ``bench/results/detect-real.json``.

Run (about two minutes with a baseline on two cores)::

    .venv/bin/python bench/bench_detect_real.py
    git worktree add /tmp/base 8f7317e && .venv/bin/python bench/bench_detect_real.py --baseline /tmp/base
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from common import metadata, write_json  # noqa: E402

_CHILD = r"""
import hashlib, json, sys, time
sys.path.insert(0, sys.argv[1])
import numpy as np
from catadioptric.formats import load_camera
from catadioptric.detect import detect_lines
from catadioptric.detect.cli import read_image

image, calib = sys.argv[2], sys.argv[3]
cam = load_camera(calib)
img = read_image(image)
t = time.perf_counter()
det = detect_lines(img, cam)
sec = time.perf_counter() - t
h = hashlib.sha256()
for u in det.uv:
    h.update(np.ascontiguousarray(u).tobytes())
h.update(np.ascontiguousarray(det.normal).tobytes())
h.update(np.asarray(det.family).tobytes())
for f in det.families:
    h.update(np.asarray(f.direction).tobytes())
print(json.dumps({"seconds": sec, "lines": len(det), "families": len(det.families), "hash": h.hexdigest()[:16]}))
"""


def _images(real: str) -> list[tuple[str, str, str]]:
    mei = os.path.join(real, "mei")
    out = [(f"mei/{n}", os.path.join(mei, n), os.path.join(mei, "mei_omnidir.yaml"))
           for n in sorted(os.listdir(mei)) if n.startswith("img_para_") and n.endswith(".png")]
    room = os.path.join(ROOT, "tests", "data", "ocamcalib")
    out.append(("ocamcalib/example.jpg", os.path.join(room, "example.jpg"), os.path.join(room, "calib_results.txt")))
    return out


def _detect(code: str, image: str, calib: str) -> dict:
    p = subprocess.run([sys.executable, "-c", _CHILD, code, image, calib], capture_output=True, text=True,
                       env={**os.environ, "PYTHONPATH": code})
    if p.returncode != 0:
        raise SystemExit(f"detection of {image} with the code of {code} failed:\n{p.stderr[-2000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def _commit(code: str) -> str | None:
    """The commit checked out in ``code`` (the report names code by its commit, not by a path of
    this machine)."""
    p = subprocess.run(["git", "-C", code, "rev-parse", "HEAD"], capture_output=True, text=True)
    return p.stdout.strip() or None


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--real", default=os.path.join(os.path.dirname(ROOT), "shared", "real"),
                    help="the folder of real photographs (default ../shared/real)")
    ap.add_argument("--baseline", metavar="DIR", help="another checkout to time beside this one")
    ap.add_argument("--repeat", type=int, default=1, help="detections per image and code (the best is kept)")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "detect-real.json"))
    args = ap.parse_args()
    if not os.path.isdir(os.path.join(args.real, "mei")):
        raise SystemExit(f"--real: expected a folder with mei/ (as ../shared/real), got {args.real!r}")
    if args.baseline is not None and not os.path.isdir(os.path.join(args.baseline, "catadioptric")):
        raise SystemExit(f"--baseline: expected a checkout of the project (a folder with catadioptric/), got "
                         f"{args.baseline!r}")
    codes = {"this": ROOT} | ({} if args.baseline is None else {"baseline": os.path.abspath(args.baseline)})
    rows = []
    for name, image, calib in _images(args.real):
        row = {"image": name}
        for _ in range(max(1, args.repeat)):
            for which, code in codes.items():  # alternating, so that the machine's load falls on both
                r = _detect(code, image, calib)
                best = row.get(which)
                if best is None or r["seconds"] < best["seconds"]:
                    row[which] = r
        if "baseline" in row:
            row["ratio"] = row["baseline"]["seconds"] / row["this"]["seconds"]
            row["same_lines"] = row["baseline"]["hash"] == row["this"]["hash"]
        rows.append(row)
        print(f"{name}: {row['this']['seconds']:.2f} s, {row['this']['lines']} lines"
              + (f"; baseline {row['baseline']['seconds']:.2f} s (x{row['ratio']:.2f}), same lines: "
                 f"{row['same_lines']}" if "baseline" in row else ""), flush=True)
    total = {w: sum(r[w]["seconds"] for r in rows) for w in codes}
    out = {"benchmark": "detect-real", "meta": metadata(), "repeat": args.repeat, "images": rows,
           "total_seconds": total, "baseline_commit": None if args.baseline is None else _commit(args.baseline)}
    if args.baseline is not None:
        out["total_ratio"] = total["baseline"] / total["this"]
        print(f"total: {total['this']:.1f} s against {total['baseline']:.1f} s (x{out['total_ratio']:.2f})")
    write_json(args.out, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
