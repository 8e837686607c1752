"""Argument checks shared by the public API: every error names the argument,
what was expected and what was given."""
from __future__ import annotations

import numpy as np


class CatadioptricError(ValueError):
    """Bad input to a catadioptric function: the message names the argument."""


def _describe(a: np.ndarray) -> str:
    return f"an array of shape {a.shape}"


def as_float_array(value, name: str, last: int | tuple[int, ...] | None = None, *, finite: bool = True,
                   min_ndim: int = 0) -> np.ndarray:
    """``value`` as a float64 array, checked for its trailing shape and finiteness."""
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise CatadioptricError(f"{name}: expected numbers, got {type(value).__name__} ({exc})") from None
    if last is not None:
        tail = (last,) if isinstance(last, int) else tuple(last)
        if a.ndim < len(tail) or a.shape[a.ndim - len(tail):] != tail:
            want = "(..., " + ", ".join(map(str, tail)) + ")"
            raise CatadioptricError(f"{name}: expected an array of shape {want}, got {_describe(a)}")
    if a.ndim < min_ndim:
        raise CatadioptricError(f"{name}: expected at least {min_ndim} dimensions, got {_describe(a)}")
    if finite and not np.all(np.isfinite(a)):
        bad = np.argwhere(~np.isfinite(a))[0]
        raise CatadioptricError(
            f"{name}: expected finite values, got {float(a[tuple(bad)])!r} at index {tuple(int(i) for i in bad)}"
        )
    return a


def as_scalar(value, name: str, *, positive: bool = False, finite: bool = True) -> float:
    try:
        f = float(value)
    except (TypeError, ValueError):
        raise CatadioptricError(f"{name}: expected a real number, got {value!r}") from None
    if finite and not np.isfinite(f):
        raise CatadioptricError(f"{name}: expected a finite number, got {f!r}")
    if positive and not f > 0:
        raise CatadioptricError(f"{name}: expected a positive number, got {f!r}")
    return f


def as_rotation(value, name: str) -> np.ndarray:
    R = as_float_array(value, name, (3, 3))
    if R.shape != (3, 3):
        raise CatadioptricError(f"{name}: expected a 3x3 rotation matrix, got {_describe(R)}")
    err = np.max(np.abs(R @ R.T - np.eye(3)))
    if err > 1e-9 or np.linalg.det(R) < 0:
        raise CatadioptricError(
            f"{name}: expected a rotation matrix (orthonormal, det +1), got one with "
            f"|R R^T - I| = {err:.3g} and det {np.linalg.det(R):.6g}"
        )
    return R
