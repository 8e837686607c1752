"""A seeded fuzzer of the public geometry API: no silent wrong answer, no unclear exception, no hang.

Each case is one call (or a few related calls) built from a seeded numpy generator:

* **valid input** whose answer is known without the library's solvers: pixels back-projected
  and the points along their rays projected again (the pixel must come back), the same rig in
  other length units (the same pixels, flags and rays), directions and points of extreme
  magnitudes (the same answers as for moderate ones), a row alone and in its batch (the same
  flags and pixels), targets near and on the camera's normal rays (the reflection point where
  the camera sees itself), the unified model's round trips;
* **bad input**: wrong types (complex, bool, datetime, strings), shapes, non-finite or
  impossible values and options, which must be refused by a ``CatadioptricError`` whose
  message starts with the name of the offending argument.

Outcomes: ``ok``; ``hang`` (over the time limit); ``traceback`` (any other exception, or a
numpy warning); ``unclear`` (a ``CatadioptricError`` that names no argument of the call);
``accepted`` (bad input not refused); ``refused`` (valid input refused); ``wrong`` (a check
failed). Run ``python tests/fuzz_api.py [--seed S] [--cases N]`` for the figures; the CI
test is ``tests/test_fuzz.py``.
"""
from __future__ import annotations

import argparse
import re
import signal
import sys
import time
import traceback
import warnings
from collections import Counter, defaultdict
from dataclasses import dataclass

import numpy as np

import catadioptric as cd
from catadioptric.rigs import preset, preset_names

OUTCOMES = ("ok", "hang", "traceback", "unclear", "accepted", "refused", "wrong")
W, H = 64, 48  # small images: the curve tracers seed from the pixel grid


class Hang(Exception):
    pass


class Wrong(AssertionError):
    pass


def check(cond, msg):
    if not cond:
        raise Wrong(msg)


@dataclass
class Case:
    family: str
    call: object  # a function of no argument
    names: tuple = ()  # argument names an error may name; () = valid input, no error expected
    label: str = ""


# ----------------------------------------------------------------------------- rigs
def scaled(cam, k):
    """The same rig with every length multiplied by ``k``."""
    m = cam.mirror
    return cd.CatadioptricCamera(cd.QuadricMirror(m.A, m.B * k, m.C * k * k, m.z_min * k, m.z_max * k),
                                 cam.pinhole, cam.center * k, cam.R_cam_from_mirror)


def special_rigs():
    """The issue's rigs: a sphere seen off-axis, a paraboloid seen on its axis."""
    pin = cd.PinholeCamera.from_fov(W, H, 60.0)
    sphere = cd.CatadioptricCamera.looking_at_mirror(cd.QuadricMirror(1.0, 0.0, 1.0, -1.0, 0.0), pin,
                                                     (0.0, 0.8, -3.5), target=(0, 0, -1))
    parab = cd.CatadioptricCamera.looking_at_mirror(cd.QuadricMirror(0.0, 3.4, 33.2, 0.0, 33.2 / 3.4), pin,
                                                    (0.0, 0.0, 26.5), target=(0, 0, 0))
    return {"sphere_off_axis": sphere, "paraboloid_on_axis": parab}


def random_rig(rng):
    """A random rig: every kind of mirror, the camera outside or inside, on or off the axis (or
    within 1e-6 of it), any field of view, in a random length unit."""
    kind = rng.choice(["sphere", "ellipsoid", "hyperboloid", "paraboloid", "cone", "cylinder", "one_sheet",
                       "sphere_inside", "ellipsoid_inside"])
    u = lambda a, b: float(rng.uniform(a, b))
    if kind == "sphere":
        m = cd.QuadricMirror.sphere(u(0.02, 0.1), z_min=0.0, z_max=0.2)
        base = np.array([0.0, 0.0, u(0.2, 0.5)])
    elif kind == "sphere_inside":
        r = u(0.05, 0.1)
        m = cd.QuadricMirror.sphere(r, z_min=-r, z_max=u(0.0, 0.9) * r)
        base = rng.uniform(-0.3, 0.3, 3) * r
    elif kind == "ellipsoid":
        a = u(0.02, 0.06)
        c = a * u(1.2, 2.0)
        f = np.sqrt(c * c - a * a)
        m = cd.QuadricMirror.ellipsoid(a, c, z_min=f + 0.25 * (c - f), z_max=c)
        base = m.foci[0]
    elif kind == "ellipsoid_inside":
        a = u(0.02, 0.06)
        c = a * u(0.5, 2.0)
        m = cd.QuadricMirror.ellipsoid(a, c, z_min=u(-0.5, 0.5) * c, z_max=c)
        base = np.array([0.0, 0.0, -u(0.0, 0.8) * c])
    elif kind == "hyperboloid":
        a, c = u(0.02, 0.05), u(0.02, 0.05)
        m = cd.QuadricMirror.hyperboloid(a, c, z_min=c, z_max=c + u(0.01, 0.05))
        base = m.foci[0]
    elif kind == "one_sheet":
        a = u(0.02, 0.05)
        m = cd.QuadricMirror(-u(0.2, 3.0), 0.0, a * a, -u(0.0, 0.05), u(0.01, 0.05))
        base = np.array([0.0, 0.0, -u(0.1, 0.4)])
    elif kind == "paraboloid":
        up = int(rng.choice([1, -1]))
        m = cd.QuadricMirror.paraboloid(u(0.005, 0.03), z_min=min(0, 0.03 * up), z_max=max(0, 0.03 * up), opening=up)
        base = np.array([0.0, 0.0, -u(0.1, 0.4) * up])
    elif kind == "cylinder":
        m = cd.QuadricMirror.cylinder(u(0.02, 0.05), z_min=0.0, z_max=u(0.02, 0.1))
        base = np.array([0.0, 0.0, -u(0.05, 0.3)])
    else:
        m = cd.QuadricMirror.cone(u(0.3, 1.1), z_min=-0.05, z_max=-0.005)
        base = np.array([0.0, 0.0, u(0.1, 0.4)])
    off = rng.uniform(-0.01, 0.01, 3) * rng.choice([0.0, 1.0, 1e-6])
    if kind.endswith("inside"):
        off = off * 0.1
    pin = cd.PinholeCamera.from_fov(W, H, u(20.0, 120.0))
    cam = cd.CatadioptricCamera.looking_at_mirror(m, pin, base + off, target=(0, 0, 0.5 * (m.z_min + m.z_max)))
    return scaled(cam, 10.0 ** rng.choice([0, 0, -3, 3, -9, 9]))


def rig_pool(rng, n_random=12):
    rigs = {name: preset(name, width=W, height=H) for name in preset_names()}
    rigs.update(special_rigs())
    for i in range(n_random):
        rigs[f"random{i}"] = random_rig(rng)
    return rigs


def normal_pixels(cam):
    """Pixels (and mirror points) where the camera sees its own reflection (the reflected ray
    passes back through the camera), refined by least squares from the best grid pixel."""
    from scipy.optimize import least_squares

    grid = cam.pinhole.pixel_grid(2).reshape(-1, 2)
    rays = cam.backproject(grid)
    ok = rays.valid
    if not np.any(ok):
        return np.zeros((0, 2))
    back = cam.center - rays.origins[ok]
    back /= np.linalg.norm(back, axis=1, keepdims=True)
    err = np.linalg.norm(rays.directions[ok] - back, axis=1)
    out = []
    for k in np.argsort(err)[:1]:
        if err[k] > 0.2:
            continue

        def res(uv):
            r = cam.backproject(uv)
            if not r.valid:
                return np.array([1.0, 1.0, 1.0])
            b = cam.center - r.origins
            return r.directions - b / np.linalg.norm(b)

        sol = least_squares(res, grid[ok][k], xtol=1e-15, ftol=1e-15, gtol=1e-15, method="lm")
        if np.linalg.norm(sol.fun) < 1e-12 and cam.backproject(sol.x).valid:
            out.append(sol.x)
    return np.array(out).reshape(-1, 2)


def plane_pixels(cam, rng, n):
    """Pixels of mirror points in (or within 1e-12 to 1e-3 rad of) the plane of the camera and the
    axis: symmetric configurations, where solutions pair up."""
    m = cam.mirror
    az = np.arctan2(cam.center[1], cam.center[0]) + rng.choice([0.0, np.pi], n)
    az += rng.choice([0.0, 1.0], n) * 10.0 ** rng.uniform(-12, -3, n) * rng.choice([-1, 1], n)
    z = rng.uniform(m.z_min, m.z_max, n)
    rho = np.sqrt(np.maximum(m.radius_squared(z), 0.0))
    return cam.pixels_of_mirror_points(np.stack([rho * np.cos(az), rho * np.sin(az), z], -1))


def random_pixels(cam, rng, n, near=None):
    """Random pixels; a third near the camera's normal rays (some exactly on them), a sixth in
    the plane of the camera and the axis."""
    uv = np.stack([rng.uniform(-0.5, W - 0.5, n), rng.uniform(-0.5, H - 0.5, n)], -1)
    if near is not None and len(near):
        k = n // 3
        ang = rng.uniform(0, 2 * np.pi, k)
        rad = 10.0 ** rng.uniform(-12, -2, k) * (rng.uniform(size=k) > 0.1)  # some exactly on the normal ray
        uv[:k] = near[rng.integers(len(near), size=k)] + rad[:, None] * np.stack([np.cos(ang), np.sin(ang)], -1)
    k = n // 6
    uv[n - k:] = plane_pixels(cam, rng, k)
    return uv


# ----------------------------------------------------------------------------- valid-input checks
def ill_conditioned(cam, p, rel=1e-7, px=1e-3, w=1):
    """True when moving the point ``p`` by ``rel`` times the mirror's scale moves one of its images by
    more than ``px`` pixels or changes their number (near a caustic, or near a ring of solutions: a
    target on a sphere's axis through the camera, or a target near the axis of a camera within 1e-8
    of it): its pixels are then defined only to that precision, and which of them rounding finds
    is not a wrong answer."""
    rng = np.random.default_rng(0)
    e = rng.normal(size=(4, 3))
    e *= rel * (cam.mirror.scale if w else np.linalg.norm(p)) / np.linalg.norm(e, axis=1, keepdims=True)
    pr = (cam.project if w else cam.vanishing_points)(np.concatenate([p[None], p + e]))
    found = np.isfinite(pr.uv[..., 0])  # every reflection point, visible or not
    ref = pr.uv[0][found[0]]
    for j in range(1, 5):
        uv = pr.uv[j][found[j]]
        if len(uv) != len(ref):
            return True
        if len(ref) and np.max(np.min(np.linalg.norm(ref[:, None] - uv[None], axis=-1), axis=1)) > px:
            return True
    return False


def _find(uv_all, valid, uv0, tol):
    d = np.where(valid, np.linalg.norm(uv_all - uv0[:, None, :], axis=-1), np.inf).min(axis=-1)
    return d <= tol, d


def _alone_equals_batch(fn, X, res_uv, res_valid, rows):
    for i in rows:
        one = fn(X[i:i + 1])
        check(np.array_equal(one.valid[0], res_valid[i]), f"row {i}: valid {one.valid[0]} alone, "
                                                           f"{res_valid[i]} in the batch")
        d = np.nanmax(np.abs(one.uv[0] - res_uv[i]), initial=0.0)
        check(d <= 1e-12, f"row {i}: pixels differ by {d:.3g} alone and in the batch")
    # the memory layout does not matter either: the same bits from a Fortran-ordered copy (issue 39)
    f = fn(np.asfortranarray(X))
    check(np.array_equal(f.valid, res_valid) and np.array_equal(f.uv, res_uv, equal_nan=True),
          f"a Fortran-ordered batch gives other pixels (by {np.nanmax(np.abs(f.uv - res_uv), initial=0.0):.3g})")


def project_round_trip(cam, rng, near):
    uv = random_pixels(cam, rng, 24, near)
    rays = cam.backproject(uv)
    ok = rays.valid
    if not np.any(ok):
        return
    L = cam.mirror.scale
    lam = L * 10.0 ** rng.uniform(-2, 5, ok.sum())
    P = rays.origins[ok] + lam[:, None] * rays.directions[ok]
    # points too close to the camera centre are a different question (the camera sees them directly)
    far = np.linalg.norm(P - cam.center, axis=1) > 1e-6 * L
    P, uv0 = P[far], uv[ok][far]
    pr = cam.project(P)
    found, d = _find(pr.uv, pr.valid, uv0, 1e-6)
    bad = np.nonzero(~found)[0]
    check(not len(bad), f"{len(bad)} of {len(P)} points lost; e.g. pixel {uv0[bad[:1]].tolist()} "
                        f"point {P[bad[:1]].tolist()} nearest valid at {d[bad[:1]]} px")
    _alone_equals_batch(cam.project, P, pr.uv, pr.valid, rng.integers(len(P), size=3))


def vanishing_round_trip(cam, rng, near):
    uv = random_pixels(cam, rng, 24, near)
    rays = cam.backproject(uv)
    ok = rays.valid
    if not np.any(ok):
        return
    S = rays.directions[ok] * 10.0 ** rng.uniform(-3, 3, (ok.sum(), 1))
    vp = cam.vanishing_points(S)
    found, d = _find(vp.uv, vp.valid, uv[ok], 1e-6)
    bad = np.nonzero(~found)[0]
    check(not len(bad), f"{len(bad)} of {len(S)} directions lost; e.g. pixel {uv[ok][bad[:1]].tolist()} "
                        f"direction {S[bad[:1]].tolist()} nearest valid at {d[bad[:1]]} px")
    _alone_equals_batch(cam.vanishing_points, S, vp.uv, vp.valid, rng.integers(len(S), size=3))
    back = cam.directions_from_vanishing_points(vp.uv[found, 0])
    s = S[found] / np.linalg.norm(S[found], axis=1, keepdims=True)
    check(np.all(np.linalg.norm(back - s, axis=1) < 1e-6), "directions_from_vanishing_points misses the direction")


def units(cam, rng, near):
    k = 10.0 ** rng.choice([-12, -9, -6, -3, 3, 6, 9, 12])
    ck = scaled(cam, k)
    uv = random_pixels(cam, rng, 24, near)
    r1, r2 = cam.backproject(uv), ck.backproject(uv)
    check(np.array_equal(r1.valid, r2.valid), f"backproject valid differs at scale {k:g}: "
                                              f"{int(np.sum(r1.valid != r2.valid))} of {len(uv)} pixels")
    both = r1.valid & r2.valid
    dd = np.max(np.linalg.norm(r1.directions[both] - r2.directions[both], axis=1), initial=0.0)
    check(dd < 1e-9, f"backproject directions differ by {dd:.3g} at scale {k:g}")
    do = np.max(np.linalg.norm(r1.origins[both] * k - r2.origins[both], axis=1) / (k * cam.mirror.scale), initial=0.0)
    check(do < 1e-9, f"backproject origins differ by {do:.3g} (relative) at scale {k:g}")
    if not np.any(both):
        return
    P = r1.origins[both] + cam.mirror.scale * 10.0 ** rng.uniform(-1, 3, (both.sum(), 1)) * r1.directions[both]
    p1, p2 = cam.project(P), ck.project(P * k)
    bad = np.nonzero(np.any(p1.valid != p2.valid, axis=1))[0]
    bad = [i for i in bad if not (ill_conditioned(cam, P[i]) or ill_conditioned(ck, P[i] * k))]
    check(not len(bad), f"project valid differs at scale {k:g} for point {P[bad[:1]].tolist()}: "
                        f"{p1.valid[bad[:1]].tolist()} and {p2.valid[bad[:1]].tolist()}")
    du = np.nanmax(np.abs(p1.uv - p2.uv), axis=(1, 2), initial=0.0)
    bad = [i for i in np.nonzero(du >= 1e-7)[0] if not (ill_conditioned(cam, P[i]) or ill_conditioned(ck, P[i] * k))]
    check(not len(bad), f"project pixels differ by {du.max():.3g} px at scale {k:g} for point "
                        f"{P[bad[:1]].tolist()}")
    S = r1.directions[both]
    v1, v2 = cam.vanishing_points(S), ck.vanishing_points(S)
    fine = lambda i: not (ill_conditioned(cam, S[i], w=0) or ill_conditioned(ck, S[i], w=0))  # noqa: E731
    bad = [i for i in np.nonzero(np.any(v1.valid != v2.valid, axis=1))[0] if fine(i)]
    check(not len(bad), f"vanishing_points valid differs at scale {k:g} for direction {S[bad[:1]].tolist()}")
    du = np.nanmax(np.abs(v1.uv - v2.uv), axis=(1, 2), initial=0.0)
    bad = [i for i in np.nonzero(du >= 1e-7)[0] if fine(i)]
    check(not len(bad), f"vanishing pixels differ by {du.max():.3g} px at scale {k:g} for direction {S[bad[:1]].tolist()}")


def magnitudes(cam, rng, near):
    uv = random_pixels(cam, rng, 12, near)
    rays = cam.backproject(uv)
    ok = rays.valid
    if not np.any(ok):
        return
    S = rays.directions[ok]
    k = 10.0 ** rng.uniform(-300, 300, (len(S), 1))
    v1, v2 = cam.vanishing_points(S), cam.vanishing_points(S * k)
    # a unit vector's last bit depends on the length it came from: ill-conditioned rows may move
    bad = [i for i in np.nonzero(np.any(v1.valid != v2.valid, axis=1))[0] if not ill_conditioned(cam, S[i], w=0)]
    check(not bad, f"vanishing_points valid changes with the length of the directions (lengths {k[:2, 0].tolist()})")
    du = np.nanmax(np.abs(v1.uv - v2.uv), axis=(1, 2), initial=0.0)
    bad = [i for i in np.nonzero(du >= 1e-9)[0] if not ill_conditioned(cam, S[i], w=0)]
    check(not bad, f"vanishing pixels change by {du.max():.3g} px with the length of the directions")
    # subnormal directions (|s| ~ 1e-320, a few bits each): the same vanishing points as the very
    # same vectors scaled exactly (by a power of two) to ordinary lengths (issue 39: 0.035 px off)
    sub = S * 10.0 ** rng.uniform(-322, -310, (len(S), 1))
    keep = np.all(np.isfinite(sub), axis=1) & np.any(sub != 0, axis=1)
    if np.any(keep):
        sub = sub[keep]
        e = np.frexp(np.max(np.abs(sub), axis=1))[1]
        v1, v2 = cam.vanishing_points(sub), cam.vanishing_points(np.ldexp(sub, -e[:, None]))
        fine = [i for i in range(len(sub)) if not ill_conditioned(cam, np.ldexp(sub[i], -e[i]), w=0)]
        du = np.nanmax(np.abs(v1.uv - v2.uv), axis=(1, 2), initial=0.0)[fine]
        check(np.array_equal(v1.valid[fine], v2.valid[fine]) and np.all(du < 1e-9),
              f"vanishing points of subnormal directions differ by {du.max(initial=0.0):.3g} px from those of the "
              f"same vectors scaled exactly")
    # far points: their images reach the vanishing points
    L = cam.mirror.scale
    lam = L * 10.0 ** rng.uniform(9, 300, len(S))
    P = rays.origins[ok] + lam[:, None] * S
    pr = cam.project(P)
    found, d = _find(pr.uv, pr.valid, uv[ok], 1e-3)
    check(np.all(found), f"far points (lambda up to {lam.max():.3g}) lost: {int(np.sum(~found))} of {len(P)}")
    huge = cam.backproject(uv * 10.0 ** rng.uniform(0, 300, (len(uv), 1)))
    check(np.all(np.isfinite(huge.directions[huge.valid])), "backproject of far pixels gives non-finite rays")


def lines(cam, rng, near):
    L = cam.mirror.scale
    q = rng.normal(size=(2, 3)) * L * 10.0 ** rng.uniform(0, 2)
    s = rng.normal(size=(2, 3)) * 10.0 ** rng.uniform(-200, 200)
    ims = cam.line_image(q, s, max_step_px=float(rng.choice([1.0, 4.0])))
    for im in ims:
        for p in im.pieces:
            check(np.all(np.isfinite(p.uv)), "line_image gives non-finite vertices")
            check(np.allclose(cam.pixels_of_mirror_points(p.mirror_points), p.uv, atol=1e-6),
                  "line_image vertices are not the pixels of their mirror points")
    a = rng.normal(size=(2, 3)) * L * 10.0 ** rng.uniform(0, 250)
    segs = cam.segment_image(a, a + rng.normal(size=(2, 3)) * np.abs(a).max(), max_step_px=4.0)
    for im in segs:
        for p in im.pieces:
            check(np.all(np.isfinite(p.uv)), "segment_image gives non-finite vertices")
    n = rng.normal(size=3)
    c1 = cam.vanishing_curve(n, max_step_px=4.0, n_start=90)
    c2 = cam.vanishing_curve(n * 10.0 ** rng.uniform(-300, 300), max_step_px=4.0, n_start=90)
    # the same curves: every vertex of one on the other (the ends are located to 1e-9 rad, so their
    # vertices can stack differently; pixels far off the image are exact only relative to their size)
    check(len(c1) == len(c2) and all(_same_polyline(a.uv, b.uv) for a, b in zip(c1, c2)),
          f"vanishing_curve changes with the length of the normal: pieces of {[len(c.uv) for c in c1]} and "
          f"{[len(c.uv) for c in c2]} vertices")


def _off_polyline(pts, poly):
    """Distance of each point to the polyline ``poly (M, 2)``."""
    if len(poly) == 1:
        return np.linalg.norm(pts - poly[0], axis=1)
    a, e = poly[:-1], np.diff(poly, axis=0)
    t = np.clip(np.einsum("pik,ik->pi", pts[:, None] - a[None], e) / np.maximum(np.sum(e * e, 1), 1e-300), 0, 1)
    return np.min(np.linalg.norm(pts[:, None] - (a[None] + t[..., None] * e[None]), axis=-1), axis=1)


def _same_polyline(a, b, tol=1e-4):
    return bool(np.all(_off_polyline(a, b) <= tol * (1 + np.abs(a).max(axis=1)))
                and np.all(_off_polyline(b, a) <= tol * (1 + np.abs(b).max(axis=1))))


def random_unified(rng):
    xi = float(rng.choice([0.0, rng.uniform(0, 1), 1.0, rng.uniform(1, 3)]))
    f = rng.uniform(50, 300)
    K = np.array([[f, rng.uniform(-1, 1), W / 2], [0, f * rng.choice([1, -1]) * rng.uniform(0.8, 1.2), H / 2],
                  [0, 0, 1.0]])
    from scipy.spatial.transform import Rotation

    R = Rotation.from_rotvec(rng.normal(size=3)).as_matrix()
    center = rng.normal(size=3) * 0.1 * rng.choice([0.0, 1.0])  # at the origin: points at any distance from it
    return cd_unified().UnifiedCamera(xi, K, R, center, np.eye(3), W, H)


def cd_unified():
    import catadioptric.unified as u

    return u


def unified(rng):
    uc = random_unified(rng)
    uv = np.stack([rng.uniform(-0.5, W - 0.5, 30), rng.uniform(-0.5, H - 0.5, 30)], -1)
    rays = uc.backproject(uv)
    ok = rays.valid
    if not np.any(ok):
        return
    # distances from the viewpoint: any float when it is the origin, else above the rounding of its coordinates
    k = 10.0 ** rng.uniform(-300 if not np.any(uc.center) else -3, 300, (ok.sum(), 1))
    pr = uc.project(uc.center + k * rays.directions[ok])
    d = np.linalg.norm(pr.uv - uv[ok], axis=-1)
    check(np.all(pr.valid) and np.all(d < 1e-6), f"unified project of points at distances {k[:2, 0].tolist()} "
                                                 f"misses the pixel by {np.nanmax(d, initial=np.inf):.3g}")
    vp = uc.vanishing_points(rays.directions[ok] * k)
    d = np.linalg.norm(vp.uv - uv[ok], axis=-1)
    check(np.all(vp.valid) and np.all(d < 1e-6), "unified vanishing points change with the length of the directions")
    q = uc.center + rng.normal(size=(3, 3)) * 10.0 ** rng.uniform(-100 if not np.any(uc.center) else -3, 100)
    s = rng.uniform(-1, 1, (3, 3)) * 10.0 ** rng.uniform(-300, 300)
    C = uc.line_image(q, s)
    C1 = uc.line_image(uc.center + (q - uc.center) / np.abs(q - uc.center).max(), s / np.abs(s).max())
    same = np.minimum(np.abs(C - C1).max(axis=(1, 2)), np.abs(C + C1).max(axis=(1, 2)))
    check(np.all(same < 1e-9), f"unified line_image changes with the magnitude of its input by {same.max():.3g}")
    sm = uc.sample_line_image(q, s, num=16)
    check(np.all(np.isfinite(sm.uv[sm.valid])), "unified sample_line_image gives non-finite valid pixels")


# ----------------------------------------------------------------------------- bad input
def bad_arrays(rng, shape):
    """Values an array argument must refuse, with a label each."""
    x = rng.normal(size=shape)
    return [
        ("complex", x + 1j * rng.normal(size=shape)),
        ("bool", x > 0),
        ("datetime", np.full(shape, np.datetime64("2020-01-01"))),
        ("strings", np.full(shape, "1.0")),
        ("nan", np.where(np.arange(x.size).reshape(shape) == rng.integers(x.size), np.nan, x)),
        ("inf", np.full(shape, np.inf)),
        ("object", np.array([None] * int(np.prod(shape)), dtype=object).reshape(shape)),
        ("wrong_shape", rng.normal(size=shape[:-1] + (shape[-1] + 1,))),
        ("dict", {"x": 1}),
    ]


def bad_numbers():
    return [0, -1, -1.5, np.nan, np.inf, -np.inf, "1", None, True, 1e-320]


def bad_counts():
    return [0, -3, 1.5, True, "8", None, np.nan, 10**12]


def bad_cases(rng, cam, uc):
    out = []
    P = rng.normal(size=(4, 3))
    for label, v in bad_arrays(rng, (4, 3)):
        out += [Case("bad_arrays", (lambda v=v: cam.project(v)), ("points",), f"project {label}"),
                Case("bad_arrays", (lambda v=v: cam.vanishing_points(v)), ("directions",), f"vanishing {label}"),
                Case("bad_arrays", (lambda v=v: uc.project(v)), ("points",), f"unified project {label}"),
                Case("bad_arrays", (lambda v=v: cam.line_image(v, P)), ("points",), f"line_image {label}"),
                Case("bad_arrays", (lambda v=v: cam.segment_image(P, v)), ("p1",), f"segment_image {label}")]
    for label, v in bad_arrays(rng, (4, 2)):
        out += [Case("bad_arrays", (lambda v=v: cam.backproject(v)), ("uv",), f"backproject {label}"),
                Case("bad_arrays", (lambda v=v: cam.directions_from_vanishing_points(v)), ("uv",),
                     f"directions_from_vanishing_points {label}")]
    out += [Case("bad_arrays", lambda: cam.vanishing_points(np.zeros((2, 3))), ("directions",), "zero direction"),
            Case("bad_arrays", lambda: cam.vanishing_curve([0.0, 0.0, 0.0]), ("normal",), "zero normal"),
            Case("bad_arrays", lambda: cam.segment_image(P, P[:2] + 1), ("p0", "p1"), "segment counts"),
            Case("bad_arrays", lambda: cam.segment_image(P, P), ("p0", "p1"), "segment equal ends"),
            Case("bad_arrays", lambda: cam.line_image(P, P[:3]), ("points", "directions"), "line counts"),
            Case("bad_arrays", lambda: uc.vanishing_points(np.zeros(3)), ("directions",), "unified zero direction")]
    n = np.array([0.0, 0.0, 1.0])
    for v in bad_numbers():
        out += [Case("bad_options", (lambda v=v: cam.vanishing_curve(n, max_step_px=v)), ("max_step_px",),
                     f"vanishing_curve max_step_px={v!r}"),
                Case("bad_options", (lambda v=v: cam.line_image(P[:1], P[1:2], max_step_px=v)), ("max_step_px",),
                     f"line_image max_step_px={v!r}")]
    for v in bad_counts():
        out += [Case("bad_options", (lambda v=v: cam.vanishing_curve(n, n_start=v)), ("n_start",),
                     f"vanishing_curve n_start={v!r}"),
                Case("bad_options", (lambda v=v: cam.vanishing_curve(n, max_rounds=v if v != 0 else -1)),
                     ("max_rounds",), f"vanishing_curve max_rounds={v if v != 0 else -1!r}"),
                Case("bad_options", (lambda v=v: cam.line_image(P[:1], P[1:2], n_start=v)), ("n_start",),
                     f"line_image n_start={v!r}"),
                Case("bad_options", (lambda v=v: cam.line_image(P[:1], P[1:2], seed_step=v)), ("seed_step",),
                     f"line_image seed_step={v!r}"),
                Case("bad_options", (lambda v=v: uc.sample_line_image(P, P, num=v)), ("num",),
                     f"sample_line_image num={v!r}")]
    # pixels that do not span a line's image: copies of one pixel (issue 39: a confident line, rms 1e-14)
    from catadioptric.linefit import fit_line, fit_parallel_lines

    nc = preset("hyperboloid_9pct", width=W, height=H)
    one = np.tile(rng.uniform([8, 8], [W - 8, H - 8]), (int(rng.integers(5, 40)), 1))
    out += [Case("bad_arrays", lambda: fit_line(nc, one), ("uv",), "fit_line copies of one pixel"),
            Case("bad_arrays", lambda: fit_line(nc, np.concatenate([one, one[:4] + [1.0, 0.0]])), ("uv",),
                 "fit_line two distinct pixels"),
            Case("bad_arrays", lambda: fit_parallel_lines(nc, [one, one + 3.0]), ("uv_sets",),
                 "fit_parallel_lines copies of one pixel")]
    out += [Case("bad_options", lambda: cam.vanishing_points(P, which="-s"), ("which",), "which"),
            Case("bad_options", lambda: cam.line_image(P[:1], P[1:2], lam_range=[[1.0, 0.0]]), ("lam_range",),
                 "lam_range reversed")]
    return out


def _tiny_focal(rng, fov=None):
    """A camera matrix with tiny focal lengths (issue 39: fx = fy = 1e-5 refused as singular) is
    accepted and inverted: its pixel rays project back onto the pixels."""
    if fov is None:
        f = 10.0 ** rng.uniform(-8, -3)
        pin = cd.PinholeCamera(np.array([[f, 0, 31.5], [0, f * rng.uniform(0.5, 2), 23.5], [0, 0, 1]]), W, H)
    else:
        pin = cd.PinholeCamera.from_fov(W, H, fov)
    uv = rng.uniform([0, 0], [W, H], (8, 2))
    back = pin.project(pin.pixel_rays(uv))
    d = np.max(np.abs(back - uv))
    check(d < 1e-9, f"K {pin.K.tolist()}: pixel rays project back {d:.3g} px off")


def constructor_cases(rng):
    K = np.array([[100.0, 0, 31.5], [0, 100.0, 23.5], [0, 0, 1]])
    m = cd.QuadricMirror.sphere(0.05, z_min=0.0, z_max=0.05)
    pin = cd.PinholeCamera(K, W, H)
    Q = cd.QuadricMirror
    out = [
        Case("constructors", lambda: cd.PinholeCamera(K, True, 48), ("width",), "width=True"),
        Case("constructors", lambda: cd.PinholeCamera(K, 64, 48.0), ("height",), "height=48.0"),
        Case("constructors", lambda: cd.PinholeCamera(K * [[-1], [1], [1]], 64, 48), ("K",), "K negative fx"),
        Case("constructors", lambda: cd.PinholeCamera(K * [[1], [-1], [1]], 64, 48), ("K",), "K negative fy"),
        Case("constructors", lambda: cd.PinholeCamera(K + 1j, 64, 48), ("K",), "K complex"),
        Case("constructors", lambda: cd.PinholeCamera.from_fov(0, 48, 40.0), ("width",), "from_fov width=0"),
        Case("constructors", lambda: cd.PinholeCamera.from_fov("64", 48, 40.0), ("width",), "from_fov width='64'"),
        Case("constructors", lambda: cd.PinholeCamera.from_fov(64, -48, 40.0), ("height",), "from_fov height<0"),
        Case("constructors", lambda: cd.PinholeCamera.from_fov(64.5, 48, 40.0), ("width",), "from_fov width=64.5"),
        Case("constructors", lambda: cd.PinholeCamera.from_fov(64, 48, "wide"), ("fov_x_deg",), "from_fov fov"),
        Case("constructors", lambda: cd.PinholeCamera.from_fov(64, 48, 1e-320), ("fov_x_deg",), "from_fov fov=1e-320"),
        Case("constructors", lambda: cd.PinholeCamera(np.diag([1e-310, 1e-310, 1.0]), 64, 48), ("K",),
             "K subnormal focal lengths"),
        Case("constructors", lambda: _tiny_focal(rng), (), "K fx = fy ~ 1e-5 (well conditioned relative to its columns)"),
        Case("constructors", lambda: _tiny_focal(rng, fov=180.0 - 10.0 ** rng.uniform(-13, -2)), (),
             "from_fov near 180 degrees"),
        Case("constructors", lambda: Q.paraboloid(0.01, 0.0, 0.02, opening=True), ("opening",), "opening=True"),
        Case("constructors", lambda: Q.paraboloid(0.01, 0.0, 0.02, opening=1.0 + 1e-9), ("opening",), "opening~1"),
        Case("constructors", lambda: Q.cylinder(1e-200, -1.0, 1.0), ("radius",), "cylinder radius=1e-200"),
        Case("constructors", lambda: Q.sphere(1e-200, -1e-200, 1e-200), ("radius",), "sphere radius=1e-200"),
        Case("constructors", lambda: Q(1e300, 0.0, 1.0, -1e-160, 1e-160), ("A",), "A=1e300"),
        Case("constructors", lambda: Q(1.0, 1e300, 1.0, -1.0, 1.0), ("A", "B", "C"), "B=1e300"),
        Case("constructors", lambda: Q.sphere(1e200, -1.0, 1.0), ("radius",), "sphere radius=1e200"),
        Case("constructors", lambda: Q.sphere(1.0, 1.0, 2.0), ("z_min", "z_max"), "patch touching at one z"),
        Case("constructors", lambda: Q.sphere(1.0, -3.0, -1.0), ("z_min", "z_max"), "patch touching at the bottom"),
        Case("constructors", lambda: Q(1.0 + 0j, 0.0, 1.0, -1.0, 0.0), ("A",), "A complex"),
        Case("constructors", lambda: Q(True, 0.0, 1.0, -1.0, 0.0), ("A",), "A=True"),
        Case("constructors", lambda: cd.CatadioptricCamera(m, pin, [0.0, 0.0, np.nan]), ("center",), "center nan"),
        Case("constructors", lambda: cd.CatadioptricCamera(m, pin, [0.0, 0.0, 0.3], np.eye(3) * 2),
             ("R_cam_from_mirror",), "R not a rotation"),
        Case("constructors", lambda: cd.CatadioptricCamera(m, pin, [0.0, 0.0, 0.3 + 0j]), ("center",), "center complex"),
        Case("constructors", lambda: cd.CatadioptricCamera.looking_at_mirror(m, pin, [0, 0, 0.3], up=[np.nan, 0, 0]),
             ("up",), "up=nan"),
        Case("constructors", lambda: cd.CatadioptricCamera.looking_at_mirror(m, pin, [0, 0, 0.3], up=[0, 0, 0]),
             ("up",), "up=0"),
        Case("constructors", lambda: cd.CatadioptricCamera.looking_at_mirror(m, pin, [0, 0, 0.3], target=[0, 0, 0.3]),
             ("target",), "target=center"),
        Case("constructors", lambda: cd.CatadioptricCamera.looking_at_mirror(m, pin, [0, 0, 0.3], target=[0, 0, np.inf]),
             ("target",), "target=inf"),
        Case("constructors", lambda: cd.CatadioptricCamera.looking_at_mirror("sphere", pin, [0, 0, 0.3]),
             ("mirror",), "mirror=str"),
        Case("constructors", lambda: cd.RigPose(np.eye(3), [0.0, np.inf, 0.0]), ("t",), "RigPose t=inf"),
    ]
    cam = cd.CatadioptricCamera.looking_at_mirror(m, pin, [0.0, 0.0, 0.3])
    d = cam.to_dict()
    for key in ("mirror", "pinhole", "center", "R_cam_from_mirror"):
        dd = dict(d)
        del dd[key]
        out.append(Case("constructors", (lambda dd=dd: cd.CatadioptricCamera.from_dict(dd)), ("d", key),
                        f"from_dict without {key}"))
    dd = dict(d, pinhole={"K": d["pinhole"]["K"]})
    out.append(Case("constructors", lambda: cd.CatadioptricCamera.from_dict(dd), ("d", "pinhole", "width"),
                    "from_dict pinhole without width"))
    out.append(Case("constructors", lambda: cd.CatadioptricCamera.from_dict([1, 2]), ("d",), "from_dict list"))
    U = cd_unified().UnifiedCamera
    out += [Case("constructors", lambda: U(np.nan, K), ("xi",), "unified xi nan"),
            Case("constructors", lambda: U(0.5, K, width=True, height=48), ("width",), "unified width=True"),
            Case("constructors", lambda: U(0.5 + 1j, K), ("xi",), "unified xi complex"),
            Case("constructors", lambda: U(0.5, K, sphere_z_range=(0.5, 0.5)), ("sphere_z_range",), "z range")]
    return out


# ----------------------------------------------------------------------------- running
def cases(seed: int, n_valid: int):
    """The fuzz cases of one seed: ``n_valid`` valid-input cases per family and every bad-input case."""
    rng = np.random.default_rng(seed)
    rigs = rig_pool(rng)
    names = sorted(rigs)
    near = {}
    out = []
    fams = [("project_round_trip", project_round_trip), ("vanishing_round_trip", vanishing_round_trip),
            ("units", units), ("magnitudes", magnitudes)]
    for fam, fn in fams:
        for i in range(n_valid):
            name = names[i % len(names)]
            cam = rigs[name]
            if name not in near:
                near[name] = normal_pixels(cam)
            r = np.random.default_rng([seed, len(out)])
            out.append(Case(fam, (lambda fn=fn, cam=cam, r=r, nr=near[name]: fn(cam, r, nr)), (), name))
    for i in range(max(1, n_valid // 4)):
        name = names[i % len(names)]
        r = np.random.default_rng([seed, len(out)])
        out.append(Case("lines", (lambda cam=rigs[name], r=r: lines(cam, r, None)), (), name))
    for i in range(n_valid):
        r = np.random.default_rng([seed, len(out)])
        out.append(Case("unified", (lambda r=r: unified(r)), (), "random"))
    uc = random_unified(rng)
    out += bad_cases(rng, rigs[names[int(rng.integers(len(names)))]], uc)
    out += constructor_cases(rng)
    return out


_ARG = r"[A-Za-z_][\w.]*(?:\[[^\]]*\])*"
_NAMED = re.compile(rf"^({_ARG}(?:, {_ARG})*): ")


def named(msg: str) -> list[str]:
    """The argument names a ``CatadioptricError`` message starts with."""
    m = _NAMED.match(msg)
    return [re.sub(r"\[.*\]$", "", a) for a in m.group(1).split(", ")] if m else []


def run_case(case: Case, timeout: float) -> tuple[str, str]:
    def alarm(*_):
        raise Hang()

    old = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            case.call()
        outcome = ("accepted", "no error") if case.names else ("ok", "")
    except Hang:
        outcome = ("hang", f"over {timeout} s")
    except cd.CatadioptricError as e:
        msg = str(e)
        if not case.names:
            outcome = ("refused", msg)
        elif not set(named(msg)) & set(case.names):
            outcome = ("unclear", f"names {named(msg)}, expected one of {list(case.names)}: {msg}")
        else:
            outcome = ("ok", "")
    except Wrong as e:
        outcome = ("wrong", str(e))
    except Exception as e:  # noqa: BLE001 - the point: anything else is a traceback for the user
        tb = traceback.extract_tb(e.__traceback__)[-1]
        outcome = ("traceback", f"{type(e).__name__}: {str(e)[:200]} ({tb.filename.split('/')[-1]}:{tb.lineno})")
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    return outcome


def run(seed: int = 0, n_valid: int = 30, timeout: float = 10.0, verbose: bool = False):
    """Run the cases of one seed; returns ``[(case, outcome, detail, seconds)]``."""
    out = []
    for case in cases(seed, n_valid):
        t = time.perf_counter()
        outcome, detail = run_case(case, timeout)
        out.append((case, outcome, detail, time.perf_counter() - t))
        if verbose and outcome != "ok":
            print(f"  {case.family:22s} {case.label:36s} {outcome:9s} {detail[:300]}", flush=True)
    return out


def summary(results) -> str:
    by = defaultdict(Counter)
    secs = Counter()
    for case, outcome, _, dt in results:
        by[case.family][outcome] += 1
        secs[case.family] += dt
    lines_ = [f"{'family':22s} {'cases':>5s} " + " ".join(f"{o:>9s}" for o in OUTCOMES) + "  seconds"]
    tot = Counter()
    for fam in by:
        n = sum(by[fam].values())
        tot.update(by[fam])
        lines_.append(f"{fam:22s} {n:5d} " + " ".join(f"{by[fam][o]:9d}" for o in OUTCOMES) + f"  {secs[fam]:7.1f}")
    lines_.append(f"{'total':22s} {sum(tot.values()):5d} " + " ".join(f"{tot[o]:9d}" for o in OUTCOMES)
                  + f"  {sum(secs.values()):7.1f}")
    return "\n".join(lines_)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, nargs="+", default=[0])
    ap.add_argument("--cases", type=int, default=30, help="valid-input cases per family and seed")
    ap.add_argument("--timeout", type=float, default=10.0)
    ap.add_argument("-v", "--verbose", action="store_true")
    a = ap.parse_args(argv)
    results = []
    for s in a.seed:
        results += run(s, a.cases, a.timeout, a.verbose)
    print(summary(results))
    return int(any(o != "ok" for _, o, _, _ in results))


if __name__ == "__main__":
    sys.exit(main())
