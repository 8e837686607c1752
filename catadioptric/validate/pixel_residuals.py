"""``catadioptric validate pixel-residuals``: how the detector's pixels scatter about each line's
own fitted curve: their rms and their autocorrelation along the line.

    catadioptric validate pixel-residuals DATASET VIEW [VIEW ...] [--min-pixels 60] [--lags 8]

Each view's beauty image goes through :func:`catadioptric.detect.detect_lines`; for every line of
at least ``--min-pixels`` pixels the signed first-order distances of its pixels to the plane it was
fitted to (:func:`catadioptric.linefit.planes.plane_distances`), in their order along the curve,
give the residual rms (median over the lines) and the autocorrelation at lags 1 to ``--lags``
pixels (pooled over the lines). Independent pixel errors would correlate 0 at every lag; the
detector's are small and smooth along the line, which is why the image path's covariance is scaled
(docs/relative_pose.md, "The covariance of the image path").
"""
from __future__ import annotations

import numpy as np

__all__ = ["pixel_residuals", "register_pixel_residuals"]


def pixel_residuals(image, cam, *, min_pixels: int = 60, lags: int = 8) -> dict:
    """Detect the lines of ``image`` seen by ``cam`` and measure their pixels' residuals about their
    own planes: ``{"lines", "rms_median_px", "autocorrelation"}`` (lags 1 to ``lags``; None without a
    line of ``min_pixels`` pixels)."""
    from ..detect import detect_lines
    from ..linefit.planes import pixel_rays_with_jacobian, plane_distances

    det = detect_lines(image, cam)
    acc, cnt, rms = np.zeros(lags + 1), np.zeros(lags + 1), []
    for i, uv in enumerate(det.uv):
        if len(uv) < min_pixels:
            continue
        d = plane_distances(det.normal[i][None], pixel_rays_with_jacobian(det.cam, np.asarray(uv)))[0]
        d = d[np.isfinite(d)]
        d = d - d.mean()
        rms.append(float(np.sqrt(np.mean(d ** 2))))
        for k in range(lags + 1):
            acc[k] += np.sum(d[:len(d) - k] * d[k:])
            cnt[k] += max(len(d) - k, 0)
    if not rms:
        return {"lines": 0, "rms_median_px": None, "autocorrelation": None}
    r = acc / np.maximum(cnt, 1)
    return {"lines": len(rms), "rms_median_px": float(np.median(rms)),
            "autocorrelation": (r[1:] / r[0]).tolist() if r[0] > 0 else None}


def _run(args) -> int:
    from .._checks import CatadioptricError
    from ..dataset import Dataset

    try:
        ds = Dataset(args.dataset)
    except CatadioptricError as exc:
        raise CatadioptricError(f"DATASET: {exc}") from None
    unknown = [v for v in args.views if v not in ds.names]
    if unknown:
        raise CatadioptricError(f"VIEW: expected views of the dataset ({', '.join(ds.names)}), got {unknown}")
    for name in args.views:
        v = ds[name]
        r = pixel_residuals(v["beauty"], v["camera"], min_pixels=args.min_pixels, lags=args.lags)
        if not r["lines"]:
            print(f"{name}: no line of {args.min_pixels} pixels or more")
            continue
        ac = "-" if r["autocorrelation"] is None else ", ".join(f"{x:.2f}" for x in r["autocorrelation"])
        print(f"{name}: {r['lines']} lines, residual rms median {r['rms_median_px']:.3f} px; autocorrelation at "
              f"lags 1..{args.lags}: {ac}")
    return 0


def register_pixel_residuals(vs) -> None:
    """Add ``validate pixel-residuals`` to the ``validate`` subparsers ``vs``."""
    from ..cliargs import positive_int

    p = vs.add_parser("pixel-residuals", help="the detected pixels' scatter about each line's own curve",
                      description="Detect the lines of each view's beauty image and print the rms of their pixels' "
                                  "distances to each line's own fitted plane (median over the lines) and the "
                                  "residuals' autocorrelation along the lines.")
    p.add_argument("dataset", metavar="DATASET", help="dataset folder written by `catadioptric render`")
    p.add_argument("views", metavar="VIEW", nargs="+", help="views of the dataset")
    p.add_argument("--min-pixels", type=positive_int, default=60, help="lines with fewer pixels are skipped (60)")
    p.add_argument("--lags", type=positive_int, default=8, help="autocorrelation lags in pixels (8)")
    p.set_defaults(func=_run)
