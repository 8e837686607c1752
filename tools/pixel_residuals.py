"""How the detector's pixels scatter about each line's own fitted curve (docs/relative_pose.md,
"The covariance of the image path"): their rms and their autocorrelation along the line.

    .venv/bin/python tools/pixel_residuals.py DATASET VIEW [VIEW ...] [--min-pixels 60] [--lags 8]

Each view's beauty image goes through ``detect_lines``; for every line of at least ``--min-pixels``
pixels the signed first-order distances of its pixels to the plane it was fitted to
(``linefit.planes.plane_distances``), in their order along the curve, give the residual rms
(median over the lines) and the autocorrelation at lags 1..``--lags`` pixels (pooled over the
lines). Independent pixel errors would correlate 0 at every lag.
"""
from __future__ import annotations

import argparse

import numpy as np

from catadioptric.dataset import Dataset
from catadioptric.detect import detect_lines
from catadioptric.linefit.planes import pixel_rays_with_jacobian, plane_distances


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("views", nargs="+")
    ap.add_argument("--min-pixels", type=int, default=60)
    ap.add_argument("--lags", type=int, default=8)
    args = ap.parse_args()
    ds = Dataset(args.dataset)
    for name in args.views:
        v = ds[name]
        det = detect_lines(v["beauty"], v["camera"])
        acc, cnt, rms = np.zeros(args.lags + 1), np.zeros(args.lags + 1), []
        for i, uv in enumerate(det.uv):
            if len(uv) < args.min_pixels:
                continue
            d = plane_distances(det.normal[i][None], pixel_rays_with_jacobian(det.cam, np.asarray(uv)))[0]
            d = d - d.mean()
            rms.append(float(np.sqrt(np.mean(d**2))))
            for k in range(args.lags + 1):
                acc[k] += np.sum(d[:len(d) - k] * d[k:])
                cnt[k] += len(d) - k
        if not rms:
            print(f"{name}: no line of {args.min_pixels} pixels or more")
            continue
        r = acc / cnt
        print(f"{name}: {len(rms)} lines, residual rms median {np.median(rms):.3f} px; autocorrelation at lags "
              f"1..{args.lags}: " + ", ".join(f"{x:.2f}" for x in r[1:] / r[0]))


if __name__ == "__main__":
    main()
