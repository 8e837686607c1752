"""Kalibr's ``pinhole`` camera, intrinsics ``[fu, fv, pu, pv]``, with one of its distortions
(Kalibr's wiki, "Supported models"):

* ``radtan`` ``[k1, k2, r1, r2]``: radial-tangential, OpenCV's ``k1, k2, p1, p2``, on the
  normalised point ``(x, y) = (X_x, X_y) / X_z``::

      r2 = x^2 + y^2
      xd = x (1 + k1 r2 + k2 r2^2) + 2 r1 x y + r2 (r2 + 2 x^2)
      yd = y (1 + k1 r2 + k2 r2^2) + r1 (r2 + 2 y^2) + 2 r2 x y

  (the same as ``cv2.projectPoints`` with ``distCoeffs = (k1, k2, p1, p2)``); a point has an
  image when ``X_z > 0``. Inverse: Newton's method (:func:`~catadioptric.models.mei.undistort_radtan`),
  no ray where it does not converge or the distortion folds over;
* ``equidistant`` ``[k1, k2, k3, k4]``: Kannala-Brandt, as Kalibr and ``cv2.fisheye``::

      theta = atan2(sqrt(X_x^2 + X_y^2), X_z)
      theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)
      (xd, yd) = theta_d (X_x, X_y) / sqrt(X_x^2 + X_y^2)

  valid for ``theta`` below ``theta_max``: the first angle where ``theta_d`` stops increasing
  (``d theta_d / d theta = 0``), at most pi. For ``X_z > 0`` this is Kalibr's and
  ``cv2.fisheye``'s formula (both go through ``X / X_z``, so they take points in front only);
  beyond 90 degrees it is the Kannala-Brandt model's own continuation. Inverse: Newton's method
  on ``theta``, kept inside ``[0, theta_max]`` (bisection where a step would leave it), to 1e-15;
* ``none``: ``(xd, yd) = (x, y)``, points with ``X_z > 0``.

Then ``u = fu xd + pu``, ``v = fv yd + pv``. Directions are in Kalibr's camera frame (x right,
y down, z forward: OpenCV's).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError, as_float_array, as_scalar
from .base import CentralCamera, nonzero_focal
from .mei import radtan_distort, undistort_radtan

__all__ = ["KalibrPinholeCamera", "PINHOLE_DISTORTIONS"]

#: Kalibr's distortions of a pinhole camera this model takes, with their number of coefficients
PINHOLE_DISTORTIONS = {"radtan": 4, "equidistant": 4, "none": 0}


def _equidistant_theta_max(k) -> float:
    """The first positive root of ``d theta_d / d theta = 1 + 3 k1 t + 5 k2 t^2 + 7 k3 t^3 +
    9 k4 t^4`` (``t = theta^2``), as an angle; pi when there is none below pi."""
    k1, k2, k3, k4 = k
    coeffs = np.trim_zeros(np.array([9.0 * k4, 7.0 * k3, 5.0 * k2, 3.0 * k1, 1.0]), "f")
    best = np.pi
    if coeffs.size > 1:
        for t in np.roots(coeffs):
            if abs(t.imag) <= 1e-12 * max(1.0, abs(t.real)) and t.real > 0:
                best = min(best, float(np.sqrt(t.real)))
    return best


@dataclass(frozen=True, eq=False, repr=False)
class KalibrPinholeCamera(CentralCamera):
    """Kalibr's pinhole camera (module docstring): ``fu``, ``fv`` (non-zero), ``pu``, ``pv``,
    ``distortion_model`` (``"radtan"``, ``"equidistant"`` or ``"none"``) and its
    ``distortion_coeffs`` (4 numbers; none for ``"none"``)."""

    fu: float = 1.0
    fv: float = 1.0
    pu: float = 0.0
    pv: float = 0.0
    distortion_model: str = "none"
    distortion_coeffs: tuple = ()

    model = "pinhole"

    def __post_init__(self):
        super().__post_init__()
        dm = self.distortion_model
        if dm not in PINHOLE_DISTORTIONS:
            raise CatadioptricError(f"distortion_model: expected one of {sorted(PINHOLE_DISTORTIONS)}, got {dm!r}")
        n = PINHOLE_DISTORTIONS[dm]
        D = as_float_array(list(self.distortion_coeffs) if self.distortion_coeffs is not None else [],
                           "distortion_coeffs").reshape(-1)
        if dm == "none" and D.size == 4 and not D.any():
            D = D[:0]  # zeros written for "none" are no distortion
        if D.size != n:
            raise CatadioptricError(f"distortion_coeffs: expected {n} numbers for distortion_model {dm}, got {D.size}")
        object.__setattr__(self, "fu", nonzero_focal(self.fu, "fu"))
        object.__setattr__(self, "fv", nonzero_focal(self.fv, "fv"))
        object.__setattr__(self, "pu", as_scalar(self.pu, "pu"))
        object.__setattr__(self, "pv", as_scalar(self.pv, "pv"))
        object.__setattr__(self, "distortion_coeffs", tuple(float(v) for v in D))
        if dm == "equidistant":
            object.__setattr__(self, "_theta_max", _equidistant_theta_max(self.distortion_coeffs))

    def params(self) -> dict:
        return {"fu": self.fu, "fv": self.fv, "pu": self.pu, "pv": self.pv, "distortion_model": self.distortion_model,
                "distortion_coeffs": list(self.distortion_coeffs)}

    @property
    def theta_max(self) -> float:
        """The largest angle from the axis the model images: pi/2 (excluded) for ``radtan`` and
        ``none``, the end of the monotone range of ``theta_d`` for ``equidistant``."""
        return getattr(self, "_theta_max", np.pi / 2)

    # ------------------------------------------------------------------ equidistant
    def _theta_d(self, t):
        k1, k2, k3, k4 = self.distortion_coeffs
        t2 = t * t
        return t * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))

    def _dtheta_d(self, t):
        k1, k2, k3, k4 = self.distortion_coeffs
        t2 = t * t
        return 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)))

    def _theta_of(self, td):
        """``theta`` in ``[0, theta_max]`` with ``theta_d(theta) = td`` (Newton in a bracket);
        ``ok`` where ``td`` is below ``theta_d(theta_max)``."""
        tmax = self.theta_max
        ok = (td >= 0) & (td < self._theta_d(tmax))
        lo = np.zeros_like(td)
        hi = np.full_like(td, tmax)
        t = np.clip(td, 0.0, tmax)
        for _ in range(100):
            f = self._theta_d(t) - td
            lo = np.where(f < 0, t, lo)
            hi = np.where(f > 0, t, hi)
            with np.errstate(all="ignore"):
                step = t - f / self._dtheta_d(t)
            inside = np.isfinite(step) & (step > lo) & (step < hi)
            t_new = np.where(inside, step, 0.5 * (lo + hi))
            done = np.abs(t_new - t) <= 1e-15 * np.maximum(t, 1e-300)
            t = t_new
            if np.all(done | ~ok):
                break
        return t, ok

    # ------------------------------------------------------------------ the protocol
    def project_unit(self, X):
        x, y, z = X[..., 0], X[..., 1], X[..., 2]
        if self.distortion_model == "equidistant":
            rho = np.hypot(x, y)
            theta = np.arctan2(rho, z)
            s = np.where(rho > 0, self._theta_d(theta) / np.where(rho > 0, rho, 1.0), 1.0)
            xd, yd = s * x, s * y
            valid = theta < self.theta_max
        else:
            xn, yn = x / z, y / z
            if self.distortion_model == "radtan":
                xd, yd = radtan_distort(xn, yn, *self.distortion_coeffs)[:2]
            else:
                xd, yd = xn, yn
            valid = z > 0
        uv = np.stack([self.fu * xd + self.pu, self.fv * yd + self.pv], axis=-1)
        return uv, valid

    def lift(self, uv):
        xd = (uv[..., 0] - self.pu) / self.fu
        yd = (uv[..., 1] - self.pv) / self.fv
        if self.distortion_model == "equidistant":
            td = np.hypot(xd, yd)
            theta, ok = self._theta_of(td)
            s = np.where(td > 0, np.sin(theta) / np.where(td > 0, td, 1.0), 0.0)
            X = np.stack([s * xd, s * yd, np.cos(theta)], axis=-1)
            X /= np.linalg.norm(X, axis=-1, keepdims=True)
            return X, ok & np.isfinite(td)
        if self.distortion_model == "radtan":
            x, y, ok = undistort_radtan(xd, yd, *self.distortion_coeffs)
        else:
            x, y, ok = xd, yd, np.isfinite(xd) & np.isfinite(yd)
        X = np.stack([x, y, np.ones_like(x)], axis=-1)
        X /= np.linalg.norm(X, axis=-1, keepdims=True)
        return X, ok & np.all(np.isfinite(X), axis=-1)
