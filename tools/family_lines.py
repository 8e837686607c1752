"""One true family's lines in one benchmark view, as labelled and as detected (issue 9: where a
family the labels identify is lost by the detector).

    .venv/bin/python tools/family_lines.py hyperboloid 4 A 1

Prints the family's labelled lines (segment, pixels), then each detected line that matches one
of them (``detect.evaluate``'s matching: half its pixels within 1.5 px of the label curve): its
pixels, the detected family it was put in (-1: unassigned), its chi-square against the family's
true direction and the true families it agrees with (chi-square at most 9 with the detector's
angle floor of 0.1 degree, ``detect.families``), its plane's standard error; and each detected
family with the true family nearest its direction. Needs the benchmark's datasets.
"""
from __future__ import annotations

import argparse

import numpy as np
from threadpoolctl import threadpool_limits

from catadioptric.dataset import Dataset
from catadioptric.detect import detect_lines
from catadioptric.detect.evaluate import _match_lines, label_curves


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config")
    ap.add_argument("pair", type=int)
    ap.add_argument("side", choices=("A", "B"))
    ap.add_argument("family", type=int, help="the true family's index")
    ap.add_argument("--data", default="render/out/relative_pose_benchmark")
    ap.add_argument("--min-pixels", type=int, default=30)
    args = ap.parse_args()
    renderer = "mitsuba" if args.pair % 2 == 0 else "povray"
    view = Dataset(f"{args.data}/datasets/{args.config}_{renderer}")[f"p{args.pair:02d}{args.side}"]
    with threadpool_limits(1):
        det = detect_lines(view["beauty"], view["camera"])
    truth = label_curves(view)
    match, _ = _match_lines([np.asarray(u) for u in det.uv], truth, 1.5, 0.5)
    dirs = {int(f["index"]): np.asarray(f["direction_M"], float) for f in view["families"]}
    keys = sorted(dirs)
    S = np.array([dirs[k] for k in keys])
    floor2 = np.sin(np.radians(0.1)) ** 2
    print(f"labelled lines of family {args.family} (segment, pixels; {args.min_pixels} or more):",
          [(t["segment"], len(t["uv"])) for t in truth if t["family"] == args.family and len(t["uv"]) >= args.min_pixels])
    for i in range(len(det)):
        if match[i] < 0 or truth[match[i]]["family"] != args.family:
            continue
        n, C = det.normal[i], det.normal_cov[i]
        chi2 = (S @ n) ** 2 / (np.einsum("hi,ij,hj->h", S, C, S) + floor2)
        agree = [k for k, c in zip(keys, chi2) if c <= 9.0]
        print(f"detected line {i}: {len(det.uv[i])} px, segment {truth[match[i]]['segment']} "
              f"({len(truth[match[i]]['uv'])} px labelled), detected family {int(det.family[i])}, chi-square "
              f"{chi2[keys.index(args.family)]:.1f}, agrees with {agree}, plane's standard error "
              f"{np.degrees(np.sqrt(np.trace(C))):.3f} deg")
    for k, f in enumerate(det.families):
        a = np.degrees(np.arccos(np.clip(np.abs(S @ f.direction), 0.0, 1.0)))
        print(f"detected family {k}: {len(f.lines)} lines {f.lines}, nearest true family {keys[int(np.argmin(a))]} "
              f"at {a.min():.2f} deg")


if __name__ == "__main__":
    main()
