"""Derive and check the unified-model formulas of catadioptric/unified/ with sympy.

Run: ``.venv/bin/python derivations/unified_central.py`` (prints each identity, exits 1 on failure).

1. A conic of revolution seen from a focus: in a frame with the viewpoint (focus F2) at the
   origin and the other focus F1 at ``d e3`` (d = 2 f), a point ``r = R s`` (s unit, R signed)
   lies on the ellipsoid / two-sheet hyperboloid iff ``1/R = (mu - gamma e s_z) / l`` with
   mu = +-1 (gamma = +1 ellipsoid, -1 hyperboloid; e = f / alpha, l = beta^2 / alpha).
2. The pinhole at F1 then sees ``r - F1 = R diag(1, 1, k) (s + xi e3)`` with
   ``k = 1 + gamma e d / l`` and ``xi = -mu d / (l + gamma e d)``; for the branch with xi > 0,
   ``xi = 2 e / (1 + e^2)`` and ``|k| = (alpha^2 + f^2) / beta^2`` for both kinds of mirror.
3. The lifting: ``X_s = w q - xi e3`` on the unit sphere gives
   ``w^2 |q|^2 - 2 xi w q_z + xi^2 - 1 = 0`` with discriminant/4 ``q_z^2 + (1 - xi^2)(q_x^2 + q_y^2)``.
4. The line conic: ``n . X_s = 0`` and ``|X_s| = 1`` with ``X_s = w m - xi e3`` eliminate w to
   ``m^T Omega m = 0``, ``Omega = (1 - xi^2) n n^T + xi^2 n_z (n e3^T + e3 n^T) - xi^2 n_z^2 I``.
"""
import sys

import sympy as sp

ok = True


def check(label, expr):
    global ok
    z = sp.simplify(expr)
    good = z == 0 or (hasattr(z, "is_zero_matrix") and z.is_zero_matrix)
    print(f"{'ok  ' if good else 'FAIL'} {label}")
    ok &= bool(good)


alpha, f, sz, phi = sp.symbols("alpha f s_z phi", positive=True)
sx, sy = sp.cos(phi) * sp.sqrt(1 - sz**2), sp.sin(phi) * sp.sqrt(1 - sz**2)
s = sp.Matrix([sx, sy, sz])

for kind, gamma in (("ellipsoid", 1), ("hyperboloid", -1)):
    # semi-axis across: beta^2 = alpha^2 - f^2 (ellipsoid), f^2 - alpha^2 (hyperboloid)
    beta2 = gamma * (alpha**2 - f**2)
    A = gamma * beta2 / alpha**2  # x^2 + y^2 + A (z - f)^2 = gamma beta^2 (centre at f e3)
    e = f / alpha
    l = beta2 / alpha
    d = 2 * f
    for mu in (1, -1):
        R = l / (mu - gamma * e * sz)
        r = R * s
        on = r[0] ** 2 + r[1] ** 2 + A * (r[2] - f) ** 2 - gamma * beta2
        check(f"{kind}, mu={mu:+d}: r = R s with 1/R = (mu - gamma e s_z)/l lies on the mirror", on)
        k = 1 + gamma * e * d / l
        xi = -mu * d / (l + gamma * e * d)
        lhs = r - sp.Matrix([0, 0, d])
        rhs = R * sp.diag(1, 1, k) * (s + sp.Matrix([0, 0, xi]))
        check(f"{kind}, mu={mu:+d}: r - F1 = R diag(1,1,k) (s + xi e3)", lhs - rhs)
        if mu == (1 if gamma < 0 else -1):  # the branch with xi > 0 (see unified_from_central)
            check(f"{kind}: xi = 2e/(1+e^2)", xi - 2 * e / (1 + e**2))
            check(f"{kind}: |k| = (alpha^2 + f^2)/beta^2", sp.Abs(k) ** 2 - ((alpha**2 + f**2) / beta2) ** 2)

# 3. lifting
w, X, qx, qy, qz = sp.symbols("w xi q_x q_y q_z", real=True)
Xs = sp.Matrix([w * qx, w * qy, w * qz - X])
quad = sp.expand(Xs.dot(Xs) - 1)
qq = qx**2 + qy**2 + qz**2
check("lifting: |w q - xi e3|^2 - 1 = w^2 |q|^2 - 2 xi w q_z + xi^2 - 1", quad - (w**2 * qq - 2 * X * w * qz + X**2 - 1))
disc4 = (X * qz) ** 2 - qq * (X**2 - 1)
check("lifting: discriminant/4 = q_z^2 + (1 - xi^2)(q_x^2 + q_y^2)", disc4 - (qz**2 + (1 - X**2) * (qx**2 + qy**2)))
wplus = (X * qz + sp.sqrt(disc4)) / qq
check("lifting: the root (xi q_z + sqrt(disc))/|q|^2 solves it", quad.subs(w, wplus))

# 4. line conic
nx, ny, nz, m1, m2, m3 = sp.symbols("n_x n_y n_z m_1 m_2 m_3", real=True)
n = sp.Matrix([nx, ny, nz])
m = sp.Matrix([m1, m2, m3])
e3 = sp.Matrix([0, 0, 1])
wl = X * nz / n.dot(m)  # from n . (w m - xi e3) = 0
sphere = (wl * m - X * e3).dot(wl * m - X * e3) - 1
Omega = (1 - X**2) * n * n.T + X**2 * nz * (n * e3.T + e3 * n.T) - X**2 * nz**2 * sp.eye(3)
check("line conic: (n.m)^2 (|X_s|^2 - 1) = -m^T Omega m", sp.expand(sphere * n.dot(m) ** 2) + (m.T * Omega * m)[0])

sys.exit(0 if ok else 1)
