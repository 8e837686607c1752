"""Independent, deliberately simple and slow reflection oracle for the tests.

It shares no code with the library's solvers: it scans the mirror patch on a
dense (azimuth, height) grid for near-solutions of the reflection law, refines
each local minimum with scipy's least_squares, and checks visibility by
solving ray-quadric intersections with numpy.roots, one ray at a time.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares


def _surface(A, B, C, phi, z):
    rho = np.sqrt(np.maximum(C - A * z * z - B * z, 0.0))
    return np.stack([rho * np.cos(phi), rho * np.sin(phi), z], axis=-1)


def _reflected(A, B, c, r):
    n = np.stack([r[..., 0], r[..., 1], A * r[..., 2] + B / 2], axis=-1)
    i = r - c
    i = i / np.linalg.norm(i, axis=-1, keepdims=True)
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    return i - 2 * np.sum(i * n, axis=-1, keepdims=True) * n


def _target_dir(r, target, w):
    t = target - w * r
    return t / np.linalg.norm(t, axis=-1, keepdims=True)


def _hits(A, B, C, zmin, zmax, o, d, t_lo, t_hi):
    """Does o + t d meet the patch for t in (t_lo, t_hi)? (numpy.roots, one ray)"""
    a = d[0] ** 2 + d[1] ** 2 + A * d[2] ** 2
    b = 2 * (o[0] * d[0] + o[1] * d[1] + A * o[2] * d[2]) + B * d[2]
    cc = o[0] ** 2 + o[1] ** 2 + A * o[2] ** 2 + B * o[2] - C
    for t in np.roots([a, b, cc]):
        if abs(t.imag) < 1e-12 and t_lo < t.real < t_hi:
            z = o[2] + t.real * d[2]
            if zmin <= z <= zmax:
                return True
    return False


def reflection_points(cam, target, w=1.0, n_phi=720, n_z=400, sign=+1):
    """All reflection points of one target (point, w = 1; direction, w = 0) in the patch.

    ``sign=-1`` searches reflected rays pointing away from the target instead.
    Returns a list of (r, valid) with r in M.
    """
    m = cam.mirror
    A, B, C = m.A, m.B, m.C
    c = np.asarray(cam.center, float)
    target = np.asarray(target, float)
    L = m.scale
    # heights spaced uniformly in arc length along a meridian, so that the grid stays dense
    # near the vertex (where the radius changes fast with z)
    zf = np.linspace(m.z_min, m.z_max, 20001)
    rf = np.sqrt(np.maximum(C - A * zf * zf - B * zf, 0.0))
    s_arc = np.r_[0.0, np.cumsum(np.hypot(np.diff(zf), np.diff(rf)))]
    zs = np.interp(np.linspace(0.0, s_arc[-1], n_z), s_arc, zf)
    phis = np.linspace(0, 2 * np.pi, n_phi, endpoint=False)
    P, Z = np.meshgrid(phis, zs, indexing="ij")
    R = _surface(A, B, C, P, Z)
    with np.errstate(all="ignore"):
        e = np.linalg.norm(_reflected(A, B, c, R) - sign * _target_dir(R, target, w), axis=-1)
    e = np.where(np.isfinite(e) & (C - A * Z * Z - B * Z >= 0), e, np.inf)
    # local minima on the grid (azimuth wraps around)
    pad = np.pad(e, ((0, 0), (1, 1)), constant_values=np.inf)
    pad = np.concatenate([pad[-1:], pad, pad[:1]], axis=0)
    core = pad[1:-1, 1:-1]
    ismin = np.ones_like(core, dtype=bool)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            if di or dj:
                ismin &= core <= pad[1 + di: pad.shape[0] - 1 + di, 1 + dj: pad.shape[1] - 1 + dj]
    seeds = np.argwhere(ismin & (core < 0.3))

    def resid(x):
        r = x * L
        omega = (r[0] ** 2 + r[1] ** 2 + A * r[2] ** 2 + B * r[2] - C) / L**2
        return np.r_[_reflected(A, B, c, r) - sign * _target_dir(r, target, w), omega]

    found = []
    for i, j in seeds:
        x0 = _surface(A, B, C, phis[i], zs[j]) / L
        sol = least_squares(resid, x0, xtol=1e-15, ftol=1e-15, gtol=1e-15, method="lm")
        if np.linalg.norm(sol.fun) > 1e-11:
            continue
        r = sol.x * L
        if not (m.z_min - 1e-12 <= r[2] <= m.z_max + 1e-12) or C - A * r[2] ** 2 - B * r[2] < 0:
            continue
        if any(np.linalg.norm(r - f[0]) < 1e-9 * L for f in found):
            continue
        # visibility, one ray at a time
        t_end = 1 - 1e-9 if w > 0.5 else np.inf
        blocked_in = _hits(A, B, C, m.z_min, m.z_max, c, r - c, 1e-9, 1 - 1e-9)
        # the reflected ray leaves along sign * (target - w r): for the -s points, along -s
        blocked_out = _hits(A, B, C, m.z_min, m.z_max, r, sign * (target - w * r), 1e-9, t_end)
        front = (cam.R_cam_from_mirror @ (r - c))[2] > 0
        found.append((r, bool(front and not blocked_in and not blocked_out)))
    return found
