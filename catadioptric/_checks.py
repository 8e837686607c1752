"""Argument checks shared by the public API: every error names the argument,
what was expected and what was given."""
from __future__ import annotations

import numpy as np


class CatadioptricError(ValueError):
    """Bad input to a catadioptric function: the message names the argument."""


def _describe(a: np.ndarray) -> str:
    return f"an array of shape {a.shape}"


def _kind_error(name: str, value, what: str) -> CatadioptricError:
    return CatadioptricError(f"{name}: expected real numbers, got {what}")


def as_float_array(value, name: str, last: int | tuple[int, ...] | None = None, *, finite: bool = True,
                   min_ndim: int = 0) -> np.ndarray:
    """``value`` as a float64 array, checked for its trailing shape and finiteness.

    Only real numbers are accepted: complex values (whose imaginary part would be dropped),
    booleans, dates and strings are refused rather than converted."""
    if isinstance(value, (str, bytes, dict, set)):
        raise _kind_error(name, value, f"{type(value).__name__} {value!r:.60}")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise _kind_error(name, value, f"{type(value).__name__} ({exc})") from None
    if raw.dtype.kind not in "fiuO":
        raise _kind_error(name, value, f"an array of dtype {raw.dtype}")
    if raw.dtype.kind == "O":
        bad = [v for v in raw.reshape(-1)[:100000]
               if isinstance(v, (bool, np.bool_, str, bytes, complex, np.complexfloating))]
        if bad:
            raise _kind_error(name, value, f"an array holding {type(bad[0]).__name__} {bad[0]!r:.60}")
    try:
        a = np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise _kind_error(name, value, f"{type(value).__name__} ({exc})") from None
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
    """``value`` as a float: a real number (not a bool, a string or a complex number)."""
    if isinstance(value, (bool, np.bool_, str, bytes, complex, np.complexfloating)) or (
            isinstance(value, np.ndarray) and value.dtype.kind not in "fiu"):
        raise CatadioptricError(f"{name}: expected a real number, got {value!r}")
    try:
        f = float(value)
    except (TypeError, ValueError):
        raise CatadioptricError(f"{name}: expected a real number, got {value!r}") from None
    if finite and not np.isfinite(f):
        raise CatadioptricError(f"{name}: expected a finite number, got {f!r}")
    if positive and not f > 0:
        raise CatadioptricError(f"{name}: expected a positive number, got {f!r}")
    return f


def as_count(value, name: str, *, minimum: int = 1, maximum: int | None = None) -> int:
    """``value`` as an int in ``[minimum, maximum]`` (an integer type; not a bool, float or string)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise CatadioptricError(f"{name}: expected an integer, got {value!r}")
    v = int(value)
    if v < minimum or (maximum is not None and v > maximum):
        want = f">= {minimum}" if maximum is None else f"in [{minimum}, {maximum}]"
        raise CatadioptricError(f"{name}: expected an integer {want}, got {v}")
    return v


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
