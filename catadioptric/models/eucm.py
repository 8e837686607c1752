"""The extended unified camera model (EUCM): Kalibr's ``eucm`` camera, intrinsics
``[alpha, beta, fu, fv, pu, pv]`` (B. Khomutenko, G. Garcia, P. Martinet, "An Enhanced Unified
Camera Model", RA-L 2016; formulas and validity as in V. Usenko, N. Demmel, D. Cremers, "The
Double Sphere Camera Model", 3DV 2018, section 3.3).

A point ``X = (x, y, z)`` of the camera frame (Kalibr's: x right, y down, z along the axis)::

    d = sqrt(beta (x^2 + y^2) + z^2)
    u = fu x / (alpha d + (1 - alpha) z) + pu,   v = fv y / (alpha d + (1 - alpha) z) + pv

defined for ``z > -w d`` with ``w = alpha / (1 - alpha)`` when ``alpha <= 0.5``, else
``(1 - alpha) / alpha``. The inverse, in closed form (the paper's unprojection)::

    mx = (u - pu) / fu,   my = (v - pv) / fv,   r2 = mx^2 + my^2
    mz = (1 - beta alpha^2 r2) / (alpha sqrt(1 - (2 alpha - 1) beta r2) + 1 - alpha)
    X = (mx, my, mz) / |(mx, my, mz)|

defined for every pixel when ``alpha <= 0.5``, else for ``r2 <= 1 / (beta (2 alpha - 1))``.
With ``beta = 1`` it is Mei's unified model (``xi = alpha / (1 - alpha)``) without distortion.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError, as_scalar
from .base import CentralCamera, nonzero_focal

__all__ = ["EUCMCamera"]



@dataclass(frozen=True, eq=False, repr=False)
class EUCMCamera(CentralCamera):
    """Kalibr's extended unified model (module docstring): ``alpha`` in [0, 1], ``beta > 0``,
    focal lengths ``fu``, ``fv`` (non-zero), principal point ``pu``, ``pv``; directions in
    Kalibr's camera frame (x right, y down, z forward)."""

    alpha: float = 0.5
    beta: float = 1.0
    fu: float = 1.0
    fv: float = 1.0
    pu: float = 0.0
    pv: float = 0.0

    model = "eucm"

    def __post_init__(self):
        super().__post_init__()
        alpha = as_scalar(self.alpha, "alpha")
        if not 0.0 <= alpha <= 1.0:
            raise CatadioptricError(f"alpha: expected a number in [0, 1], got {alpha!r}")
        beta = as_scalar(self.beta, "beta")
        if not beta > 0:
            raise CatadioptricError(f"beta: expected a positive number, got {beta!r}")
        object.__setattr__(self, "alpha", alpha)
        object.__setattr__(self, "beta", beta)
        object.__setattr__(self, "fu", nonzero_focal(self.fu, "fu"))
        object.__setattr__(self, "fv", nonzero_focal(self.fv, "fv"))
        object.__setattr__(self, "pu", as_scalar(self.pu, "pu"))
        object.__setattr__(self, "pv", as_scalar(self.pv, "pv"))

    def params(self) -> dict:
        return {"alpha": self.alpha, "beta": self.beta, "fu": self.fu, "fv": self.fv, "pu": self.pu, "pv": self.pv}

    @property
    def _w(self) -> float:
        a = self.alpha
        if a <= 0.5:
            return a / (1.0 - a)
        return (1.0 - a) / a

    def project_unit(self, X):
        a, b = self.alpha, self.beta
        x, y, z = X[..., 0], X[..., 1], X[..., 2]
        d = np.sqrt(b * (x * x + y * y) + z * z)
        den = a * d + (1.0 - a) * z
        uv = np.stack([self.fu * x / den + self.pu, self.fv * y / den + self.pv], axis=-1)
        return uv, (z > -self._w * d) & (den > 0)

    def lift(self, uv):
        a, b = self.alpha, self.beta
        mx = (uv[..., 0] - self.pu) / self.fu
        my = (uv[..., 1] - self.pv) / self.fv
        r2 = mx * mx + my * my
        disc = 1.0 - (2.0 * a - 1.0) * b * r2
        mz = (1.0 - b * a * a * r2) / (a * np.sqrt(np.maximum(disc, 0.0)) + 1.0 - a)
        X = np.stack([mx, my, mz], axis=-1)
        X /= np.linalg.norm(X, axis=-1, keepdims=True)
        valid = disc >= 0 if a > 0.5 else np.isfinite(r2)
        return X, valid & np.all(np.isfinite(X), axis=-1)
