"""Mei's unified model with radial-tangential distortion: OpenCV's ``cv2.omnidir`` and Kalibr's
``omni`` + ``radtan`` (C. Mei, P. Rives, "Single View Point Omnidirectional Camera Calibration
from Planar Grids", ICRA 2007).

A point ``X`` of the camera frame (OpenCV's: x right, y down, z along the optical axis)::

    Xs = X / |X|                                         # onto the unit sphere
    x, y = Xs_x / (Xs_z + xi), Xs_y / (Xs_z + xi)        # from (0, 0, -xi) onto the plane z = 1
    r2 = x^2 + y^2
    xd = x (1 + k1 r2 + k2 r2^2) + 2 p1 x y + p2 (r2 + 2 x^2)
    yd = y (1 + k1 r2 + k2 r2^2) + p1 (r2 + 2 y^2) + 2 p2 x y
    u = fx xd + s yd + cx,   v = fy yd + cy

as ``cv2.omnidir.projectPoints`` computes it (checked in ``tests/test_models_mei.py``). A point has
an image when ``Xs_z + xi > 0`` and, for ``xi > 1``, ``1 + xi Xs_z >= 0`` (the side of the
sphere the re-projection centre sees).

The inverse (:meth:`MeiCamera.lift`): Newton's method on the distortion (the 2x2 Jacobian in
closed form, from the undistorted guess ``(xd, yd)``, to 1e-15), then the closed-form lift
from the plane to the sphere, ``Xs = (l x, l y, l - xi)`` with
``l = (xi + sqrt(1 + (1 - xi^2) r2)) / (1 + r2)``. A pixel whose undistortion does not converge,
or whose preimage lies beyond the radius where the radial distortion folds over
(:func:`monotone_r2`; or where the Jacobian's determinant is not positive), has no ray.
``cv2.omnidir.undistortPoints`` is no inverse to use here: it rectifies to a perspective view
and cannot give rays more than 90 degrees from the axis.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError, as_float_array, as_scalar
from .base import CentralCamera

__all__ = ["MeiCamera", "radtan_distort", "undistort_radtan", "monotone_r2"]


def radtan_distort(x, y, k1, k2, p1, p2):
    """Distorted ``(xd, yd)`` and the Jacobian entries ``d(xd, yd) / d(x, y)``."""
    r2 = x * x + y * y
    rad = 1.0 + k1 * r2 + k2 * r2 * r2
    drad = k1 + 2.0 * k2 * r2  # d rad / d r2
    xd = x * rad + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * rad + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    a = rad + 2.0 * x * x * drad + 2.0 * p1 * y + 6.0 * p2 * x
    b = 2.0 * x * y * drad + 2.0 * p1 * x + 2.0 * p2 * y
    c = 2.0 * x * y * drad + 2.0 * p1 * x + 2.0 * p2 * y
    d = rad + 2.0 * y * y * drad + 6.0 * p1 * y + 2.0 * p2 * x
    return xd, yd, a, b, c, d


def undistort_radtan(xd, yd, k1, k2, p1, p2, iters: int = 30):
    """``(x, y, ok)``: the undistorted plane point of ``(xd, yd)`` by Newton's method; ``ok`` where
    it converged (to 1e-14 of the distorted point's size) with a positive Jacobian determinant."""
    x, y = xd.copy(), yd.copy()
    if k1 == 0 and k2 == 0 and p1 == 0 and p2 == 0:
        return x, y, np.isfinite(x) & np.isfinite(y)
    scale = np.maximum(1.0, np.hypot(xd, yd))
    for _ in range(iters):
        fx, fy, a, b, c, d = radtan_distort(x, y, k1, k2, p1, p2)
        ex, ey = fx - xd, fy - yd
        det = a * d - b * c
        with np.errstate(all="ignore"):
            dx = (d * ex - b * ey) / det
            dy = (a * ey - c * ex) / det
        dx = np.where(np.isfinite(dx), dx, 0.0)
        dy = np.where(np.isfinite(dy), dy, 0.0)
        # a step never longer than the point's size: Newton far from the root of a quartic overshoots
        cap = np.maximum(np.hypot(x, y), 1.0)
        n = np.hypot(dx, dy)
        f = np.where(n > cap, cap / np.maximum(n, 1e-300), 1.0)
        x, y = x - f * dx, y - f * dy
        if np.all(np.hypot(ex, ey) <= 1e-15 * scale):
            break
    fx, fy, a, b, c, d = radtan_distort(x, y, k1, k2, p1, p2)
    ok = (np.hypot(fx - xd, fy - yd) <= 1e-12 * scale) & (a * d - b * c > 0) & (x * x + y * y < monotone_r2(k1, k2))
    return x, y, ok


def monotone_r2(k1: float, k2: float) -> float:
    """The squared radius up to which the radial distortion ``r (1 + k1 r^2 + k2 r^4)`` grows with
    ``r`` (the smallest positive root of ``1 + 3 k1 s + 5 k2 s^2``, inf when none): beyond it the
    image folds over, and a distorted point has a second preimage that is not the camera's."""
    roots = np.roots([5.0 * k2, 3.0 * k1, 1.0]) if k2 != 0 else (np.array([-1.0 / (3.0 * k1)]) if k1 != 0 else [])
    pos = [float(r.real) for r in np.atleast_1d(roots) if abs(r.imag) < 1e-12 and r.real > 0]
    return min(pos) if pos else float("inf")


@dataclass(frozen=True, eq=False, repr=False)
class MeiCamera(CentralCamera):
    """Mei's unified model (module docstring): ``xi``, ``K`` (3x3 with skew ``K[0, 1]``) and
    ``D = (k1, k2, p1, p2)``, image ``width`` x ``height``. A negative ``fy`` (the project's
    own export of a right-handed sphere frame, docs/unified.md) is the tool's formula too."""

    xi: float = 1.0
    K: np.ndarray = None
    D: tuple = (0.0, 0.0, 0.0, 0.0)

    model = "mei"

    def __post_init__(self):
        super().__post_init__()
        xi = as_scalar(self.xi, "xi")
        if xi < 0:
            raise CatadioptricError(f"xi: expected a number >= 0, got {xi!r}")
        if self.K is None:
            raise CatadioptricError("K: expected a 3x3 camera matrix, got None")
        K = as_float_array(self.K, "K")
        if K.shape != (3, 3):
            raise CatadioptricError(f"K: expected a 3x3 camera matrix, got an array of shape {K.shape}")
        if not (K[1, 0] == 0 and K[2, 0] == 0 and K[2, 1] == 0 and K[2, 2] == 1 and K[0, 0] != 0 and K[1, 1] != 0):
            raise CatadioptricError(f"K: expected [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with fx, fy non-zero, "
                                    f"got {K.tolist()}")
        D = as_float_array(self.D, "D").reshape(-1)
        if D.shape != (4,):
            raise CatadioptricError(f"D: expected 4 distortion coefficients (k1, k2, p1, p2), got {D.size}")
        K = K.copy()
        K.setflags(write=False)
        object.__setattr__(self, "xi", xi)
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "D", tuple(float(v) for v in D))

    def params(self) -> dict:
        return {"xi": self.xi, "K": self.K.tolist(), "D": list(self.D)}

    def lift(self, uv):
        K = self.K
        fx, s, cx, fy, cy = K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]
        yd = (uv[..., 1] - cy) / fy
        xd = (uv[..., 0] - cx - s * yd) / fx
        x, y, ok = undistort_radtan(xd, yd, *self.D)
        xi = self.xi
        r2 = x * x + y * y
        disc = 1.0 + (1.0 - xi * xi) * r2
        lam = (xi + np.sqrt(np.maximum(disc, 0.0))) / (1.0 + r2)
        X = np.stack([lam * x, lam * y, lam - xi], axis=-1)
        X /= np.linalg.norm(X, axis=-1, keepdims=True)
        valid = ok & (disc >= 0) & self._sees(X[..., 2])
        return X, valid

    def _sees(self, zs):
        ok = zs + self.xi > 0
        if self.xi > 1:
            ok &= 1.0 + self.xi * zs >= 0
        return ok

    def project_unit(self, X):
        K = self.K
        den = X[..., 2] + self.xi
        x, y = X[..., 0] / den, X[..., 1] / den
        xd, yd = radtan_distort(x, y, *self.D)[:2]
        uv = np.stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]], axis=-1)
        return uv, self._sees(X[..., 2])
