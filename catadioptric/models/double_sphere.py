"""The double sphere model: Kalibr's ``ds`` camera, intrinsics ``[xi, alpha, fu, fv, pu, pv]``
(V. Usenko, N. Demmel, D. Cremers, "The Double Sphere Camera Model", 3DV 2018, section 3.5).

A point ``X = (x, y, z)`` of the camera frame (Kalibr's: x right, y down, z along the axis)::

    d1 = |X|,   d2 = sqrt(x^2 + y^2 + (xi d1 + z)^2)
    den = alpha d2 + (1 - alpha) (xi d1 + z)
    u = fu x / den + pu,   v = fv y / den + pv

defined for ``z > -w2 d1`` with ``w1 = alpha / (1 - alpha)`` when ``alpha <= 0.5``, else
``(1 - alpha) / alpha``, and ``w2 = (w1 + xi) / sqrt(2 w1 xi + xi^2 + 1)``. The inverse, in
closed form (the paper's unprojection)::

    mx = (u - pu) / fu,   my = (v - pv) / fv,   r2 = mx^2 + my^2
    mz = (1 - alpha^2 r2) / (alpha sqrt(1 - (2 alpha - 1) r2) + 1 - alpha)
    X = (mz xi + sqrt(mz^2 + (1 - xi^2) r2)) / (mz^2 + r2) (mx, my, mz) - (0, 0, xi)

defined for every pixel when ``alpha <= 0.5``, else for ``r2 <= 1 / (2 alpha - 1)`` (and where
the square root's argument ``mz^2 + (1 - xi^2) r2`` is not negative, which matters for
``|xi| > 1`` only). A lifted direction is kept only where it projects (``z > -w2 d1``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError, as_scalar
from .base import CentralCamera, nonzero_focal

__all__ = ["DoubleSphereCamera"]


@dataclass(frozen=True, eq=False, repr=False)
class DoubleSphereCamera(CentralCamera):
    """Kalibr's double sphere model (module docstring): ``xi``, ``alpha`` in [0, 1], focal
    lengths ``fu``, ``fv`` (non-zero), principal point ``pu``, ``pv``; directions in Kalibr's
    camera frame (x right, y down, z forward)."""

    xi: float = 0.0
    alpha: float = 0.5
    fu: float = 1.0
    fv: float = 1.0
    pu: float = 0.0
    pv: float = 0.0

    model = "ds"

    def __post_init__(self):
        super().__post_init__()
        alpha = as_scalar(self.alpha, "alpha")
        if not 0.0 <= alpha <= 1.0:
            raise CatadioptricError(f"alpha: expected a number in [0, 1], got {alpha!r}")
        object.__setattr__(self, "xi", as_scalar(self.xi, "xi"))
        object.__setattr__(self, "alpha", alpha)
        object.__setattr__(self, "fu", nonzero_focal(self.fu, "fu"))
        object.__setattr__(self, "fv", nonzero_focal(self.fv, "fv"))
        object.__setattr__(self, "pu", as_scalar(self.pu, "pu"))
        object.__setattr__(self, "pv", as_scalar(self.pv, "pv"))

    def params(self) -> dict:
        return {"xi": self.xi, "alpha": self.alpha, "fu": self.fu, "fv": self.fv, "pu": self.pu, "pv": self.pv}

    @property
    def _w2(self) -> float:
        a, xi = self.alpha, self.xi
        w1 = a / (1.0 - a) if a <= 0.5 else (1.0 - a) / a
        return (w1 + xi) / np.sqrt(2.0 * w1 * xi + xi * xi + 1.0)

    def _sees(self, X):
        return X[..., 2] > -self._w2 * np.linalg.norm(X, axis=-1)

    def project_unit(self, X):
        a, xi = self.alpha, self.xi
        x, y, z = X[..., 0], X[..., 1], X[..., 2]
        d1 = np.sqrt(x * x + y * y + z * z)
        k = xi * d1 + z
        d2 = np.sqrt(x * x + y * y + k * k)
        den = a * d2 + (1.0 - a) * k
        uv = np.stack([self.fu * x / den + self.pu, self.fv * y / den + self.pv], axis=-1)
        return uv, self._sees(X) & (den > 0)

    def lift(self, uv):
        a, xi = self.alpha, self.xi
        mx = (uv[..., 0] - self.pu) / self.fu
        my = (uv[..., 1] - self.pv) / self.fv
        r2 = mx * mx + my * my
        disc = 1.0 - (2.0 * a - 1.0) * r2
        mz = (1.0 - a * a * r2) / (a * np.sqrt(np.maximum(disc, 0.0)) + 1.0 - a)
        disc2 = mz * mz + (1.0 - xi * xi) * r2
        s = (mz * xi + np.sqrt(np.maximum(disc2, 0.0))) / (mz * mz + r2)
        X = np.stack([s * mx, s * my, s * mz - xi], axis=-1)
        X /= np.linalg.norm(X, axis=-1, keepdims=True)
        valid = (disc >= 0 if a > 0.5 else np.isfinite(r2)) & (disc2 >= 0)
        return X, valid & np.all(np.isfinite(X), axis=-1) & self._sees(X)
