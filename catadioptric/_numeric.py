"""Numerical helpers shared by the geometry: products that give every row the same bits
whatever the batch, and norms that neither overflow nor underflow.

* :func:`rowdot` multiplies a batch of rows by a fixed matrix. A BLAS product (``a @ b``)
  rounds a row differently depending on where the row falls in the blocks the library
  splits the batch into, and on the number of BLAS threads: the same point projected alone
  or in a batch, or in a process with another ``OPENBLAS_NUM_THREADS`` (a Dask worker sets
  it to 1), would get other last bits, which near a degeneracy can decide whether a
  solution is kept. ``np.einsum`` without ``optimize`` sums each entry in the order of the
  inner index, without BLAS.
* :func:`row_norm`: ``np.linalg.norm(v, axis=-1)`` of short rows (2- or 3-vectors), the same bits,
  without the strided reduction numpy runs over a last axis that short (4-12 times the time of
  the squares summed one component after the other, on the line fits' batches).
* :func:`unit` and :func:`norm` divide by the largest component before squaring, so that
  vectors of any finite length (1e-300 or 1e300) keep their direction.
"""
from __future__ import annotations

import numpy as np

__all__ = ["rowdot", "unit", "norm", "row_norm", "max_abs", "cross", "LUMA"]

#: the luminance of RGB levels: Rec. 601 weights, as OpenCV's colour-to-grey conversion (one convention for the
#: whole project: detection, chessboard corners, the sides of a line)
LUMA = np.array([0.299, 0.587, 0.114])


def rowdot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` for rows ``a (..., k)`` and a matrix ``b (k, n)`` or a vector ``b (k,)``, every
    row rounded the same way whatever the batch it is in (no BLAS)."""
    b = np.asarray(b, dtype=float)
    return np.einsum("...k,k->...", a, b) if b.ndim == 1 else np.einsum("...k,kn->...n", a, b)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross(a, b)`` of 3-vectors along the last axis (broadcast), to the same bits (the same
    products and differences), without ``np.cross``'s per-call overhead (axis handling: about 20 us a
    call, which the refinement's finite differences pay tens of thousands of times)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def row_norm(v: np.ndarray) -> np.ndarray:
    """``np.linalg.norm(v, axis=-1)`` to the same bits (the same squares, added in the same order:
    numpy's reduction adds fewer than 8 of them one after the other from the first; longer rows,
    which it sums pairwise, are passed to it), for rows ``v (..., k)``; the squares neither scaled
    nor guarded (:func:`norm` for that)."""
    v = np.asarray(v, dtype=float)
    if not 0 < v.shape[-1] < 8:
        return np.linalg.norm(v, axis=-1)
    s = v[..., 0] * v[..., 0]
    for i in range(1, v.shape[-1]):
        s = s + v[..., i] * v[..., i]
    return np.sqrt(s)


def max_abs(v: np.ndarray, axis: int = -1, keepdims: bool = True) -> np.ndarray:
    """The largest absolute component along ``axis``."""
    return np.max(np.abs(v), axis=axis, keepdims=keepdims)


def unit(v: np.ndarray, axis: int = -1) -> np.ndarray:
    """``v / |v|`` along ``axis`` without overflow or underflow (NaN for zero vectors)."""
    v = np.asarray(v, dtype=float)
    m = max_abs(v, axis)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = v / m
        return w / np.linalg.norm(w, axis=axis, keepdims=True)


def norm(v: np.ndarray, axis: int = -1) -> np.ndarray:
    """``|v|`` along ``axis`` without overflow or underflow of the squares (inf only when the
    length itself is beyond the float range)."""
    v = np.asarray(v, dtype=float)
    m = max_abs(v, axis)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        w = np.where(m > 0, v / np.where(m > 0, m, 1.0), 0.0)
        return (m * np.linalg.norm(w, axis=axis, keepdims=True)).squeeze(axis)
