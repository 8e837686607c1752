"""Linear line solvers on reflected rays: the Pluecker null space (4-pixel minimal sets), the
near-central plane candidates, and lines of a known direction."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError
from ..cameras import CatadioptricCamera
from ._common import check_camera, check_uv, tangent_basis


# --------------------------------------------------------------------------- linear solver
@dataclass
class _RayFrame:
    """Rays of the valid pixels in a normalised frame: origin ``x0`` (the point nearest all
    rays), moment scale ``eps`` (rms distance of the rays from ``x0``), ``dmin``: the smallest
    distance from ``x0`` a line may have (see :func:`_far_enough`)."""

    o: np.ndarray
    d: np.ndarray
    x0: np.ndarray
    eps: float
    dmin: float = 0.0


def pushed_out(frame: _RayFrame, L) -> np.ndarray:
    """The lines ``L (n, 6)`` (unit ``s``) moved, where closer than ``frame.dmin`` to ``x0``, away from it
    to that distance (same direction). A line through the point where a near-central rig's
    reflected rays nearly meet meets every ray and fits any pixels: no candidate starts there."""
    if frame.dmin <= 0 or len(L) == 0:
        return L
    s, m = L[:, :3], L[:, 3:]
    foot = np.cross(s, m - np.cross(frame.x0, s))  # from x0 to the line, normal to s
    dist = np.linalg.norm(foot, axis=-1)
    close = dist < frame.dmin
    if not close.any():
        return L
    fallback = tangent_basis(s[close])[0]
    u = np.where((dist[close] > 1e-12 * frame.dmin)[:, None], foot[close] / np.maximum(dist[close], 1e-300)[:, None],
                 fallback)
    q = frame.x0 + frame.dmin * u
    out = L.copy()
    out[close, 3:] = np.cross(q, s[close])
    return out


def ray_frame(cam, o, d, dmin: float = 0.0) -> _RayFrame:
    """The rays ``o, d`` in a normalised frame centred on the point nearest all of them (see :class:`_RayFrame`)."""
    proj = np.eye(3) - d[:, :, None] * d[:, None, :]
    A = proj.sum(axis=0)
    b = np.einsum("nij,nj->i", proj, o)
    try:
        x0 = np.linalg.solve(A, b)
        if not np.all(np.isfinite(x0)) or np.linalg.norm(x0) > 1e3 * cam.mirror.scale:
            raise np.linalg.LinAlgError
    except np.linalg.LinAlgError:
        x0 = np.mean(o, axis=0)
    mom = np.cross(o - x0, d)
    eps = float(np.sqrt(np.mean(np.sum(mom**2, axis=-1))))
    eps = max(eps, 1e-9 * cam.mirror.scale)
    return _RayFrame(o, d, x0, eps, float(dmin))


def candidates_from_rays(frame: _RayFrame, o, d):
    """Candidate lines ``(s, m)`` meeting rays ``o, d (S, k, 3)`` (k >= 4); returns ``L (S, 3, 6)``
    (unit s, Pluecker exact) and ``ok (S, 3)``. Candidates: the two real roots of the
    Pluecker quadratic on the span of the two smallest right singular vectors (or its
    best real approximation), and the smallest singular vector made Pluecker."""
    o = o - frame.x0
    rows = np.concatenate([np.cross(o, d) / frame.eps, d], axis=-1)  # unknowns (eps s, m')
    rows = rows / np.maximum(np.linalg.norm(rows, axis=-1, keepdims=True), 1e-300)
    _, _, Vt = np.linalg.svd(rows, full_matrices=rows.shape[-2] < 6)
    v1, v2 = Vt[:, -1, :], Vt[:, -2, :]
    a1, b1, a2, b2 = v1[:, :3], v1[:, 3:], v2[:, :3], v2[:, 3:]
    q11 = np.sum(a1 * b1, axis=-1)
    q22 = np.sum(a2 * b2, axis=-1)
    q12 = 0.5 * (np.sum(a1 * b2, axis=-1) + np.sum(a2 * b1, axis=-1))
    Q = np.stack([np.stack([q11, q12], -1), np.stack([q12, q22], -1)], -2)
    lam, U = np.linalg.eigh(Q)  # ascending
    real = lam[:, 0] * lam[:, 1] <= 0
    sq0 = np.sqrt(np.abs(lam[:, 1]))  # weight of eigvec 0
    sq1 = np.sqrt(np.abs(lam[:, 0]))
    c_plus = U[:, :, 0] * sq0[:, None] + U[:, :, 1] * sq1[:, None]
    c_minus = U[:, :, 0] * sq0[:, None] - U[:, :, 1] * sq1[:, None]
    # no real root: the combination nearest to isotropic (eigenvector of smaller |eigenvalue|)
    small = np.where((np.abs(lam[:, 0]) < np.abs(lam[:, 1]))[:, None], U[:, :, 0], U[:, :, 1])
    c_plus = np.where(real[:, None], c_plus, small)
    combos = np.stack([c_plus, c_minus, np.tile([1.0, 0.0], (len(v1), 1))], axis=1)  # (S, 3, 2)
    y = combos[..., 0:1] * v1[:, None, :] + combos[..., 1:2] * v2[:, None, :]
    s = y[..., :3] / frame.eps
    mp = y[..., 3:]
    ok = np.ones(s.shape[:2], dtype=bool)
    ok[:, 1] = real
    ns = np.linalg.norm(s, axis=-1)
    ok &= ns > 1e-12 * np.maximum(np.linalg.norm(mp, axis=-1), 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = s / ns[..., None]
        mp = mp / ns[..., None]
        mp = mp - np.sum(s * mp, axis=-1, keepdims=True) * s  # exact Pluecker
    m = mp + np.cross(frame.x0, s)
    L = np.concatenate([s, m], axis=-1)
    ok &= np.all(np.isfinite(L), axis=-1)
    return L, ok


def plane_candidates(frame: _RayFrame, o, d, n_angles: int, default_distance: float):
    """Near-central candidates for rays ``o, d (S, k, 3)`` (k >= 2): the lines in the plane through
    ``x0`` that holds the rays' directions best, with ``n_angles`` directions spread over
    the range that keeps every ray on one side (a line seen from ``x0`` spans 180 degrees)
    and the offset from ``x0`` that best meets the rays (``default_distance`` when that
    is not positive). Returns ``L (S, n_angles, 6)`` and ``ok``."""
    _, _, Vt = np.linalg.svd(d, full_matrices=d.shape[-2] < 3)
    n = Vt[:, -1, :]
    a, b = tangent_basis(n)
    th = np.arctan2(np.einsum("skj,sj->sk", d, b), np.einsum("skj,sj->sk", d, a))
    ths = np.sort(th, axis=1)
    gaps = np.diff(np.concatenate([ths, ths[:, :1] + 2 * np.pi], axis=1), axis=1)
    g = np.argmax(gaps, axis=1)
    rows = np.arange(len(ths))
    start = ths[rows, (g + 1) % ths.shape[1]]
    span = 2 * np.pi - gaps[rows, g]
    free = np.maximum(np.pi - span, 0.0)
    frac = (np.arange(n_angles) + 0.5) / n_angles
    phi = (start + span)[:, None] + frac[None, :] * free[:, None]  # (S, n_angles)
    s = np.cos(phi)[..., None] * a[:, None, :] + np.sin(phi)[..., None] * b[:, None, :]
    u = np.cross(n[:, None, :], s)
    dm = np.mean(d, axis=1)
    u = u * np.where(np.sum(u * dm[:, None, :], axis=-1) < 0, -1.0, 1.0)[..., None]
    w = np.cross(u, s)  # q' = h u  =>  m' = h (u x s) = h w
    Mom = np.cross(o - frame.x0, d)  # (S, k, 3)
    sm = np.einsum("sai,ski->sak", s, Mom)
    dw = np.einsum("sai,ski->sak", w, d)
    with np.errstate(invalid="ignore", divide="ignore"):
        h = -np.sum(sm * dw, axis=-1) / np.sum(dw * dw, axis=-1)
    bad = ~np.isfinite(h) | (h <= max(0.1 * default_distance, frame.dmin)) | (h > 1e2 * default_distance)
    h = np.where(bad, default_distance, h)
    q = frame.x0 + h[..., None] * u
    L = np.concatenate([s, np.cross(q, s)], axis=-1)
    ok = np.all(np.isfinite(L), axis=-1) & (span < np.pi)[:, None]
    return L, ok


def all_candidates(cam, frame, o, d, n_angles=8):
    """Every candidate from one set of rays ``(k, 3)``: ``(n, 6)``."""
    L1, ok1 = candidates_from_rays(frame, o[None], d[None])
    L2, ok2 = plane_candidates(frame, o[None], d[None], n_angles, 10.0 * cam.mirror.scale)
    L = np.concatenate([L1[0][ok1[0]], L2[0][ok2[0]]])
    return pushed_out(frame, L)


def line_candidates(cam: CatadioptricCamera, uv) -> np.ndarray:
    """Lines ``(n, 6)`` (Pluecker ``(s, m)``, unit ``s``) meeting the back-projected rays of pixels
    ``uv (M, 2)`` (M >= 4): the roots of the Pluecker constraint on the two-dimensional
    near-null space of ``s . (o_j x d_j) + d_j . m = 0`` and the least-squares null vector
    (see the module docstring), then the near-central candidates (lines in the plane
    through the rays' centre that holds the rays). The true line is among them for exact
    pixels; with noise they are starting points. Pixels that do not see the world are
    ignored."""
    check_camera(cam, "the line")
    uv = check_uv(uv, "uv", 4)
    rays = cam.backproject(uv)
    if int(rays.valid.sum()) < 4:
        raise CatadioptricError(f"uv: expected at least 4 pixels that see the world, got {int(rays.valid.sum())}")
    o, d = rays.origins[rays.valid], rays.directions[rays.valid]
    fr = ray_frame(cam, o, d)
    return all_candidates(cam, fr, o, d)


def moment_candidates(frame, s, o, d, scale):
    """Lines along a fixed unit direction ``s`` that meet rays ``o, d (k, 3)``: the linear
    least-squares moment (``m . s = 0``, ``s . (o_j x d_j) + d_j . m = 0``; good for strongly
    non-central rays) and lines in the plane through ``x0`` that holds the rays, at the
    least-squares offset and at 3, 10 and 30 times the mirror ``scale`` (a near-central
    camera hardly sees the offset). Returns ``(n, 6)``."""
    e1, e2 = tangent_basis(s)
    Mom = np.cross(o - frame.x0, d)
    A = np.stack([d @ e1, d @ e2], axis=-1)
    rhs = -(Mom @ s)
    ab = np.linalg.lstsq(A, rhs, rcond=None)[0]
    out = [np.concatenate([s, ab[0] * e1 + ab[1] * e2 + np.cross(frame.x0, s)])]
    _, _, Vt = np.linalg.svd(d, full_matrices=len(d) < 3)
    u = np.cross(Vt[-1], s)
    nu = np.linalg.norm(u)
    u = u / nu if nu > 1e-12 else e1
    if u @ np.mean(d, axis=0) < 0:
        u = -u
    w = np.cross(u, s)
    dw = d @ w
    h = -np.sum((Mom @ s) * dw) / max(np.sum(dw * dw), 1e-300)
    hs = [3.0 * scale, 10.0 * scale, 30.0 * scale]
    if np.isfinite(h) and scale < h < 1e3 * scale:
        hs.append(h)
    for h in hs:
        out.append(np.concatenate([s, np.cross(frame.x0 + h * u, s)]))
    return pushed_out(frame, np.array(out))


