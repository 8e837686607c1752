"""The measured accuracy tables of docs/linefit.md (reference segments and families)."""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError
from ._common import unit_vectors
from .fits import fit_line
from .linear import ray_frame
from .problem import Problem
from .synthetic import family_pixels, segment_pixels
from .vanishing import vanishing_points_from_curves

# --------------------------------------------------------------------------- measured accuracy
# Reference scenes of docs/linefit.md (tests/test_linefit.py uses the same numbers): per rig a
# segment close to the mirror (end points in M, metres) and the pixel noise "unit" that puts its
# fitted direction's standard error near 0.4 degrees; and a family of parallel lines whose +s
# vanishing point is a given pixel, each line through the point at a given depth on the ray of
# a given pixel.
REFERENCE_SEGMENTS = {
    "sphere": (((0.223, -0.192, 0.186), (-0.313, 0.025, -0.152)), 0.5),
    "hyperboloid_9pct": (((0.381, -0.37, -0.096), (-0.476, 0.125, 0.22)), 0.1),
    "ellipsoid": (((-0.251, -0.54, -0.038), (0.486, 0.343, -0.046)), 0.03),
}
REFERENCE_FAMILIES = {
    "hyperboloid_9pct": ((330, 60), [(120, 240), (520, 240), (320, 420), (200, 380)], [0.4, 0.5, 0.6, 0.45]),
    "sphere": ((250, 70), [(150, 250), (470, 230), (330, 380), (420, 120)], [0.3, 0.4, 0.35, 0.5]),
    "ellipsoid": ((150, 200), [(320, 120), (460, 330), (300, 400), (420, 200)], [0.4, 0.5, 0.6, 0.45]),
    "hyperboloid_central": ((480, 160), [(150, 250), (470, 330), (330, 400), (420, 120)], [0.5, 0.6, 0.4, 0.7]),
    "ellipsoid_central": ((480, 160), [(150, 250), (470, 330), (330, 400), (420, 120)], [0.5, 0.6, 0.4, 0.7]),
}


def _angle_deg(s, t):
    return float(np.degrees(np.arccos(np.clip(abs(s @ t) / np.linalg.norm(s) / np.linalg.norm(t), -1, 1))))


def _predicted_direction_std(cam, a, b, n=100):
    """Direction standard error (degrees per pixel of noise) of a segment's fit at the truth."""
    uv, pts = segment_pixels(cam, a, b, n)
    if len(uv) < 0.8 * n:
        return None
    s = unit_vectors(b - a)
    r = cam.backproject(uv)
    x0 = ray_frame(cam, r.origins, r.directions).x0
    q = a - (a @ s) * s
    pb = Problem(cam, uv, np.zeros(len(uv), dtype=np.int64), 1, x0, s, q[None], (pts - q) @ s)
    C = pb.schur_cov(pb.x0(), np.ones(len(uv), dtype=bool))
    return float(np.degrees(np.sqrt(C[0, 0] + C[1, 1])))


def accuracy_table(*, trials: int = 40, family_seeds: int = 10, random_segments: int = 150, seed: int = 0,
                   out=print) -> dict:
    """Measure and print the accuracy tables of docs/linefit.md (markdown). Takes a few minutes.

    1. Conditioning: the predicted direction error at 1 px of noise for random segments
       near each rig (100 pixels each), from the covariance at the true line.
    2. Single lines (reference segments): median errors over ``trials`` noisy fits per
       noise level, the median predicted standard error and the ratio of the Monte Carlo
       trace of the direction covariance to the median predicted one.
    3. Families and vanishing points at 1 px (reference families, ``family_seeds`` noise draws).
    Returns the numbers as a dict."""
    from ..rigs import preset

    rng = np.random.default_rng(seed)
    res = {"conditioning": {}, "single": {}, "family": {}}
    out("### Conditioning: predicted direction error of one line at 1 px noise (degrees)\n")
    out("| rig | segments | median | 10th percentile | best |")
    out("|---|---|---|---|---|")
    for name in ("sphere", "hyperboloid_9pct", "hyperboloid", "ellipsoid"):
        cam = preset(name)
        g = cam.pinhole.pixel_grid(10).reshape(-1, 2)
        r = cam.backproject(g)
        dirs = r.directions[r.valid]
        vals = []
        for _ in range(random_segments):
            v = dirs[rng.integers(len(dirs))]
            dist = rng.uniform(0.08, 0.3)
            s = unit_vectors(np.cross(v, rng.normal(size=3)))
            half = rng.uniform(1.0, 4.0) * dist
            x = _predicted_direction_std(cam, v * dist - half * s, v * dist + half * s)
            if x is not None:
                vals.append(x)
        vals = np.array(vals)
        res["conditioning"][name] = vals
        out(f"| {name} | {len(vals)} | {np.median(vals):.3g} | {np.percentile(vals, 10):.3g} | {vals.min():.3g} |")
    out("\n### Single lines: reference segments, 100 pixels, median over "
        f"{trials} noise draws (plain least squares)\n")
    out("| rig | sigma (px) | direction error (deg) | predicted std (deg) | MC / predicted trace "
        "| position error (mm) |")
    out("|---|---|---|---|---|---|")
    for name, ((a, b), unit) in REFERENCE_SEGMENTS.items():
        cam = preset(name)
        a, b = np.array(a), np.array(b)
        uv, _ = segment_pixels(cam, a, b, 100)
        s = unit_vectors(b - a)
        mid = 0.5 * (a + b)
        for sigma in sorted({unit * k for k in (0.25, 0.5, 1.0, 2.0)} | {1.0}):
            ds, ang, pos, pred = [], [], [], []
            for t in range(trials):
                noisy = uv + np.random.default_rng(1000 + t).normal(0.0, sigma, uv.shape)
                try:
                    f = fit_line(cam, noisy, ransac=False, loss="linear")
                except CatadioptricError:
                    continue
                sf = f.direction if f.direction @ s >= 0 else -f.direction
                ds.append(sf - s)
                ang.append(_angle_deg(f.direction, s))
                pos.append(np.linalg.norm(np.cross(mid - f.point, f.direction)))
                pred.append(np.trace(f.direction_cov))
            ratio = float(np.trace(np.cov(np.array(ds).T)) / np.median(pred))
            row = dict(direction_deg=float(np.median(ang)), predicted_deg=float(np.degrees(np.sqrt(np.median(pred)))),
                       mc_ratio=ratio, position_mm=1e3 * float(np.median(pos)), n=len(ang))
            res["single"][(name, sigma)] = row
            out(f"| {name} | {sigma:.4g} | {row['direction_deg']:.3g} | {row['predicted_deg']:.3g} | {ratio:.2f} "
                f"| {row['position_mm']:.3g} |")
    out(f"\n### Families of 4 parallel lines and their vanishing points, 1 px noise, median over {family_seeds} "
        "draws\n")
    out("| rig | family direction error (deg) | predicted std (deg) | single-line direction error (deg) "
        "| +s vanishing point error (px) | predicted std (px) | spread of single fits (max, px) |")
    out("|---|---|---|---|---|---|---|")
    for name, spec in REFERENCE_FAMILIES.items():
        cam = preset(name)
        s, sets, _ = family_pixels(cam, *spec)
        vp_pixel = np.array(spec[0], dtype=float)
        fam, fam_sd, single, vp_err, vp_sd, spread = [], [], [], [], [], []
        for t in range(family_seeds):
            rg = np.random.default_rng(2000 + t)
            noisy = [u + rg.normal(0.0, 1.0, u.shape) for u in sets]
            v = vanishing_points_from_curves(cam, noisy)
            fam.append(_angle_deg(v.direction, s))
            fam_sd.append(np.degrees(np.sqrt(np.trace(v.direction_cov))))
            if v.family is not None:
                single += [_angle_deg(f.direction, s) for f in v.individual if f is not None]
            k = [i for i in v.observable() if v.sign[i] > 0]
            if k:
                j = k[int(np.argmin(np.linalg.norm(v.uv[k] - vp_pixel, axis=-1)))]
                vp_err.append(np.linalg.norm(v.uv[j] - vp_pixel))
                vp_sd.append(np.sqrt(np.trace(v.uv_cov[j])))
                spread.append(v.spread_max[j])
        med = lambda x: float(np.nanmedian(x)) if len(x) else float("nan")
        row = dict(family_deg=med(fam), family_pred_deg=med(fam_sd), single_deg=med(single), vp_px=med(vp_err),
                   vp_pred_px=med(vp_sd), spread_px=med(spread), lines=len(sets))
        res["family"][name] = row
        single_txt = f"{row['single_deg']:.3g}" if single else "- (central)"
        out(f"| {name} | {row['family_deg']:.3g} | {row['family_pred_deg']:.3g} | {single_txt} | {row['vp_px']:.3g} "
            f"| {row['vp_pred_px']:.3g} | {row['spread_px']:.3g} |")
    return res

