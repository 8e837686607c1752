"""Small helpers shared by the line fits: tangent bases, argument checks, seeds."""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError, as_float_array, as_scalar
from ..cameras import CatadioptricCamera

_LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")
# median of |e| for a pixel's distance to a fitted curve, in units of the pixel noise sigma (per
# coordinate): once the point's place along the curve is fitted, only the error across the curve is
# left, a 1-D Gaussian, whose |e| has median 0.6745 sigma (not the 1.1774 sigma of a 2-D error: taken
# for one, a 3.5-sigma inlier threshold cut at 2 sigma and the noise came out 12 % low)
HALF_NORMAL_MEDIAN = 0.6744897501960817
# --------------------------------------------------------------------------- small helpers
def unit_vectors(v):
    """``v`` divided by its norm along the last axis."""
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def tangent_basis(s):
    """Two unit vectors ``e1, e2`` with ``(e1, e2, s)`` right-handed orthonormal, for unit ``s (..., 3)``."""
    s = np.asarray(s, dtype=float)
    a = np.where((np.abs(s[..., 0]) < 0.8)[..., None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    e1 = unit_vectors(np.cross(a, s))
    e2 = np.cross(s, e1)
    return e1, e2


def check_camera(cam, what: str):
    """Raise unless ``cam`` is a non-central :class:`CatadioptricCamera` (``what``: what a central one cannot fix)."""
    if not isinstance(cam, CatadioptricCamera):
        raise CatadioptricError(f"cam: expected a CatadioptricCamera, got {type(cam).__name__}")
    if cam.is_central:
        raise CatadioptricError(
            f"cam: the camera is central (every ray passes through the viewpoint "
            f"{np.round(cam.viewpoint, 6).tolist()}): one image fixes only the plane through the viewpoint "
            f"that holds the line, not {what}; use fit_interpretation_plane (and vanishing_points_from_curves "
            f"for two or more parallel lines)"
        )


def check_uv(uv, name: str, min_pixels: int = 5) -> np.ndarray:
    """The pixels ``uv`` as a float array ``(M, 2)`` with ``M >= min_pixels``, else :class:`CatadioptricError`."""
    a = as_float_array(uv, name, 2)
    if a.ndim != 2:
        raise CatadioptricError(f"{name}: expected an array of shape (M, 2), got an array of shape {a.shape}")
    if len(a) < min_pixels:
        raise CatadioptricError(f"{name}: expected at least {min_pixels} pixels, got {len(a)}")
    return a


def check_distinct(uv: np.ndarray, name: str, min_pixels: int = 5) -> None:
    """At least ``min_pixels`` different positions (to a millionth of a pixel) among the pixels
    ``uv (M, 2)`` that see the world, for a fit whose unknowns the pixels must span: copies of one
    pixel fit a line exactly and tell nothing about it."""
    n = len(np.unique(np.round(uv, 6), axis=0))
    if n < min_pixels:
        raise CatadioptricError(f"{name}: expected at least {min_pixels} distinct pixels (a line's image spans "
                                f"several), got {len(uv)} pixels at {n} distinct position(s)")


def check_options(loss, f_scale, pixel_sigma, inlier_threshold):
    """Check the robust loss and its scales; returns ``f_scale, pixel_sigma, inlier_threshold`` as floats (or None)."""
    if loss not in _LOSSES:
        raise CatadioptricError(f"loss: expected one of {list(_LOSSES)}, got {loss!r}")
    f_scale = as_scalar(f_scale, "f_scale", positive=True)
    if pixel_sigma is not None:
        pixel_sigma = as_scalar(pixel_sigma, "pixel_sigma", positive=True)
    if inlier_threshold is not None:
        inlier_threshold = as_scalar(inlier_threshold, "inlier_threshold", positive=True)
    return f_scale, pixel_sigma, inlier_threshold


def check_fit_options(jac, max_trials, f_scale, pixel_sigma, inlier_threshold) -> float:
    """Checks shared by the fits; returns the RANSAC inlier threshold in pixels."""
    if jac not in ("analytic", "2-point", "3-point"):
        raise CatadioptricError(f"jac: expected 'analytic', '2-point' or '3-point', got {jac!r}")
    if not (isinstance(max_trials, (int, np.integer)) and max_trials >= 1):
        raise CatadioptricError(f"max_trials: expected a positive integer, got {max_trials!r}")
    if inlier_threshold is not None:
        return inlier_threshold
    return 3.5 * pixel_sigma if pixel_sigma is not None else 3.0 * f_scale


def as_rng(seed):
    """A numpy Generator from ``seed`` (an int, None or a Generator, returned as is)."""
    if isinstance(seed, np.random.Generator):
        return seed
    if seed is None or isinstance(seed, (int, np.integer)):
        return np.random.default_rng(seed)
    raise CatadioptricError(f"seed: expected an int, None or a numpy Generator, got {type(seed).__name__}")


def scatter(ok, v, fill, M, tail=()):
    """An array ``(M,) + tail`` holding ``v`` at the rows ``ok`` and ``fill`` elsewhere."""
    out = np.full((M,) + tail, fill, dtype=np.asarray(v).dtype if not isinstance(fill, float) else float)
    out[ok] = v
    return out


def check_min_distance(min_distance, cam) -> float:
    """The smallest distance of a fitted line from the rays' centre: ``min_distance`` (metres,
    >= 0), default the mirror's scale."""
    if min_distance is None:
        return 1.0 * cam.mirror.scale
    d = as_scalar(min_distance, "min_distance")
    if d < 0:
        raise CatadioptricError(f"min_distance: expected a non-negative number of metres, got {d!r}")
    return d
