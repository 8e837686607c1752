"""Batched bivariate polynomials in (y, t): arrays ``P[..., i, j]`` multiplying ``y**i t**j``.

Just enough algebra to build the reflection constraints for a whole batch of
targets at once; loops run over the (small) degrees only.
"""
from __future__ import annotations

import numpy as np

from .polynomial import polymul


def const(value) -> np.ndarray:
    """A (batch of) constant(s) as bivariate polynomials ``(..., 1, 1)``."""
    return np.asarray(value, dtype=float)[..., None, None]


def from_t(p: np.ndarray) -> np.ndarray:
    """A polynomial in t only, ``(..., n)``, as a bivariate one ``(..., 1, n)``."""
    return np.asarray(p, dtype=float)[..., None, :]


Y = np.array([[0.0], [1.0]])  # the monomial y


def add(*terms: np.ndarray) -> np.ndarray:
    ny = max(t.shape[-2] for t in terms)
    nt = max(t.shape[-1] for t in terms)
    shape = np.broadcast_shapes(*(t.shape[:-2] for t in terms)) + (ny, nt)
    out = np.zeros(shape)
    for t in terms:
        out[..., : t.shape[-2], : t.shape[-1]] += t
    return out


def scale(p: np.ndarray, k) -> np.ndarray:
    return p * np.asarray(k, dtype=float)[..., None, None]


def mul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    ny = p.shape[-2] + q.shape[-2] - 1
    nt = p.shape[-1] + q.shape[-1] - 1
    shape = np.broadcast_shapes(p.shape[:-2], q.shape[:-2]) + (ny, nt)
    out = np.zeros(shape)
    for i in range(p.shape[-2]):
        for j in range(q.shape[-2]):
            out[..., i + j, :] += polymul(p[..., i, :], q[..., j, :])
    return out


def y_coefficient(p: np.ndarray, k: int, nt: int | None = None) -> np.ndarray:
    """The t-polynomial multiplying ``y**k`` (zeros when absent), padded to ``nt`` terms."""
    nt = p.shape[-1] if nt is None else nt
    out = np.zeros(p.shape[:-2] + (nt,))
    if k < p.shape[-2]:
        m = min(nt, p.shape[-1])
        out[..., :m] = p[..., k, :m]
    return out
