"""Scaramuzza's polynomial model as the OCamCalib toolbox writes it (``calib_results.txt``) and
its C code (``ocam_functions.c``) uses it (D. Scaramuzza, A. Martinelli, R. Siegwart, "A
Toolbox for Easily Calibrating Omnidirectional Cameras", IROS 2006).

The tool's pixel order: a 2-D point is ``(row, column)``; the centre ``(xc, yc)`` is the
centre's row and column (from 0). ``cam2world`` (pixel to direction)::

    xp = ((row - xc) - d (col - yc)) / (c - d e)
    yp = (-e (row - xc) + c (col - yc)) / (c - d e)
    zp = ss[0] + ss[1] rho + ss[2] rho^2 + ...,   rho = sqrt(xp^2 + yp^2)
    X = (xp, yp, zp) / |(xp, yp, zp)|

and ``world2cam`` (direction to pixel)::

    n = sqrt(X_x^2 + X_y^2),   theta = atan(X_z / n)
    rho = invpol[0] + invpol[1] theta + invpol[2] theta^2 + ...
    x, y = X_x rho / n, X_y rho / n
    row = c x + d y + xc,   col = e x + y + yc          (n = 0: row, col = xc, yc)

Our pixels are OpenCV's ``(u, v) = (column, row)`` (docs/conventions.md): :meth:`lift` is
``cam2world`` of ``(row, col) = (v, u)``, :meth:`project_unit` is ``world2cam`` returning
``(u, v) = (col, row)``.

**Frame.** Directions are in OCamCalib's own camera frame, unchanged: x along the image rows
(downwards in the image), y along the columns (rightwards), z = x cross y, so that the camera
looks along -z (``ss[0] < 0``: the centre pixel's direction is ``(0, 0, -1)``). In OpenCV's
frame (x right, y down, z forward) the same direction is ``(X_y, X_x, -X_z)``.

**Two polynomials.** ``invpol`` is the toolbox's fit of the inverse of the ``ss`` mapping, not
its exact inverse (OCamCalib's ``findinvpoly`` raises its degree until the fit's error in
``rho`` is below 0.01 px, over elevations -90 to 68.8 degrees (1.20 rad) and radii up to half
the image's diagonal): ``world2cam(cam2world(p))`` differs from ``p`` by that fit's error. For
the example of ``tests/data/ocamcalib`` (pyomniunwarp's ``calib_results.txt``) it is at most
0.0019 px (median 0.0012 px) over its ROI (radii 235 to 600 px about the centre) and at most
0.0034 px up to 750 px from the centre; beyond 800 px (corners of the full photograph outside
the calibrated crop, elevations past the fit's range) ``invpol`` extrapolates and the mismatch
grows to 9 px (``tests/test_models_ocamcalib.py`` checks the ROI figure against the toolbox's
0.01 px). :meth:`lift` uses ``cam2world`` (the model's exact formula), :meth:`project_unit`
the tool's ``world2cam``. The image region (:meth:`CentralCamera.region`) asks the round trip to
close within the toolbox's own 0.01 px plus the 0.003 px of the coefficients' printed digits
(``round_trip_px``, 0.013 px), the bound ``tests/test_models_ocamcalib.py`` checks.

**Validity.** Every pixel has a ray (``cam2world`` is a polynomial). A direction has an image
when its elevation ``theta`` is at most ``theta_max``, the largest elevation that ``cam2world``
gives over the image (the elevation ``atan2(zp, rho)`` increases with ``rho`` from -90 degrees at
the centre; ``theta_max`` is its value at the image point farthest from the centre, or where it
stops increasing); the C code's ``world2cam`` extrapolates ``invpol`` beyond that. The
direction ``(0, 0, +1)`` has none (the C code would put it on the centre).

**ROI and crop.** ``roi = (u0, v0, r_min, r_max)`` in our pixels (centre column, centre row)
when the file gives the radii (pyomniunwarp's "ROI max min radius" block), else None.
``crop = (left, right)``: pyomniunwarp's "left right cropped pixel" block, the columns cropped
off the photograph before calibrating; the camera here is the one of the full photograph
(``width`` = file width + left + right, ``yc`` = file column + left), ``crop`` records how the
file's numbers relate to it (:func:`catadioptric.formats.ocamcalib.ocamcalib_text` writes them
back so).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError, as_float_array, as_scalar
from .base import CentralCamera

__all__ = ["ScaramuzzaCamera"]


def _polyval(coeffs, t):
    """``coeffs[0] + coeffs[1] t + ...`` accumulated as the C code does (powers ``t_i *= t``)."""
    out = np.full_like(t, coeffs[0])
    ti = np.ones_like(t)
    for a in coeffs[1:]:
        ti = ti * t
        out = out + ti * a
    return out


def _coeffs(v, name, n_min):
    a = as_float_array(v, name).reshape(-1)
    if a.size < n_min:
        raise CatadioptricError(f"{name}: expected at least {n_min} coefficients, got {a.size}")
    return tuple(float(x) for x in a)


@dataclass(frozen=True, eq=False, repr=False)
class ScaramuzzaCamera(CentralCamera):
    """OCamCalib's model (module docstring): ``ss`` (cam2world polynomial, ``ss[0] < 0``),
    ``invpol`` (world2cam polynomial in the elevation), the centre ``xc`` (row) and ``yc``
    (column) in the full image, the affine ``c``, ``d``, ``e``, image ``width`` x ``height``,
    ``roi`` ``(u0, v0, r_min, r_max)`` or None, ``crop`` ``(left, right)``. Directions in
    OCamCalib's frame (x along rows, y along columns, looking along -z)."""

    ss: tuple = None
    invpol: tuple = None
    xc: float = 0.0
    yc: float = 0.0
    c: float = 1.0
    d: float = 0.0
    e: float = 0.0
    roi: tuple = None
    crop: tuple = (0, 0)

    model = "ocamcalib"
    #: OCamCalib's ``findinvpoly`` tolerance (0.01 px) plus the file's printed digits (0.003 px)
    round_trip_px = 0.013
    #: the centre pixel's ray is ``(0, 0, -1)`` (``ss[0] < 0``): the mirror's axis, towards the mirror
    axis = (0.0, 0.0, -1.0)

    def __post_init__(self):
        super().__post_init__()
        if self.ss is None or self.invpol is None:
            raise CatadioptricError(f"{'ss' if self.ss is None else 'invpol'}: expected polynomial coefficients, "
                                    f"got None")
        ss = _coeffs(self.ss, "ss", 2)
        if not ss[0] < 0:
            raise CatadioptricError(f"ss: expected a negative constant term ss[0] (z at the centre), got {ss[0]!r}")
        invpol = _coeffs(self.invpol, "invpol", 1)
        c, d, e = (as_scalar(getattr(self, k), k) for k in ("c", "d", "e"))
        if c - d * e == 0:
            raise CatadioptricError(f"c, d, e: expected an invertible affine matrix [[c, d], [e, 1]], got c - d e = 0 "
                                    f"(c={c!r}, d={d!r}, e={e!r})")
        roi = self.roi
        if roi is not None:
            roi = as_float_array(roi, "roi").reshape(-1)
            if roi.shape != (4,) or not 0 <= roi[2] <= roi[3]:
                raise CatadioptricError(f"roi: expected (u0, v0, r_min, r_max) with 0 <= r_min <= r_max, got "
                                        f"{roi.tolist()}")
            roi = tuple(float(x) for x in roi)
        crop = as_float_array(self.crop, "crop").reshape(-1)
        if crop.shape != (2,) or np.any(crop < 0) or np.any(crop != np.round(crop)):
            raise CatadioptricError(f"crop: expected (left, right), two whole numbers of pixels >= 0, got "
                                    f"{crop.tolist()}")
        object.__setattr__(self, "ss", ss)
        object.__setattr__(self, "invpol", invpol)
        object.__setattr__(self, "xc", as_scalar(self.xc, "xc"))
        object.__setattr__(self, "yc", as_scalar(self.yc, "yc"))
        object.__setattr__(self, "c", c)
        object.__setattr__(self, "d", d)
        object.__setattr__(self, "e", e)
        object.__setattr__(self, "roi", roi)
        object.__setattr__(self, "crop", (int(crop[0]), int(crop[1])))
        object.__setattr__(self, "_theta_max", self._elevation_limit())

    def params(self) -> dict:
        return {"ss": list(self.ss), "invpol": list(self.invpol), "xc": self.xc, "yc": self.yc, "c": self.c,
                "d": self.d, "e": self.e, "roi": None if self.roi is None else list(self.roi),
                "crop": list(self.crop)}

    # ------------------------------------------------------------------ the tool's formulas
    def cam2world(self, point2D):
        """OCamCalib's ``cam2world``: points ``(..., 2)`` as ``(row, column)`` -> unit
        directions ``(..., 3)`` in OCamCalib's frame."""
        p = np.asarray(point2D, dtype=float)
        c, d, e = self.c, self.d, self.e
        invdet = 1.0 / (c - d * e)
        dr, dc = p[..., 0] - self.xc, p[..., 1] - self.yc
        xp = invdet * (dr - d * dc)
        yp = invdet * (-e * dr + c * dc)
        r = np.sqrt(xp * xp + yp * yp)
        zp = _polyval(self.ss, r)
        invnorm = 1.0 / np.sqrt(xp * xp + yp * yp + zp * zp)
        return np.stack([invnorm * xp, invnorm * yp, invnorm * zp], axis=-1)

    def world2cam(self, point3D):
        """OCamCalib's ``world2cam``: directions ``(..., 3)`` in OCamCalib's frame ->
        ``(row, column)`` points ``(..., 2)``."""
        X = np.asarray(point3D, dtype=float)
        norm = np.sqrt(X[..., 0] * X[..., 0] + X[..., 1] * X[..., 1])
        has = norm != 0
        safe = np.where(has, norm, 1.0)
        theta = np.arctan(X[..., 2] / safe)
        rho = _polyval(self.invpol, theta)
        invnorm = 1.0 / safe
        x = X[..., 0] * invnorm * rho
        y = X[..., 1] * invnorm * rho
        row = np.where(has, x * self.c + y * self.d + self.xc, self.xc)
        col = np.where(has, x * self.e + y + self.yc, self.yc)
        return np.stack([row, col], axis=-1)

    # ------------------------------------------------------------------ validity
    def _elevation_limit(self) -> float:
        """The largest elevation ``atan2(zp, rho)`` cam2world gives over the image: at the
        image corner farthest from the centre (in the affine-corrected radius), or where the
        elevation stops increasing before it."""
        corners = np.array([[-0.5, -0.5], [-0.5, self.width - 0.5], [self.height - 0.5, -0.5],
                            [self.height - 0.5, self.width - 0.5]])
        c, d, e = self.c, self.d, self.e
        dr, dc = corners[:, 0] - self.xc, corners[:, 1] - self.yc
        xp = (dr - d * dc) / (c - d * e)
        yp = (-e * dr + c * dc) / (c - d * e)
        rmax = float(np.max(np.hypot(xp, yp)))
        rho = np.linspace(0.0, rmax, 20001)
        theta = np.arctan2(_polyval(self.ss, rho), rho)
        down = np.nonzero(np.diff(theta) <= 0)[0]
        return float(theta[down[0]] if down.size else theta[-1])

    @property
    def theta_max(self) -> float:
        """The largest elevation (radians, ``atan(z / sqrt(x^2 + y^2))``) with an image (module
        docstring)."""
        return self._theta_max

    # ------------------------------------------------------------------ the protocol
    def lift(self, uv):
        rc = np.stack([uv[..., 1], uv[..., 0]], axis=-1)
        X = self.cam2world(rc)
        return X, np.all(np.isfinite(X), axis=-1)

    def project_unit(self, X):
        rc = self.world2cam(X)
        n = np.hypot(X[..., 0], X[..., 1])
        theta = np.arctan2(X[..., 2], n)
        valid = (theta <= self.theta_max) & ((n > 0) | (X[..., 2] < 0))
        return np.stack([rc[..., 1], rc[..., 0]], axis=-1), valid
