"""Shared plumbing of the benchmarks: metadata, timing, atomic JSON output."""
from __future__ import annotations

import os
import platform
import subprocess
import time

import numpy as np


def metadata() -> dict:
    import scipy

    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                                cwd=os.path.dirname(__file__)).stdout.strip() or None
        dirty = bool(subprocess.run(["git", "status", "--porcelain"], capture_output=True, text=True,
                                    cwd=os.path.dirname(__file__)).stdout.strip())
    except OSError:
        commit, dirty = None, None
    cpu = platform.processor()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {
        "commit": commit,
        "dirty": dirty,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "machine": {"cpu": cpu, "cores": os.cpu_count(), "system": platform.platform()},
        "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }


def best_time(fn, repeat: int = 3) -> float:
    """Best wall time of ``repeat`` runs (the least disturbed by other load)."""
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def write_json(path: str, data: dict) -> None:
    from catadioptric._io import atomic_write_json

    atomic_write_json(path, data, indent=2)


def least_squares_reflection(cam, target, w: float):
    """One reflection point of a target by scipy's least_squares (the per-target baseline of the
    benchmarks): a point ``target`` (w = 1) or a direction (w = 0), started in the middle of
    the patch on the side facing the target; finds one solution only."""
    from scipy.optimize import least_squares

    m, c, L = cam.mirror, cam.center, cam.mirror.scale
    z0 = 0.5 * (m.z_min + m.z_max)
    rho = np.sqrt(max(float(m.radius_squared(z0)), 0.0))
    az = np.arctan2(target[1], target[0])
    r0 = np.array([rho * np.cos(az), rho * np.sin(az), z0])

    def f(x):
        r = x * L
        n = m.normal(r)
        n = n / np.linalg.norm(n)
        i = (r - c) / np.linalg.norm(r - c)
        o = target - w * r
        return np.r_[i - 2 * (i @ n) * n - o / np.linalg.norm(o), m.implicit(r) / L**2]

    return least_squares(f, r0 / L, xtol=1e-14, ftol=1e-14, gtol=1e-14).x * L
