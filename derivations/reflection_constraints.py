"""Derive and check, with sympy, the polynomial systems of catadioptric/solvers/.

    .venv/bin/python derivations/reflection_constraints.py

Prints the genuine degree of each solver's polynomial (the corrected Table 1 of the
paper) and asserts every identity the solvers rely on; tests/test_derivations.py runs
it in CI. Notation as in docs/solvers.md: mirror x^2 + y^2 + A z^2 + B z - C = 0,
camera c = (0, c2, c3), homogeneous target (p1, p2, p3, w).
"""
from __future__ import annotations

import random

import sympy as sp

x, y, z, A, B, C, c2, c3, p1, p2, p3, w = sp.symbols("x y z A B C c2 c3 p1 p2 p3 w")


def on_mirror(e):
    """Eliminate x^2 with the mirror equation."""
    e = sp.Poly(sp.expand(e), x)
    out = 0
    for (k,), co in e.terms():
        out += co * (C - A * z**2 - B * z - y**2) ** (k // 2) * x ** (k % 2)
    return sp.expand(out)


def constraints():
    r = sp.Matrix([x, y, z])
    c = sp.Matrix([0, c2, c3])
    n = sp.Matrix([x, y, A * z + B / 2])
    kz = z - A * z - B / 2  # the normal line meets the axis at (0, 0, kz)
    M = sp.Matrix([[x, 0, 0, p1], [y, c2, 0, p2], [z, c3, kz, p3], [1, 1, 1, w]])
    cop = sp.expand(2 * M.det())
    E, F = sp.expand(cop.coeff(x, 1)), sp.expand(cop.coeff(x, 0))
    d = sp.expand(n.dot(n)) * (r - c) - 2 * n * sp.expand(n.dot(r - c))
    v = sp.Matrix([p1, p2, p3]) - w * r
    G = on_mirror(d[1] * v[2] - d[2] * v[1])
    return E, F, G, d


def check_closed_forms(E, F, G, d):
    # the forms used in catadioptric/solvers/constraints.py
    E_code = 2 * z * (1 - A) * (c2 * w - p2) + B * (p2 - c2 * w) + 2 * (c3 * p2 - c2 * p3)
    F_code = -p1 * (y * (2 * (A - 1) * z + B + 2 * c3) - c2 * (2 * A * z + B))
    assert sp.expand(E - E_code) == 0, "E"
    assert sp.expand(F - F_code) == 0, "F"
    assert sp.degree(G, x) <= 0, "G is x-free on the mirror"
    # |n|^2 depends on z only and <n, r - c> is linear in y, z on the mirror (math notes 2)
    n2 = on_mirror(x**2 + y**2 + (A * z + B / 2) ** 2)
    assert sp.degree(n2, y) == 0
    g = on_mirror(x * x + y * (y - c2) + (A * z + B / 2) * (z - c3))
    assert sp.Poly(g, y, z).total_degree() <= 2 and sp.degree(g, y) == 1
    # the paper's kappa_1 is -E at w = 0 with p = s, and kappa_9 = s3 d2 - s2 d3 (math notes 2)
    s1, s2, s3 = sp.symbols("s1 s2 s3")
    k1 = 2 * s3 * c2 - 2 * s2 * c3 - B * s2 + 2 * s2 * (1 - A) * z
    assert sp.expand(E.subs({w: 0, p2: s2, p3: s3}) + k1) == 0, "kappa_1"
    k9 = on_mirror(s3 * d[1] - s2 * d[2])
    P9 = sp.Poly(k9, y, z)
    assert set(P9.monoms()) <= {(2, 0), (1, 2), (1, 1), (1, 0), (0, 3), (0, 2), (0, 1), (0, 0)}, "kappa_9 monomials"
    assert sp.expand(P9.coeff_monomial(y**2) - 2 * c2 * s3) == 0, "a1 = 2 c2 s3"
    return True


def rand(rng):
    return sp.Rational(rng.randint(-40, 40), rng.randint(1, 9))


def degrees(E, F, G, seed=1):
    """Genuine degrees of the eliminated polynomial in z, per configuration."""
    rng = random.Random(seed)
    q = y**2 + A * z**2 + B * z - C
    H = sp.expand(F**2 + q * E**2)
    rows = []

    def general(sub, wv):
        s = {**sub, w: wv}
        R = sp.Poly(sp.resultant(G.subs(s), H.subs(s), y), z)
        Eq = sp.Poly(E.subs(s), z)
        quotient, rem = sp.div(R, Eq**2)
        assert rem.is_zero, "E^2 divides Res_y(G, H)"
        return int(quotient.degree()), int(R.degree())

    def axial(sub, wv):
        s = {**sub, w: wv, c2: 0, p1: 0}
        R = sp.Poly(sp.resultant(G.subs(s), q.subs(s), y), z)
        fl = sp.factor_list(R.as_expr())[1]
        spurious = sum(m * sp.Poly(f, z).degree() for f, m in fl if sp.Poly(f, z).degree() == 1
                       and sp.simplify(f.subs(z, 0)) == 0 and s[B] == 0 and s[C] == 0)
        return int(R.degree() - spurious), int(R.degree())

    P = lambda: {p1: rand(rng), p2: rand(rng), p3: rand(rng)}
    for wv, what in ((1, "point"), (0, "direction")):
        rows.append(("general (off-axis camera)", what, *general({A: rand(rng), B: rand(rng), C: rand(rng), c2: rand(rng),
                                                                 c3: rand(rng), **P()}, wv)))
        rows.append(("sphere, off-axis camera", what, *general({A: 1, B: 0, C: rand(rng) ** 2 + 1, c2: rand(rng),
                                                               c3: rand(rng), **P()}, wv)))
        rows.append(("axial camera", what, *axial({A: rand(rng), B: rand(rng), C: rand(rng), c3: rand(rng), **P()}, wv)))
        rows.append(("sphere, axial", what, *axial({A: 1, B: 0, C: rand(rng), c3: rand(rng), **P()}, wv)))
        rows.append(("paraboloid, axial", what, *axial({A: 0, B: rand(rng), C: rand(rng), c3: rand(rng), **P()}, wv)))
        rows.append(("cone, axial", what, *axial({A: -rand(rng) ** 2 - 1, B: 0, C: 0, c3: rand(rng), **P()}, wv)))
        rows.append(("cylinder, axial", what, *axial({A: 0, B: 0, C: rand(rng) ** 2 + 1, c3: rand(rng), **P()}, wv)))
    return rows


def main():
    E, F, G, d = constraints()
    check_closed_forms(E, F, G, d)
    rows = degrees(E, F, G)
    expected = {("general (off-axis camera)", "point"): 8, ("general (off-axis camera)", "direction"): 8,
                ("sphere, off-axis camera", "point"): 4, ("sphere, off-axis camera", "direction"): 4,
                ("axial camera", "point"): 6, ("axial camera", "direction"): 6,
                ("sphere, axial", "point"): 4, ("sphere, axial", "direction"): 4,
                ("paraboloid, axial", "point"): 5, ("paraboloid, axial", "direction"): 4,
                ("cone, axial", "point"): 2, ("cone, axial", "direction"): 2,
                ("cylinder, axial", "point"): 2, ("cylinder, axial", "direction"): 2}
    print(f"{'configuration':28s} {'target':10s} genuine  (before removing spurious factors)")
    for name, what, genuine, raw in rows:
        print(f"{name:28s} {what:10s} {genuine:7d}  ({raw})")
        assert genuine == expected[(name, what)], (name, what, genuine)
    print("all identities hold")
    return rows


if __name__ == "__main__":
    main()
