"""Back-projection (pixel -> reflected ray) and exact forward projection (point -> every pixel).

All functions are batched over leading axes and work in float64. Results with
several solutions carry a fixed-width axis (NaN-padded) and a ``valid`` mask.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ._checks import CatadioptricError, as_float_array
from ._numeric import norm, row_norm, rowdot, unit
from .mirrors import QuadricMirror
from .solvers.reflection import reflect

if TYPE_CHECKING:  # annotations only: cameras.py sits above this module and calls it
    from .cameras import CatadioptricCamera

__all__ = ["Rays", "Projections", "backproject", "project", "project_from", "intersect_mirror", "visibility"]

# the patch's ends, widened by this fraction of the mirror's scale: a point computed at an end (a vertex at
# z_max, a rim) rounds to either side; the solvers, back-projection and forward projection keep it alike
RIM = 1e-12


@dataclass
class Rays:
    """Reflected rays: ``origins (..., 3)`` on the mirror, unit ``directions (..., 3)``, ``valid (...)``.

    ``hit`` is True where the pixel's ray meets the mirror patch (origins and
    directions are set there, NaN elsewhere); ``valid`` also requires that the
    reflected ray leaves without meeting the patch again (a concave mirror can
    send it back onto itself), so that the pixel sees the world along it.
    """

    origins: np.ndarray
    directions: np.ndarray
    valid: np.ndarray
    hit: np.ndarray


@dataclass
class Projections:
    """Every image of each point: ``uv (..., K, 2)``, ``mirror_points (..., K, 3)``, ``valid (..., K)``.

    Entries are ordered valid first; ``in_image`` tells which valid pixels fall on
    the image rectangle. Invalid entries that are still reflection points in the
    patch (occluded, behind the camera) keep their coordinates; empty slots are NaN.
    """

    uv: np.ndarray
    mirror_points: np.ndarray
    valid: np.ndarray
    in_image: np.ndarray


def _quadratic_coeffs(A: float, B: float, C: float, o: np.ndarray, d: np.ndarray):
    """``Omega(o + t d) = a t^2 + b t + c`` for the mirror ``x^2 + y^2 + A z^2 + B z - C``."""
    a = d[..., 0] ** 2 + d[..., 1] ** 2 + A * d[..., 2] ** 2
    b = 2 * (o[..., 0] * d[..., 0] + o[..., 1] * d[..., 1] + A * o[..., 2] * d[..., 2]) + B * d[..., 2]
    c = o[..., 0] ** 2 + o[..., 1] ** 2 + A * o[..., 2] ** 2 + B * o[..., 2] - C
    return a, b, c


def _normalised(mirror: QuadricMirror):
    """The mirror's coefficients with lengths in units of its scale (every test below is unit-free)."""
    L = mirror.scale
    return L, mirror.A, mirror.B / L, mirror.C / (L * L), mirror.z_min / L, mirror.z_max / L


def intersect_mirror(mirror: QuadricMirror, origins, directions, t_min: float = 0.0, *, rim: float = 0.0):
    """First parameter ``t > t_min`` at which ``origins + t directions`` meets the mirror
    patch (NaN where none); hits of the quadric outside the patch do not count. ``rim``: the
    patch's ends widened by this fraction of the mirror's scale (rounding of points computed
    at an end). Computed in units of the mirror's scale along unit directions, so that the
    answer does not depend on the length unit nor on the length of ``directions``."""
    L, A, B, C, zlo, zhi = _normalised(mirror)
    o = np.asarray(origins, dtype=float) / L
    d = np.asarray(directions, dtype=float)
    dn = norm(d)
    u = unit(d)
    a, b, c = _quadratic_coeffs(A, B, C, o, u)
    disc = b * b - 4 * a * c
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        # the stable pair of roots; a = 0 (a ray along an asymptotic direction) leaves the one root -c/b
        sq = np.sqrt(disc)
        q = -0.5 * (b + np.copysign(sq, b))
        t1 = np.where(disc >= 0, q / a, np.nan)
        t2 = np.where(disc >= 0, c / q, np.nan)
        tmin = t_min * dn / L
    lo = np.fmin(t1, t2)
    hi = np.fmax(t1, t2)
    out = np.full(np.broadcast_shapes(a.shape), np.nan)
    for t in (hi, lo):  # lo last so that it wins when both qualify
        with np.errstate(invalid="ignore", over="ignore"):
            z = o[..., 2] + t * u[..., 2]
        ok = np.isfinite(t) & (t > tmin) & (z >= zlo - rim) & (z <= zhi + rim)
        out = np.where(ok, t, out)
    with np.errstate(over="ignore"):
        return out * (L / dn)


def backproject(cam: CatadioptricCamera, uv) -> Rays:
    uv = as_float_array(uv, "uv", 2)
    d_cam = cam.pinhole.pixel_rays(uv)
    d = unit(rowdot(d_cam, cam.R_cam_from_mirror))  # R^T d_cam, row-vector form
    o = np.broadcast_to(cam.center, d.shape)
    t = intersect_mirror(cam.mirror, o, d, rim=RIM)
    valid = np.isfinite(t)
    r = o + t[..., None] * d
    n = cam.mirror.normal(r)
    out = unit(reflect(d, n))
    r = np.where(valid[..., None], r, np.nan)
    out = np.where(valid[..., None], out, np.nan)
    with np.errstate(invalid="ignore"):
        again = np.isfinite(intersect_mirror(cam.mirror, r, out, t_min=1e-9 * cam.mirror.scale))
    return Rays(r, out, valid & ~again, valid)


def visibility(cam: CatadioptricCamera, r: np.ndarray, target: np.ndarray, w: np.ndarray) -> np.ndarray:
    """For reflection points ``r (..., 3)`` of homogeneous targets ``(target, w)``: True where the
    camera ray reaches ``r`` without meeting the patch first, the reflected ray reaches the
    target without meeting the patch again, and ``r`` is in front of the camera.

    Lengths in units of the mirror's scale; the reflected ray along a unit vector, so that
    targets of any magnitude (up to the float range) are tested alike."""
    from .solvers._batch_kernels import visibility_rows

    L, A, B, C, zlo, zhi = _normalised(cam.mirror)
    # the camera ray c + t (r - c): t = 1 is a root; blocked where the other, the product of roots c/a,
    # is in (eps, 1 - eps) and on the patch; the reflected ray r + t v, v the unit vector toward the
    # target: t = 0 is a root, blocked where the other, -b/a, is in (eps, |target - r| (1 - eps)) (w = 1)
    # or beyond eps (w = 0) and on the patch; eps = 1e-9. One point at a time, compiled.
    shape = np.shape(r)[:-1]
    rf = np.ascontiguousarray(r, dtype=float).reshape(-1, 3)
    tg = np.ascontiguousarray(np.broadcast_to(target, shape + (3,)), dtype=float).reshape(-1, 3)
    ww = np.ascontiguousarray(np.broadcast_to(w, shape), dtype=float).reshape(-1)
    out = np.empty(len(rf), dtype=bool)
    visibility_rows(rf, tg, ww, A, B, C, zlo, zhi, L, np.asarray(cam.center, dtype=float),
                    np.ascontiguousarray(cam.R_cam_from_mirror[2], dtype=float), out)
    return out.reshape(shape)


CHUNK = 1 << 16  # targets per batch: large enough to amortise numpy, small enough to stay in cache


@dataclass
class FlatSolutions:
    """Reflection points as flat arrays: ``owner`` (target index), ``points (M, 3)``,
    ``forward``, ``visible`` (see :func:`visibility`), ``uv (M, 2)``."""

    owner: np.ndarray
    points: np.ndarray
    forward: np.ndarray
    visible: np.ndarray
    uv: np.ndarray

    def scatter(self, N: int, K: int, keep: np.ndarray, key: np.ndarray):
        """(N, K) arrays of the kept entries, ordered by ``key`` within each target, NaN-padded."""
        from .solvers.reflection import rank_within

        o, k = self.owner[keep], key[keep]
        order, slot = rank_within(o, k)
        ok = slot < K
        o, sl, sel = o[order][ok], slot[ok], np.nonzero(keep)[0][order][ok]
        from .solvers._batch_kernels import put_rows

        r = np.full((N, K, 3), np.nan)
        uv = np.full((N, K, 2), np.nan)
        at = o * K + sl  # flat slot
        put_rows(r.reshape(-1, 3), at, np.ascontiguousarray(self.points, dtype=float), sel)
        put_rows(uv.reshape(-1, 2), at, np.ascontiguousarray(self.uv, dtype=float), sel)
        return o, sl, sel, r, uv


def solve_targets(cam: CatadioptricCamera, targets: np.ndarray, w: float, backward: bool = False) -> FlatSolutions:
    """Every reflection point in the patch of flat targets ``(N, 3)`` (w = 1 points, 0 directions)."""
    solver = cam.solver
    parts = [solver.solve_flat(targets[i:i + CHUNK], float(w), backward=backward)
             for i in range(0, max(len(targets), 1), CHUNK)]
    owner = np.concatenate([p[0] + i * CHUNK for i, p in enumerate(parts)])
    r = np.concatenate([p[1] for p in parts])
    fwd = np.concatenate([p[2] for p in parts])
    inside = cam.mirror.in_patch(r, RIM)  # the patch, its ends kept to rounding
    owner, r, fwd = owner[inside], r[inside], fwd[inside]
    tg = targets[owner]
    if w == 0:  # a -s point's reflected ray leaves along -s: test that ray for obstruction
        tg = np.where(fwd[:, None], tg, -tg)
    vis = visibility(cam, r, tg, np.full(len(owner), float(w)))
    uv = cam.pixels_of_mirror_points(r)
    return FlatSolutions(owner, r, fwd, vis, uv)


def project(cam: CatadioptricCamera, points) -> Projections:
    pts = as_float_array(points, "points", 3)
    shape = pts.shape[:-1]
    flat = pts.reshape(-1, 3)
    N, K = len(flat), cam.solver.max_solutions
    fs = solve_targets(cam, flat, 1.0)
    valid_flat = fs.forward & fs.visible
    # valid first, then the other reflection points (occluded, behind the camera)
    o, sl, sel, r, uv = fs.scatter(N, K, fs.forward, (~valid_flat).astype(np.int8))
    valid = np.zeros((N, K), dtype=bool)
    in_img = np.zeros((N, K), dtype=bool)
    at = o * K + sl
    valid.reshape(-1)[at] = valid_flat[sel]
    in_img.reshape(-1)[at] = valid_flat[sel] & cam.pinhole.in_image(fs.uv[sel])
    return Projections(uv.reshape(shape + (K, 2)), r.reshape(shape + (K, 3)), valid.reshape(shape + (K,)),
                       in_img.reshape(shape + (K,)))


def project_from(cam: CatadioptricCamera, points, start):
    """The image of each point continued from a nearby reflection point: Newton's method on
    Fermat's principle (the solvers' own polish and acceptance test,
    :func:`catadioptric.solvers._kernels.polish_accept`) from ``start (N, 3)``, the reflection
    point of a point close to ``points (N, 3)`` (M).

    Returns ``uv (N, 2)``, ``mirror_points (N, 3)`` and ``ok (N,)``: True where Newton's method
    converged to a reflection point in the patch within ``0.25`` of the mirror's scale of its
    start, toward the point and visible (:func:`visibility`); NaN elsewhere. This is the valid
    image of :func:`project` that the start's image continues into, found without the search for
    every image: an optimiser that moves its points a little per step (:mod:`catadioptric.pose.bundle`)
    re-projects them at a fraction of the cost. Where ``ok`` is False (no start, a long move, a
    point that became occluded), :func:`project` decides."""
    from .solvers._batch_kernels import homogeneous_units
    from .solvers._kernels import polish_accept
    from .solvers.reflection import ACCEPT

    P = as_float_array(points, "points", 3, finite=False).reshape(-1, 3)
    r0 = as_float_array(start, "start", 3, finite=False).reshape(-1, 3)
    if len(r0) != len(P):
        raise CatadioptricError(f"start: expected one reflection point per point ({len(P)}), got {len(r0)}")
    N = len(P)
    uv = np.full((N, 2), np.nan)
    r = np.full((N, 3), np.nan)
    ok = np.zeros(N, dtype=bool)
    owner = np.nonzero(np.all(np.isfinite(r0), axis=1) & np.all(np.isfinite(P), axis=1))[0]
    if not len(owner):
        return uv, r, ok
    L, A, B, C, zlo, zhi = _normalised(cam.mirror)
    h = np.empty((N, 4))
    homogeneous_units(np.ascontiguousarray(P), np.full(N, L), h)
    out_o = np.empty(len(owner), dtype=np.intp)
    rr = np.empty((len(owner), 3))
    fwd = np.empty(len(owner), dtype=bool)
    m = polish_accept(h, owner, np.ascontiguousarray(r0[owner] / L), A, B, C,
                      np.ascontiguousarray(cam.center, dtype=float) / L, zlo, zhi, False, 6, ACCEPT, out_o, rr, fwd)
    o, rr = out_o[:m], rr[:m] * L
    near = row_norm(rr - r0[o]) <= 0.25 * L
    o, rr = o[near], rr[near]
    vis = visibility(cam, rr, P[o], np.ones(len(o)))
    o, rr = o[vis], rr[vis]
    r[o] = rr
    uv[o] = cam.pixels_of_mirror_points(rr)
    ok[o] = True
    return uv, r, ok
