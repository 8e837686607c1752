"""What one view says about each family of parallel lines: its direction with covariance, and
its lines (a 3-D line each for a non-central rig, an interpretation plane each for a central one).

The lines one view sees are given as :class:`ViewLines` (pixels per line, the family of each line,
and an id shared with the other view for lines known to be the same). The fits are those of
:mod:`catadioptric.linefit`; a line whose pixels do not fit (the fit names it) is dropped and
the family refitted, so one bad line cannot sink its family.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from .._checks import CatadioptricError
from ..viewlines import ViewLines  # below both detect (which produces it) and pose; re-exported here
from .rotation import with_floor

__all__ = ["ViewLines", "FamilyEstimate", "fit_view_families", "is_central", "rays_centre"]


def rays_centre(cam) -> np.ndarray:
    """The point nearest all the rays of the image (the viewpoint of a central camera)."""
    if is_central(cam):
        return np.asarray(cam.viewpoint, dtype=float)
    pin = cam.pinhole
    u, v = np.meshgrid(np.linspace(0, pin.width - 1, 40), np.linspace(0, pin.height - 1, 30))
    r = cam.backproject(np.stack([u.ravel(), v.ravel()], axis=1))
    o, d = r.origins[r.valid], r.directions[r.valid]
    P = np.eye(3) - d[:, :, None] * d[:, None, :]
    return np.linalg.lstsq(P.sum(0), np.einsum("nij,nj->i", P, o), rcond=None)[0]


def is_central(cam) -> bool:
    """True for a camera whose rays all pass through one viewpoint (an exact central rig, or a
    unified-model camera)."""
    return bool(getattr(cam, "is_central", True))


@dataclass
class FamilyEstimate:
    """One family in one view. ``direction`` (unit, sign as fitted or as the given end says) with
    ``cov (3, 3)``; ``lines``: indices (into the view's lines) of the lines kept; per kept line
    ``pluecker (L, 6)`` in the view's mirror frame (non-central; NaN for central) and the
    unit ``normals (L, 3)`` of the planes through ``centre`` that hold each line (central: the
    interpretation planes, ``centre`` the viewpoint; non-central: the planes through the
    point nearest all the rays of the image, which a near-central rig fixes far better than
    the line's distance); ``inv_distance``, ``inv_distance_std (L,)``: each line's inverse distance
    from ``centre`` and its standard error (non-central; NaN for central: one view does not place
    a line); ``inliers``: a boolean mask per kept line over its pixels; ``sigma`` (pixels) and
    ``rms`` of the fit; ``dropped``: ``{line index: reason}``; ``normal_covs (L, 3, 3)``: the
    covariance of each plane's normal (plane fits; None for the exact non-central fit); ``seen_sides``: see
    :func:`~catadioptric.pose.central.sides`."""

    key: object
    direction: np.ndarray
    cov: np.ndarray
    lines: list
    pluecker: np.ndarray
    normals: np.ndarray
    centre: np.ndarray
    inv_distance: np.ndarray
    inv_distance_std: np.ndarray
    inliers: list
    sigma: float
    rms: float
    dropped: dict
    normal_covs: np.ndarray | None = None
    #: per kept line, the unit vector in its plane, normal to the direction, on the side its pixels are
    #: seen (:func:`~catadioptric.pose.central.sides` fills it the first time it is asked)
    seen_sides: np.ndarray | None = field(default=None, repr=False)


_NAMED = re.compile(r"uv_sets\[(\d+)\]")


def _full(mask, picks, n):
    """An inlier mask over all ``n`` pixels of a line from the mask over the ``picks`` fitted: the
    pixels not fitted count as inliers."""
    out = np.ones(n, dtype=bool)
    out[picks] = mask
    return out


def _fit_noncentral(cam, uv_sets, seed, f_scale, pixel_sigma, max_drops=8):
    from ..linefit import fit_parallel_lines

    keep = list(range(len(uv_sets)))
    dropped = {}
    for _ in range(max_drops + 1):
        if not keep:
            break
        try:
            fit = fit_parallel_lines(cam, [uv_sets[i] for i in keep], seed=seed, f_scale=f_scale,
                                     pixel_sigma=pixel_sigma)
        except CatadioptricError as exc:
            m = _NAMED.search(str(exc))
            if not m:
                raise
            bad = keep.pop(int(m.group(1)))
            dropped[bad] = str(exc).split(": ", 1)[-1]
            continue
        return fit, keep, dropped
    raise CatadioptricError("no line of the family fits: " + "; ".join(f"line {k}: {v}" for k, v in dropped.items()))


def _model_cov(n, model_error_rad):
    """The covariance ``(3, 3)`` a camera model's own angular error adds to a plane's unit normal ``n``:
    an error shared by the pixels of a line, which no number of them averages out."""
    return model_error_rad**2 * (np.eye(3) - np.outer(n, n))


def _view_planes(cam, sets_by_key, seed, f_scale, pixel_sigma, directions_only):
    """Every line's interpretation plane of every family at once (one back-projection, one batch of
    fits; each line's answer is the one it gets alone: :func:`~catadioptric.linefit.fit_interpretation_planes`):
    ``{key: (planes, failures)}`` as that function returns them for the family's own lines, or the
    error it raises for them (a family of one line is fitted alone: its line's error is the family's)."""
    from ..linefit import fit_interpretation_planes

    if isinstance(seed, np.random.Generator):  # one draw after another, in the families' order
        return {k: _family_planes(cam, v, seed, f_scale, pixel_sigma, directions_only) for k, v in sets_by_key.items()}
    out = {k: _family_planes(cam, v, seed, f_scale, pixel_sigma, directions_only)
           for k, v in sets_by_key.items() if len(v) < 2}
    keys = [k for k in sets_by_key if k not in out]
    if not keys:
        return out
    flat = [uv for k in keys for uv in sets_by_key[k]]
    try:
        fits, failures = fit_interpretation_planes(cam, flat, seed=seed, f_scale=f_scale, pixel_sigma=pixel_sigma,
                                                   directions_only=directions_only)
    except CatadioptricError as exc:
        return out | {k: exc for k in keys}
    start = 0
    for k in keys:
        n = len(sets_by_key[k])
        out[k] = ({i - start: fits[i] for i in range(start, start + n) if i in fits},
                  {i - start: failures[i] for i in range(start, start + n) if i in failures})
        start += n
    return out


def _family_planes(cam, uv_sets, seed, f_scale, pixel_sigma, directions_only):
    from ..linefit import fit_interpretation_planes

    try:
        return fit_interpretation_planes(cam, uv_sets, seed=seed, f_scale=f_scale, pixel_sigma=pixel_sigma,
                                         directions_only=directions_only)
    except CatadioptricError as exc:
        return exc


def _fit_central(fitted, model_error_rad=0.0):
    """A family's direction from its lines' planes ``fitted`` (``(planes, failures)`` of
    :func:`_view_planes`, or the error that fitting its one line raised)."""
    from ..linefit import direction_from_planes

    if isinstance(fitted, CatadioptricError):
        raise fitted
    fits, dropped = fitted
    keep = sorted(fits)
    planes = [fits[i] for i in keep]
    if len(planes) < 2:
        raise CatadioptricError(f"a central camera needs at least 2 lines of a family (one gives only a plane), "
                                f"got {len(planes)} that fit")
    covs = [p.normal_cov + _model_cov(p.normal, model_error_rad) for p in planes]
    s, cov = direction_from_planes([p.normal for p in planes], covs)
    return planes, s, cov, keep, dropped, np.array(covs)


def _spread(n: int, k: int | None) -> np.ndarray:
    """At most ``k`` of ``n`` indices, evenly spread (all when ``k`` is None)."""
    if k is None or n <= k:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, k)).astype(int))


def fit_view_families(view: ViewLines, *, keys=None, seed=0, f_scale: float = 1.0, pixel_sigma=None,
                      hints: dict | None = None, max_pixels: int | None = None,
                      exact: bool = True, model_error_px: float = 0.0,
                      calibration_rms_px: float = 0.0) -> tuple[dict, dict]:
    """Fit every family of ``view`` (or those in ``keys``). Returns ``(estimates, failures)``:
    ``{family: FamilyEstimate}`` and ``{family: reason}``. ``hints``: ``{family: direction}``
    in the view's mirror frame (a matched end, e.g. from a vanishing point): the fitted
    direction is flipped to agree with it. ``max_pixels``: fit each line on at most this many
    of its pixels, evenly spread (the others count as inliers). ``exact=False`` (non-central
    rigs): each line's plane through the rays' centre from its rays' directions alone, the
    family's direction normal to its planes (two lines or more), as a central camera's: far
    cheaper than the exact joint fits, and an approximation by the spread of the rays' origins
    over the lines' distances, enough to start the two-view refinement. ``model_error_px``: the
    camera model's own error (pixels; e.g. the rms of a central approximation of a non-central
    rig), added to each plane's normal covariance as an error its pixels share.
    ``calibration_rms_px``: a calibrated camera's reprojection rms (pixels, as its calibration tool
    states it): an error of the model that the lines of a family share (they lie in one part of the
    image, where the model is off the same way), so it is not reduced by their number: added to each
    family's direction as an error of that many pixels' angle (:func:`~catadioptric.pose.central.rad_per_px`)
    any way across it (:func:`~catadioptric.pose.rotation.with_floor`)."""
    fams = view.families()
    est, fail = {}, {}
    central = is_central(view.cam)
    planes_only = central or not exact
    centre = rays_centre(view.cam)
    model_error_rad = floor_deg = 0.0
    if model_error_px or calibration_rms_px:
        from .central import rad_per_px

        per_px = rad_per_px(view.cam)
        model_error_rad = float(model_error_px) * per_px
        floor_deg = float(np.degrees(float(calibration_rms_px) * per_px))
    todo = list(fams if keys is None else [k for k in keys if k in fams])
    picks_of = {key: [_spread(len(view.uv[i]), max_pixels) for i in fams[key]] for key in todo}
    sets_of = {key: [view.uv[i][p] for i, p in zip(fams[key], picks_of[key])] for key in todo}
    fitted = _view_planes(view.cam, sets_of, seed, f_scale, pixel_sigma, not central) if planes_only else {}
    for key in todo:
        idx, picks, sets = fams[key], picks_of[key], sets_of[key]
        try:
            if planes_only:
                planes, s, cov, keep, dropped, ncov = _fit_central(fitted[key], model_error_rad=model_error_rad)
                normals = np.array([p.normal for p in planes])
                rho = rho_sd = np.full(len(keep), np.nan)
                pl = np.full((len(keep), 6), np.nan)
                inl = [_full(p.inliers, picks[k], len(view.uv[idx[k]])) for p, k in zip(planes, keep)]
                rms = float(np.sqrt(np.mean(np.concatenate([p.distances[p.inliers] ** 2 for p in planes]))))
                sig = float(np.nanmedian([p.rms for p in planes]))
            else:
                fit, keep, dropped = _fit_noncentral(view.cam, sets, seed, f_scale, pixel_sigma)
                s, cov = fit.direction, fit.direction_cov
                pl = np.concatenate([np.tile(s, (fit.n_lines, 1)), fit.moments], axis=1)
                normals = np.cross(fit.points - centre, s)
                dist = np.linalg.norm(normals, axis=1)
                normals /= np.maximum(dist, 1e-300)[:, None]
                rho = 1.0 / np.maximum(dist, 1e-300)
                # the fit's parameters are (direction, then angle and inverse distance per line)
                rho_sd = np.sqrt(np.maximum(np.diag(fit.cov)[3::2], 0.0))
                inl = [_full(m, picks[k], len(view.uv[idx[k]])) for m, k in zip(fit.inliers, keep)]
                rms, sig = fit.rms, fit.sigma
                ncov = None
        except CatadioptricError as exc:
            fail[key] = str(exc)
            continue
        if hints is not None and key in hints and hints[key] is not None:
            h = np.asarray(hints[key], float)
            if s @ h < 0:
                s = -s
                pl = -pl
        est[key] = FamilyEstimate(key=key, direction=s, cov=with_floor(s, cov, floor_deg), lines=[idx[k] for k in keep],
                                  pluecker=pl,
                                  normals=normals, centre=centre, inv_distance=rho, inv_distance_std=rho_sd,
                                  inliers=list(inl), sigma=sig, rms=rms,
                                  dropped={idx[k]: v for k, v in dropped.items()}, normal_covs=ncov)
    return est, fail
