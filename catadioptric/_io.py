"""Atomic file writes and JSON-safe values, shared by datasets, reports and benchmarks."""
from __future__ import annotations

import hashlib
import json
import os
import tempfile

import numpy as np

__all__ = ["atomic_write_bytes", "atomic_write_json", "jsonable", "sha256_file"]


def _umask() -> int:
    m = os.umask(0)
    os.umask(m)
    return m


_FILE_MODE = 0o666 & ~_umask()


def atomic_write_bytes(path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and ``os.replace``
    (readers see the old file or the new one, never a part). Creates the folder."""
    path = os.fspath(path)
    d = os.path.dirname(path) or "."
    os.makedirs(d, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp", dir=d)
    try:
        os.fchmod(fd, _FILE_MODE)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def jsonable(x):
    """JSON-safe values: numpy arrays and scalars to Python, non-finite floats to None."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x


def atomic_write_json(path, obj, *, indent: int | None = 1) -> None:
    """Write ``obj`` (made JSON-ready by :func:`jsonable`) to ``path`` atomically; ``indent=None``:
    on one line, for large files read by programs only."""
    atomic_write_bytes(path, (json.dumps(jsonable(obj), indent=indent, allow_nan=False) + "\n").encode())


def sha256_file(path) -> str:
    """The SHA-256 (hex) of a file's bytes, read in blocks."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
