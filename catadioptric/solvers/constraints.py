"""The polynomial reflection constraints, built with batched bivariate algebra.

Everything here is in the solver frame: lengths divided by the mirror scale,
the camera at ``c = (0, c2, c3)``, the height ``z = zt[0] + zt[1] t`` with
``t in [-1, 1]`` spanning the patch. A target is a homogeneous 4-vector
``h = (p1, p2, p3, w)``: the point ``p`` (w = 1) or the direction ``p`` (w = 0).
See docs/solvers.md for the derivation; derivations/reflection_constraints.py
re-derives and checks every formula with sympy.
"""
from __future__ import annotations

import numpy as np

from . import bivariate as bv
from .polynomial import polyadd, polymul, polysub


def mirror_terms(A, B, C, zt):
    """Bivariate ``A z + B/2``, ``rho^2 = C - A z^2 - B z`` and ``|n|^2`` on the mirror."""
    Z = bv.from_t(np.asarray(zt, float))
    Az_B2 = bv.add(bv.scale(Z, A), bv.const(0.5 * B))
    rho2 = bv.add(bv.const(C), bv.scale(bv.mul(Z, Z), -A), bv.scale(Z, -B))
    n2 = bv.add(rho2, bv.mul(Az_B2, Az_B2))
    return Z, Az_B2, rho2, n2


def reflected_yz(A, B, C, c2, c3, zt):
    """The components d2, d3 of ``d = |n|^2 (r - c) - 2 n <n, r - c>`` on the mirror (x-free)."""
    Z, Az_B2, rho2, n2 = mirror_terms(A, B, C, zt)
    Y = bv.Y
    z_c3 = bv.add(Z, bv.const(-c3))
    g = bv.add(rho2, bv.scale(Y, -c2), bv.mul(Az_B2, z_c3))  # <n, r - c> with x^2 eliminated
    d2 = bv.add(bv.mul(n2, bv.add(Y, bv.const(-c2))), bv.scale(bv.mul(Y, g), -2.0))
    d3 = bv.add(bv.mul(n2, z_c3), bv.scale(bv.mul(Az_B2, g), -2.0))
    return d2, d3


def reflection_G(A, B, C, c2, c3, zt, h):
    """``G = d2 (p3 - w z) - d3 (p2 - w y)``: the x-free component of ``d x (p - w r)``; (N, 3, nt)."""
    d2, d3 = reflected_yz(A, B, C, c2, c3, zt)
    Z = bv.from_t(np.asarray(zt, float))
    p2, p3, w = h[:, 1], h[:, 2], h[:, 3]
    v3 = bv.add(bv.const(p3), bv.mul(bv.const(-w), Z))
    v2 = bv.add(bv.const(p2), bv.mul(bv.const(-w), bv.Y))
    return bv.add(bv.mul(d2, v3), bv.scale(bv.mul(d3, v2), -1.0))


def coplanarity(A, B, C, c2, c3, zt, h):
    """``E(z) x + F1(z) y + F0(z) = 0``: r, c, the target and the normal's foot on the axis are coplanar.

    ``E = 2 z (1 - A)(c2 w - p2) + B (p2 - c2 w) + 2 (c3 p2 - c2 p3)`` and
    ``F = -p1 [y (2 (A - 1) z + B + 2 c3) - c2 (2 A z + B)]`` (a common factor 1/2 dropped).
    """
    p1, p2, p3, w = h[:, 0], h[:, 1], h[:, 2], h[:, 3]
    k = c2 * w - p2
    E = np.stack([2 * (1 - A) * k * zt[0] - B * k + 2 * (c3 * p2 - c2 * p3), 2 * (1 - A) * k * zt[1]], axis=-1)
    F1 = -p1[:, None] * np.array([2 * (A - 1) * zt[0] + B + 2 * c3, 2 * (A - 1) * zt[1]])
    F0 = p1[:, None] * c2 * np.array([2 * A * zt[0] + B, 2 * A * zt[1]])
    return E, F1, F0


def circle_f(A, B, C, zt):
    """``f(t) = A z^2 + B z - C``, so that the mirror reads ``x^2 + y^2 + f = 0``."""
    return np.array([A * zt[0] ** 2 + B * zt[0] - C, 2 * A * zt[0] * zt[1] + B * zt[1], A * zt[1] ** 2])


def resultant_quadratics(a, b, c, d, e, f):
    """``Res_y(a y^2 + b y + c, d y^2 + e y + f) = (af - cd)^2 - (ae - bd)(bf - ce)``."""
    afcd = polysub(polymul(a, f), polymul(c, d))
    aebd = polysub(polymul(a, e), polymul(b, d))
    bfce = polysub(polymul(b, f), polymul(c, e))
    return polysub(polymul(afcd, afcd), polymul(aebd, bfce))


def resultant_quadratic_linear(a, b, c, f1, f0):
    """``Res_y(a y^2 + b y + c, f1 y + f0) = a f0^2 - b f0 f1 + c f1^2``."""
    return polyadd(polysub(polymul(a, polymul(f0, f0)), polymul(b, polymul(f0, f1))), polymul(c, polymul(f1, f1)))


def general_resultant(A, B, C, c2, c3, zt, h):
    """``Res_y(G, H)`` with ``H = F^2 + (y^2 + A z^2 + B z - C) E^2``: degree 10 in t, divisible by ``E^2``."""
    G = reflection_G(A, B, C, c2, c3, zt, h)
    E, F1, F0 = coplanarity(A, B, C, c2, c3, zt, h)
    Fb = bv.add(bv.mul(bv.from_t(F1), bv.Y), bv.from_t(F0))
    q = bv.add(bv.mul(bv.Y, bv.Y), bv.from_t(circle_f(A, B, C, zt)))
    H = bv.add(bv.mul(Fb, Fb), bv.mul(q, bv.from_t(polymul(E, E))))
    co = [bv.y_coefficient(G, k, 5) for k in (2, 1, 0)] + [bv.y_coefficient(H, k, 5) for k in (2, 1, 0)]
    return resultant_quadratics(*co), E


def plane_resultant(A, B, C, c2, c3, zt, h):
    """``Res_y(G, y^2 + A z^2 + B z - C)``: the reflection points in the plane x = 0 (which holds
    the camera at ``(0, c2, c3)`` and the axis) of targets in that plane, ``(a f - c)^2 + b^2 f``
    with ``G = a y^2 + b y + c`` and ``y^2 = -f`` on the mirror."""
    G = reflection_G(A, B, C, c2, c3, zt, h)
    a, b, c = (bv.y_coefficient(G, k, 5) for k in (2, 1, 0))
    f = np.broadcast_to(circle_f(A, B, C, zt), a.shape[:-1] + (3,))
    afc = polysub(polymul(a, f), c)
    return polyadd(polymul(afc, afc), polymul(polymul(b, b), f))


def axial_resultant(A, B, C, c3, zt, h):
    """:func:`plane_resultant` for a camera on the axis (every target is rotated into x = 0): degree 6 in t."""
    return plane_resultant(A, B, C, 0.0, c3, zt, h)
