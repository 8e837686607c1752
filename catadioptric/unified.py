"""The unified central model of catadioptric cameras (Geyer and Daniilidis 2000; Barreto and
Araujo 2001; Mei and Rives 2007), its exact parameters for a central rig, and the best central
approximation of a non-central one.

The model (docs/unified.md states it in full, with its conventions and derivations)::

    Y   = R_sphere_from_mirror @ (X_M - center)     # the viewpoint is the sphere's centre
    X_s = Y / |Y|                                   # onto the unit sphere
    p   = (x_s, y_s, z_s + xi)                      # re-projection centre at (0, 0, -xi)
    uv  ~ K @ R_tilt @ p                            # generalized projection, homogeneous

``R_tilt`` is the identity in the pure unified (Mei / OpenCV omnidir) model. It is Barreto's
rotation of the conventional camera: the exact model of a central rig whose pinhole is not
aligned with the mirror axis needs it (``K @ R_tilt`` is then the RQ decomposition of the
rig's exact 3x3 generalized projection matrix). A point has an image when
``(R_tilt @ p)_z > 0`` (in front of the virtual pinhole), ``1 + xi z_s >= 0`` (for xi > 1,
the sphere point the re-projection ray meets second) and ``z_s`` is inside
``sphere_z_range`` (the mirror patch's field of view; the whole sphere by default).

Everything is batched over leading axes and float64; points ``(..., 3)``, pixels ``(..., 2)``.
A point has at most one image in this model, so results carry no solution axis ``K``.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ._checks import CatadioptricError, as_count, as_float_array, as_rotation, as_scalar
from ._numeric import max_abs, rowdot, unit
from .cameras import CatadioptricCamera
from .solvers.reflection import reflect

__all__ = [
    "UnifiedCamera",
    "UnifiedProjection",
    "UnifiedRays",
    "UnifiedVanishingPoints",
    "LineImageSamples",
    "UnifiedFit",
    "unified_from_central",
    "fit_unified",
    "conic_from_plane_normal",
    "DEFAULT_DEPTHS",
]

# depths (metres along each exact reflected ray, from its mirror point) of the fitted points
DEFAULT_DEPTHS = (1.0, 3.0, 10.0, np.inf)


# ----------------------------------------------------------------------------- results
@dataclass
class UnifiedProjection:
    """Images of points: ``uv (..., 2)`` (NaN where the formula has no value), ``valid (...)``,
    ``in_image (...)`` (valid and on the image rectangle) and ``sphere_points (..., 3)`` (``X_s``)."""

    uv: np.ndarray
    valid: np.ndarray
    in_image: np.ndarray
    sphere_points: np.ndarray


@dataclass
class UnifiedRays:
    """Rays of pixels: every ``origins (..., 3)`` is the viewpoint; ``directions (..., 3)`` unit
    in M (NaN where invalid); ``valid (...)``."""

    origins: np.ndarray
    directions: np.ndarray
    valid: np.ndarray


@dataclass
class UnifiedVanishingPoints:
    """Vanishing points of directions ``d``: ``uv``/``valid``/``in_image`` for ``+d`` (the limit of
    ``q + lambda d``, lambda -> +inf) and ``uv_opposite``/``valid_opposite``/``in_image_opposite``
    for ``-d``. Shapes ``(..., 2)`` and ``(...)``."""

    uv: np.ndarray
    valid: np.ndarray
    in_image: np.ndarray
    uv_opposite: np.ndarray
    valid_opposite: np.ndarray
    in_image_opposite: np.ndarray


@dataclass
class LineImageSamples:
    """Samples of the image of a 3-D line: ``uv (..., num, 2)``, ``valid (..., num)``, and the angle
    ``theta (num,)`` on the great circle: theta = -pi/2 is the vanishing point of ``-d``, 0 the
    point of the line closest to the viewpoint, +pi/2 the vanishing point of ``+d``."""

    uv: np.ndarray
    valid: np.ndarray
    theta: np.ndarray

    def polylines(self, index=()) -> list[np.ndarray]:
        """The runs of consecutive valid samples of one line (``index`` into the batch axes) as a
        list of ``(n, 2)`` arrays, ready to draw."""
        uv = self.uv[index]
        ok = self.valid[index]
        runs, start = [], None
        for i, v in enumerate(list(ok) + [False]):
            if v and start is None:
                start = i
            elif not v and start is not None:
                if i - start >= 2:
                    runs.append(uv[start:i])
                start = None
        return runs


# ----------------------------------------------------------------------------- the model
def _check_K(value, name: str = "K") -> np.ndarray:
    K = as_float_array(value, name, (3, 3))
    if K.shape != (3, 3):
        raise CatadioptricError(f"{name}: expected a 3x3 matrix, got an array of shape {K.shape}")
    if not (K[1, 0] == 0 and K[2, 0] == 0 and K[2, 1] == 0 and K[2, 2] == 1):
        raise CatadioptricError(
            f"{name}: expected an upper-triangular generalized projection matrix with K[2,2] = 1, got {K.tolist()}"
        )
    if K[0, 0] == 0 or K[1, 1] == 0:
        raise CatadioptricError(f"{name}: expected nonzero focal lengths K[0,0], K[1,1], got {K.tolist()}")
    return K


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class UnifiedCamera:
    """The unified sphere model: viewpoint ``center`` (mirror frame M), sphere axes
    ``R_sphere_from_mirror`` (rows: sphere axes in M; a rotation), ``xi >= 0``, the generalized
    projection matrix ``K = [[fx, s, cx], [0, fy, cy], [0, 0, 1]]`` and the tilt ``R_tilt``
    (identity for the pure Mei / omnidir model). ``width``/``height`` (optional) bound the image;
    ``sphere_z_range`` (optional) bounds ``z_s`` of the points that have an image.

    A catadioptric image is a mirror image: with a right-handed sphere frame the exact model of
    a central rig has ``fx > 0`` and ``fy < 0`` (``det K < 0``); see docs/unified.md.
    """

    xi: float
    K: np.ndarray
    R_sphere_from_mirror: np.ndarray = field(default_factory=lambda: np.eye(3))
    center: np.ndarray = field(default_factory=lambda: np.zeros(3))
    R_tilt: np.ndarray = field(default_factory=lambda: np.eye(3))
    width: Optional[int] = None
    height: Optional[int] = None
    sphere_z_range: tuple = (-1.0, 1.0)

    def __post_init__(self):
        xi = as_scalar(self.xi, "xi")
        if xi < 0:
            raise CatadioptricError(f"xi: expected xi >= 0 (flip the sphere's z axis instead), got {xi!r}")
        K = _check_K(self.K)
        R = as_rotation(self.R_sphere_from_mirror, "R_sphere_from_mirror")
        c = as_float_array(self.center, "center", 3)
        if c.shape != (3,):
            raise CatadioptricError(f"center: expected a 3-vector, got an array of shape {c.shape}")
        Rt = as_rotation(self.R_tilt, "R_tilt")
        for name in ("width", "height"):
            v = getattr(self, name)
            if v is not None:
                if isinstance(v, (bool, np.bool_)) or not (isinstance(v, (int, np.integer)) and v > 0):
                    raise CatadioptricError(f"{name}: expected a positive integer number of pixels or None, got {v!r}")
                object.__setattr__(self, name, int(v))
        if (self.width is None) != (self.height is None):
            raise CatadioptricError(
                f"width, height: expected both or neither, got width={self.width!r}, height={self.height!r}"
            )
        zr = as_float_array(self.sphere_z_range, "sphere_z_range", 2)
        if zr.shape != (2,) or not (-1.0 <= zr[0] < zr[1] <= 1.0):
            raise CatadioptricError(
                f"sphere_z_range: expected (lo, hi) with -1 <= lo < hi <= 1, got {np.asarray(zr).tolist()}"
            )
        object.__setattr__(self, "xi", xi)
        object.__setattr__(self, "K", _frozen(K))
        object.__setattr__(self, "R_sphere_from_mirror", _frozen(R))
        object.__setattr__(self, "center", _frozen(c))
        object.__setattr__(self, "R_tilt", _frozen(Rt))
        object.__setattr__(self, "sphere_z_range", (float(zr[0]), float(zr[1])))

    # ------------------------------------------------------------------ properties
    @property
    def viewpoint(self) -> np.ndarray:
        """The single viewpoint (the sphere's centre) in M."""
        return self.center.copy()

    @property
    def is_pure(self) -> bool:
        """True when ``R_tilt`` is the identity: the model is Mei's (OpenCV omnidir) exactly."""
        return bool(np.max(np.abs(self.R_tilt - np.eye(3))) <= 1e-15)

    @property
    def generalized_projection(self) -> np.ndarray:
        """``H = K @ R_tilt``: pixels are ``H p`` dehomogenised, ``p = (x_s, y_s, z_s + xi)``."""
        return self.K @ self.R_tilt

    def in_image(self, uv) -> np.ndarray:
        """True where pixels fall on the image (-0.5 <= u < W - 0.5, same for v); all True when the
        camera has no image size."""
        uv = np.asarray(uv, dtype=float)
        if self.width is None:
            return np.all(np.isfinite(uv), axis=-1)
        return (uv[..., 0] >= -0.5) & (uv[..., 0] < self.width - 0.5) & (uv[..., 1] >= -0.5) & (
            uv[..., 1] < self.height - 0.5)

    # ------------------------------------------------------------------ the mappings
    def _from_sphere(self, Xs: np.ndarray) -> UnifiedProjection:
        """Project unit sphere points ``(..., 3)`` (sphere frame)."""
        xi = self.xi
        p = Xs.copy()
        p[..., 2] += xi
        q = p @ self.R_tilt.T
        den = q[..., 2]
        K = self.K
        with np.errstate(divide="ignore", invalid="ignore"):
            x = q[..., 0] / den
            y = q[..., 1] / den
        uv = np.stack([K[0, 0] * x + K[0, 1] * y + K[0, 2], K[1, 1] * y + K[1, 2]], axis=-1)
        zs = Xs[..., 2]
        lo, hi = self.sphere_z_range
        with np.errstate(invalid="ignore"):
            valid = (den > 0) & (1.0 + xi * zs >= 0) & (zs >= lo) & (zs <= hi) & np.all(np.isfinite(uv), axis=-1)
        uv = np.where(np.isfinite(uv), uv, np.nan)
        return UnifiedProjection(uv, valid, valid & self.in_image(uv), Xs)

    def to_sphere(self, points) -> np.ndarray:
        """Unit sphere points ``X_s (..., 3)`` of points ``(..., 3)`` in M (NaN at the viewpoint)."""
        P = as_float_array(points, "points", 3)
        with np.errstate(over="ignore", invalid="ignore"):
            return rowdot(unit(P - self.center), self.R_sphere_from_mirror.T)

    def project(self, points) -> UnifiedProjection:
        """Images of points ``(..., 3)`` in M: ``.uv (..., 2)``, ``.valid``, ``.in_image``, ``.sphere_points``.

        ``valid`` is False for points without an image: behind the virtual pinhole
        (``(R_tilt p)_z <= 0``; with R_tilt = I, ``z_s + xi <= 0``), on the hidden side of the
        sphere when xi > 1, outside ``sphere_z_range``, or at the viewpoint itself.
        """
        return self._from_sphere(self.to_sphere(points))

    def project_directions(self, directions) -> UnifiedProjection:
        """Images of the points at infinity of directions ``(..., 3)`` in M (any nonzero length)."""
        d = _unit_directions(directions, "directions")
        return self._from_sphere(d @ self.R_sphere_from_mirror.T)

    def vanishing_points(self, directions) -> UnifiedVanishingPoints:
        """Vanishing points of directions ``(..., 3)`` in M: the images of the points at infinity of
        ``+d`` and of ``-d`` (the projection formula with ``X_s = +-R d / |d|``)."""
        d = _unit_directions(directions, "directions")
        Xs = d @ self.R_sphere_from_mirror.T
        a = self._from_sphere(Xs)
        b = self._from_sphere(-Xs)
        return UnifiedVanishingPoints(a.uv, a.valid, a.in_image, b.uv, b.valid, b.in_image)

    def backproject(self, uv) -> UnifiedRays:
        """Rays of pixels ``(..., 2)``: origins at the viewpoint, unit directions in M (the closed-form
        lifting to the sphere, docs/unified.md), ``valid`` where the pixel is the image of a
        sphere point allowed by the model."""
        uv = as_float_array(uv, "uv", 2)
        Kinv = np.linalg.inv(self.K)
        m = uv[..., 0:1] * Kinv[:, 0] + uv[..., 1:2] * Kinv[:, 1] + Kinv[:, 2]
        # homogeneous: scaled by its largest component, so that far pixels neither overflow nor underflow
        q = rowdot(m / max_abs(m), self.R_tilt)  # R_tilt^T m, row-vector form
        xi = self.xi
        qq = np.sum(q * q, axis=-1)
        qz = q[..., 2]
        disc = qz * qz + (1.0 - xi * xi) * (q[..., 0] ** 2 + q[..., 1] ** 2)
        with np.errstate(invalid="ignore", divide="ignore"):
            sq = np.sqrt(disc)
            # the larger root of w^2 |q|^2 - 2 xi w q_z + xi^2 - 1 = 0, without cancellation
            w = np.where(xi * qz >= 0, (xi * qz + sq) / qq, (1.0 - xi * xi) / (sq - xi * qz))
        Xs = w[..., None] * q
        Xs[..., 2] -= xi
        # renormalise (removes the last ulp of drift; the lifting is exact on the sphere)
        Xs /= np.linalg.norm(Xs, axis=-1, keepdims=True)
        zs = Xs[..., 2]
        lo, hi = self.sphere_z_range
        with np.errstate(invalid="ignore"):
            valid = (disc >= 0) & (w > 0) & (zs >= lo) & (zs <= hi)
        d = rowdot(Xs, self.R_sphere_from_mirror)  # R^T X_s
        d = np.where(valid[..., None], d, np.nan)
        o = np.broadcast_to(self.center, d.shape).copy()
        return UnifiedRays(o, d, valid)

    # ------------------------------------------------------------------ lines
    def _plane_normals(self, points, directions):
        """Normals (sphere frame, any length) of the planes through the viewpoint and the lines, and the
        size of the points' coordinates (the rounding of ``p - c`` is relative to it)."""
        p = as_float_array(points, "points", 3)
        d = _unit_directions(directions, "directions")
        v = p - self.center
        size = np.maximum(max_abs(p), np.max(np.abs(self.center)))
        scale = np.where(max_abs(v) > 0, max_abs(v), 1.0)
        n = np.cross(v / scale, d)
        return rowdot(n, self.R_sphere_from_mirror.T), size / scale

    def line_image(self, points, directions) -> np.ndarray:
        """The conics ``C (..., 3, 3)`` (symmetric, unit Frobenius norm) of the images of the 3-D
        lines through ``points (..., 3)`` with ``directions (..., 3)`` (M): a pixel ``(u, v)`` of
        the line's image satisfies ``[u, v, 1] C [u, v, 1]^T = 0``.

        With ``n`` the normal (sphere frame) of the plane through the viewpoint and the line,
        ``Omega = (1 - xi^2) n n^T + xi^2 n_z (n e3^T + e3 n^T) - xi^2 n_z^2 I`` is the conic in
        ``p``-coordinates and ``C = K^-T R_tilt Omega R_tilt^T K^-1`` (Barreto and Araujo 2005).
        The conic holds the images of the whole great circle ``n . X_s = 0``: the line's half
        and the half of the opposite directions. NaN for lines through the viewpoint.
        """
        n, size = self._plane_normals(points, directions)
        # a line through the viewpoint to the rounding of p - c has no plane: NaN
        n = np.where(max_abs(n) > 1e-12 * size, unit(n), np.nan)
        Om = conic_from_plane_normal(n, self.xi)
        Kinv = np.linalg.inv(self.K)
        T = self.R_tilt.T @ Kinv  # p ~ T @ pixel
        C = np.einsum("ji,...jk,kl->...il", T, Om, T)
        norm = np.linalg.norm(C, axis=(-2, -1), keepdims=True)
        with np.errstate(invalid="ignore", divide="ignore"):
            return C / norm

    def sample_line_image(self, points, directions, num: int = 256) -> LineImageSamples:
        """``num`` samples of the image of each 3-D line (points ``(..., 3)``, directions ``(..., 3)``
        in M): the half great circle of the line's directions from the viewpoint, uniformly in
        angle from the vanishing point of ``-d`` to that of ``+d``, projected."""
        num = as_count(num, "num", minimum=2, maximum=10_000_000)
        p = as_float_array(points, "points", 3)
        d = _unit_directions(directions, "directions")
        v = p - self.center
        v = v / np.where(max_abs(v) > 0, max_abs(v), 1.0)
        foot = v - np.sum(v * d, axis=-1, keepdims=True) * d
        a = unit(foot)
        R = self.R_sphere_from_mirror
        a = a @ R.T
        b = d @ R.T
        theta = np.linspace(-np.pi / 2, np.pi / 2, int(num))
        Xs = np.cos(theta)[:, None] * a[..., None, :] + np.sin(theta)[:, None] * b[..., None, :]
        pr = self._from_sphere(Xs)
        return LineImageSamples(pr.uv, pr.valid, theta)

    # ------------------------------------------------------------------ OpenCV omnidir
    def to_omnidir(self) -> dict:
        """The model in the parameters of OpenCV's omnidir module (Mei's model): ``K`` (3x3, with
        fx, fy, skew s, cx, cy), ``D = [k1, k2, p1, p2] = 0``, ``xi``, and the pose of M in the
        omnidir camera frame (``X_c = R(rvec) X_M + tvec``, the sphere frame). Raises when
        ``R_tilt`` is not the identity (omnidir has no tilt)."""
        if not self.is_pure:
            raise CatadioptricError(
                "R_tilt: OpenCV omnidir has no tilted pinhole; expected R_tilt = I, got "
                f"{np.round(self.R_tilt, 12).tolist()} (fit a pure model with fit_unified(..., tilt=False))"
            )
        from scipy.spatial.transform import Rotation

        R = self.R_sphere_from_mirror
        return {
            "K": self.K.tolist(),
            "D": [0.0, 0.0, 0.0, 0.0],
            "xi": self.xi,
            "rvec": Rotation.from_matrix(R).as_rotvec().tolist(),
            "tvec": (-R @ self.center).tolist(),
            "fx": float(self.K[0, 0]),
            "fy": float(self.K[1, 1]),
            "s": float(self.K[0, 1]),
            "cx": float(self.K[0, 2]),
            "cy": float(self.K[1, 2]),
        }

    @classmethod
    def from_omnidir(cls, K, xi, rvec=(0.0, 0.0, 0.0), tvec=(0.0, 0.0, 0.0), D=None, *, width=None,
                     height=None) -> "UnifiedCamera":
        """The model of OpenCV omnidir parameters (``X_c = R(rvec) X + tvec``); ``D`` must be zero
        (this model has no lens distortion)."""
        if D is not None:
            Dv = as_float_array(D, "D").reshape(-1)
            if Dv.shape != (4,) or np.any(Dv != 0):
                raise CatadioptricError(
                    f"D: expected zero distortion [0, 0, 0, 0] (the unified model has none), got {Dv.tolist()}"
                )
        from scipy.spatial.transform import Rotation

        rv = as_float_array(rvec, "rvec").reshape(-1)
        tv = as_float_array(tvec, "tvec").reshape(-1)
        if rv.shape != (3,):
            raise CatadioptricError(f"rvec: expected a rotation vector of 3 numbers, got {rv.size}")
        if tv.shape != (3,):
            raise CatadioptricError(f"tvec: expected a translation of 3 numbers, got {tv.size}")
        R = Rotation.from_rotvec(rv).as_matrix()
        return cls(xi, K, R, -R.T @ tv, np.eye(3), width, height)

    # ------------------------------------------------------------------ serialisation
    def to_dict(self) -> dict:
        return {
            "xi": self.xi,
            "K": self.K.tolist(),
            "R_sphere_from_mirror": self.R_sphere_from_mirror.tolist(),
            "center": self.center.tolist(),
            "R_tilt": self.R_tilt.tolist(),
            "width": self.width,
            "height": self.height,
            "sphere_z_range": list(self.sphere_z_range),
        }

    @classmethod
    def from_dict(cls, d: dict) -> "UnifiedCamera":
        return cls(d["xi"], np.array(d["K"]), np.array(d["R_sphere_from_mirror"]), np.array(d["center"]),
                   np.array(d.get("R_tilt", np.eye(3))), d.get("width"), d.get("height"),
                   tuple(d.get("sphere_z_range", (-1.0, 1.0))))


def _unit_directions(directions, name: str) -> np.ndarray:
    d = as_float_array(directions, name, 3)
    zero = ~np.any(d != 0, axis=-1)
    if np.any(zero):
        bad = np.argwhere(zero)[0]
        raise CatadioptricError(f"{name}: expected nonzero direction vectors, got a zero vector at index "
                                f"{tuple(int(i) for i in bad)}")
    return unit(d)


def conic_from_plane_normal(n, xi: float) -> np.ndarray:
    """The conic ``Omega (..., 3, 3)`` in ``p``-coordinates (``p = X_s + xi e3``) of the great circle
    ``n . X_s = 0`` (``n (..., 3)`` in the sphere frame, any length):
    ``Omega = (1 - xi^2) n n^T + xi^2 n_z (n e3^T + e3 n^T) - xi^2 n_z^2 I``."""
    n = np.asarray(n, dtype=float)
    xi = float(xi)
    nz = n[..., 2]
    Om = (1.0 - xi * xi) * n[..., :, None] * n[..., None, :]
    Om[..., :, 2] += xi * xi * nz[..., None] * n
    Om[..., 2, :] += xi * xi * nz[..., None] * n
    Om -= xi * xi * (nz * nz)[..., None, None] * np.eye(3)
    return Om


# ----------------------------------------------------------------------------- exact central parameters
def _rotation_taking(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit vector ``a`` to unit vector ``b``."""
    v = np.cross(a, b)
    c = float(np.dot(a, b))
    s = float(np.linalg.norm(v))
    if s < 1e-15:
        if c > 0:
            return np.eye(3)
        # half turn about any axis orthogonal to a
        axis = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2.0 * np.outer(axis, axis) - np.eye(3)
    k = v / s
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * Kx + (1 - c) * Kx @ Kx


def _frame_with_z(z: np.ndarray) -> np.ndarray:
    """A rotation whose third row is the unit vector ``z``."""
    return _rotation_taking(z, np.array([0.0, 0.0, 1.0]))


def _rq_pinned(M: np.ndarray):
    """``M = lambda K Q`` with K upper triangular, K[2,2] = 1, K[0,0] > 0, Q a rotation, lambda > 0
    (the sign of M's overall scale is kept: callers choose it)."""
    from scipy.linalg import rq

    U, Q = rq(M)
    d1 = np.sign(U[0, 0])
    d3 = np.sign(U[2, 2])
    d2 = d1 * d3 * np.sign(np.linalg.det(Q))
    D = np.diag([d1, d2, d3])
    U = U @ D
    Q = D @ Q
    lam = U[2, 2]
    K = U / lam
    K[1, 0] = K[2, 0] = K[2, 1] = 0.0
    K[2, 2] = 1.0
    return K, Q, lam


def _conic_parameters(mirror):
    """Centre z0, semi-axes alpha (along) and beta (across), focal half-distance f, eccentricity e,
    semi-latus rectum l and gamma (+1 ellipsoid, -1 hyperboloid) of a mirror of revolution."""
    A, B, C = mirror.A, mirror.B, mirror.C
    z0 = -B / (2 * A)
    Kc = C + B * B / (4 * A)
    alpha2 = abs(Kc / A)
    beta2 = abs(Kc)
    if mirror.kind == "hyperboloid":
        f = np.sqrt(alpha2 + beta2)
        gamma = -1.0
    else:
        f = np.sqrt(max(alpha2 - beta2, 0.0))
        gamma = 1.0
    alpha = np.sqrt(alpha2)
    return z0, alpha, np.sqrt(beta2), f, f / alpha, beta2 / alpha, gamma


def _patch_edge_points(mirror) -> np.ndarray:
    """Points of the mirror patch's meridian (x >= 0, y = 0) at z_min, z_max and between, where the
    surface exists."""
    zs = np.linspace(mirror.z_min, mirror.z_max, 9)
    r2 = mirror.radius_squared(zs)
    ok = r2 >= -1e-12 * mirror.scale ** 2  # a vertex at a patch end can round to a tiny negative r^2
    return np.stack([np.sqrt(np.maximum(r2[ok], 0.0)), np.zeros(ok.sum()), zs[ok]], axis=-1)


def unified_from_central(cam: CatadioptricCamera) -> UnifiedCamera:
    """The exact unified model of a central rig: a pinhole at one focus of an ellipsoid or a
    two-sheet hyperboloid; the viewpoint is the other focus.

    With the mirror's semi-axes alpha (along the axis) and beta (across), focal half-distance f,
    eccentricity e = f / alpha, semi-latus rectum l = beta^2 / alpha and focal distance d = 2 f:
    ``xi = 2 e / (1 + e^2)`` and, in the sphere frame whose z axis points from the viewpoint to
    the pinhole, the pinhole sees ``r - F1 = R diag(1, 1, k) (X_s + xi e3)`` with
    ``|k| = (alpha^2 + f^2) / beta^2`` (R the signed distance from the viewpoint to the mirror
    point). Hence pixels ``~ K_pin R_pin R_S^T diag(1, 1, k) p``; its RQ decomposition gives
    ``K`` and ``R_tilt`` (identity when the optical axis lies along the mirror axis). Agrees with
    ``cam.project`` / ``cam.backproject`` to rounding (docs/unified.md, tests/test_unified.py).
    """
    if not isinstance(cam, CatadioptricCamera):
        raise CatadioptricError(f"cam: expected a CatadioptricCamera, got {type(cam).__name__}")
    m = cam.mirror
    if m.kind not in ("ellipsoid", "hyperboloid") or cam.viewpoint is None:
        foci = m.foci
        dist = min((float(np.linalg.norm(cam.center - f)) for f in foci), default=float("nan"))
        raise CatadioptricError(
            f"cam: expected a central rig (pinhole at a focus of an ellipsoid or two-sheet hyperboloid), got a "
            f"{m.kind} mirror with the camera {dist:.6g} m from the nearest focus"
            + ("" if foci else " (the mirror has no foci on its axis)")
        )
    z0, alpha, beta, f, e, l, gamma = _conic_parameters(m)
    foci = m.foci
    i1 = int(np.argmin([np.linalg.norm(cam.center - F) for F in foci]))
    F1, F2 = np.asarray(foci[i1], float), np.asarray(foci[1 - i1], float)  # pinhole, viewpoint
    d = 2.0 * f
    a_hat = (F1 - F2) / d
    # branch: the sign of R (world points beyond the mirror point, R > 0, or beyond the viewpoint)
    pts = _patch_edge_points(m)
    r = pts[len(pts) // 2]
    inc = r - F1
    out = reflect(inc, m.normal(r))
    sgnR = 1.0 if np.dot(out, r - F2) > 0 else -1.0
    s = sgnR * (r - F2) / np.linalg.norm(r - F2)
    Rsigned = sgnR * np.linalg.norm(r - F2)
    mu = l / Rsigned + gamma * e * np.dot(s, a_hat)
    if abs(abs(mu) - 1.0) > 1e-6:  # pragma: no cover - the focal property guarantees |mu| = 1
        raise CatadioptricError(f"cam: the mirror point does not satisfy the focal property (mu = {mu!r})")
    mu = float(np.sign(mu))
    k = 1.0 + gamma * e * d / l
    xi = -mu * d / (l + gamma * e * d)
    R_S = _frame_with_z(a_hat)
    flip = np.eye(3)
    if xi < 0:
        # rotate the sphere frame half a turn about x: p' = diag(1, -1, -1) p, xi' = -xi
        flip = np.diag([1.0, -1.0, -1.0])
        R_S = flip @ R_S
        xi = -xi
    H = cam.pinhole.K @ cam.R_cam_from_mirror @ R_S.T @ flip @ np.diag([1.0, 1.0, k]) @ flip
    # pixel ~ R H p and the pinhole's depth is R (H p)_z: keep the sign of R so that
    # (R_tilt p)_z > 0 exactly where the point is in front of the pinhole
    K, Q, _ = _rq_pinned(sgnR * H)
    g = Q[:, 2]
    if np.max(np.abs(g - [0.0, 0.0, 1.0])) <= 1e-14:
        R_swing = np.eye(3)  # the optical axis lies along the mirror axis: the pure unified model
    else:
        R_swing = _rotation_taking(np.array([0.0, 0.0, 1.0]), g)
    Rz = R_swing.T @ Q  # a rotation about z: commutes with the shift by xi e3
    R_S = Rz @ R_S
    # the patch's field of view: z_s of the viewing directions of the patch's meridian
    sdir = sgnR * (pts - F2)
    sdir /= np.linalg.norm(sdir, axis=-1, keepdims=True)
    zs = (sdir @ R_S.T)[:, 2]
    pad = 1e-12  # rounding at the rim: pixels on the patch's edge stay valid in both models
    zr = (max(-1.0, float(zs.min()) - pad), min(1.0, float(zs.max()) + pad))
    return UnifiedCamera(xi, K, R_S, F2, R_swing, cam.pinhole.width, cam.pinhole.height, zr)


# ----------------------------------------------------------------------------- fitting
@dataclass
class UnifiedFit:
    """The best central approximation of a rig (:func:`fit_unified`).

    ``camera`` is the fitted :class:`UnifiedCamera`; residuals are pixel distances between the
    fitted model's image of each sample point and the exact pixel it came from. ``rms_px``,
    ``max_px``, ``median_px`` over all samples; ``per_depth`` maps each depth (metres, "inf") to
    its rms and max; ``n_pixels`` and ``n_points`` count the samples; ``initial`` is the start
    (the exact model of the nearest central configuration when there is one)."""

    camera: UnifiedCamera
    rms_px: float
    max_px: float
    median_px: float
    per_depth: dict
    n_pixels: int
    n_points: int
    nfev: int
    success: bool
    message: str
    initial: UnifiedCamera
    depths: tuple
    tilt: bool

    def to_dict(self) -> dict:
        return {
            "camera": self.camera.to_dict(),
            "rms_px": self.rms_px,
            "max_px": self.max_px,
            "median_px": self.median_px,
            "per_depth": self.per_depth,
            "n_pixels": self.n_pixels,
            "n_points": self.n_points,
            "nfev": self.nfev,
            "success": self.success,
            "message": self.message,
            "depths_m": [("inf" if not np.isfinite(t) else float(t)) for t in self.depths],
            "tilt": self.tilt,
        }


def _normalised_plane(xi, R, c, Rt, X, w):
    """Homogeneous points ``(X, w)`` on the unit sphere, shifted by xi and tilted: ``q`` (before K)."""
    Y = (X - w[:, None] * c) @ R.T
    p = Y / np.linalg.norm(Y, axis=-1, keepdims=True)
    p[:, 2] += xi
    return p @ Rt.T


def _project_homogeneous(xi, K, R, c, Rt, X, w):
    """Pixels of homogeneous points ``(X, w)`` (w = 1 finite, 0 at infinity), no checks."""
    q = _normalised_plane(xi, R, c, Rt, X, w)
    x = q[:, 0] / q[:, 2]
    y = q[:, 1] / q[:, 2]
    return np.stack([K[0, 0] * x + K[0, 1] * y + K[0, 2], K[1, 1] * y + K[1, 2]], axis=-1), q[:, 2]


def _linear_K(xi, R, c, Rt, X, w, uv):
    """The K (fx, s, cx, fy, cy) minimising the pixel residuals for fixed xi, R, c, R_tilt (linear)."""
    q = _normalised_plane(xi, R, c, Rt, X, w)
    x = q[:, 0] / q[:, 2]
    y = q[:, 1] / q[:, 2]
    one = np.ones_like(x)
    a, *_ = np.linalg.lstsq(np.stack([x, y, one], -1), uv[:, 0], rcond=None)
    b, *_ = np.linalg.lstsq(np.stack([y, one], -1), uv[:, 1], rcond=None)
    return np.array([[a[0], a[1], a[2]], [0.0, b[0], b[1]], [0.0, 0.0, 1.0]])


def _samples(cam: CatadioptricCamera, step: int, depths):
    uv = cam.pinhole.pixel_grid(step).reshape(-1, 2)
    rays = cam.backproject(uv)
    ok = rays.valid
    uv, o, d = uv[ok], rays.origins[ok], rays.directions[ok]
    Xs, ws, uvs, tags = [], [], [], []
    for t in depths:
        if np.isfinite(t):
            Xs.append(o + t * d)
            ws.append(np.ones(len(d)))
        else:
            Xs.append(d)
            ws.append(np.zeros(len(d)))
        uvs.append(uv)
        tags.append(np.full(len(d), float(t)))
    return len(uv), np.concatenate(Xs), np.concatenate(ws), np.concatenate(uvs), np.concatenate(tags), o, d


def _generic_initial(cam: CatadioptricCamera, X, w, uv, origins, dirs) -> UnifiedCamera:
    """A start for rigs without a nearby central configuration: the point closest to all the
    exact rays as viewpoint, the sphere's z axis toward the pinhole, a coarse scan over xi with K
    solved linearly for each."""
    # least-squares point closest to the lines origins + t dirs
    P = np.eye(3)[None] - dirs[:, :, None] * dirs[:, None, :]
    A = P.sum(0)
    b = np.einsum("nij,nj->i", P, origins)
    c = np.linalg.solve(A, b)
    z = cam.center - c
    R = _frame_with_z(z / np.linalg.norm(z))
    best = None
    for xi in np.linspace(0.0, 1.5, 16):
        K = _linear_K(xi, R, c, np.eye(3), X, w, uv)
        if not (np.all(np.isfinite(K)) and K[0, 0] != 0 and K[1, 1] != 0):
            continue
        res, _ = _project_homogeneous(xi, K, R, c, np.eye(3), X, w)
        cost = np.nanmean(np.sum((res - uv) ** 2, -1))
        if best is None or cost < best[0]:
            Rk = R
            if K[0, 0] < 0:  # the same model with the sphere turned half a turn about z: fx > 0
                Rz = np.diag([-1.0, -1.0, 1.0])
                K, Rk = K @ Rz, Rz @ R
                K[2, 2] = 1.0
            best = (cost, xi, K, Rk)
    _, xi, K, R = best
    return UnifiedCamera(xi, K, R, c, np.eye(3), cam.pinhole.width, cam.pinhole.height)


def _nearest_central_initial(cam: CatadioptricCamera) -> Optional[UnifiedCamera]:
    m = cam.mirror
    if m.kind not in ("ellipsoid", "hyperboloid") or len(m.foci) != 2:
        return None
    F = min(m.foci, key=lambda F: float(np.linalg.norm(cam.center - F)))
    try:
        central = CatadioptricCamera(m, cam.pinhole, F, cam.R_cam_from_mirror)
        return unified_from_central(central)
    except CatadioptricError:
        return None


def fit_unified(cam: CatadioptricCamera, *, step: int = 8, depths=DEFAULT_DEPTHS, tilt: bool = False,
                initial: Optional[UnifiedCamera] = None, max_nfev: int = 400) -> UnifiedFit:
    """The best central (unified-model) approximation of the rig ``cam``, by least squares.

    Samples: the centres of every ``step``-th pixel (rows and columns) whose exact back-projected
    ray is valid; along each exact reflected ray, the points at ``depths`` metres from its mirror
    point (``inf``: the ray's point at infinity). Minimised: the sum over all samples of the
    squared pixel distance between the model's image of the sample point and the pixel it came
    from (``scipy.optimize.least_squares``, trust-region reflective, ``xi >= 0``), over xi, the
    five entries of K (fx, fy, skew, cx, cy), the viewpoint (3) and the sphere's orientation (3),
    plus, with ``tilt=True``, the tilt ``R_tilt`` (2: a rotation about an axis in the x-y plane).
    With ``tilt=False`` the result is a pure Mei model (OpenCV omnidir, :meth:`UnifiedCamera.to_omnidir`).

    Start: ``initial`` when given; else the exact model of the same pinhole moved to the nearest
    focus (ellipsoid, hyperboloid; for tilt=False its tilt is folded into K by a linear fit);
    else a generic start (viewpoint closest to all rays, scan of xi).
    """
    from scipy.optimize import least_squares
    from scipy.spatial.transform import Rotation

    if not isinstance(cam, CatadioptricCamera):
        raise CatadioptricError(f"cam: expected a CatadioptricCamera, got {type(cam).__name__}")
    if not (isinstance(step, (int, np.integer)) and step >= 1):
        raise CatadioptricError(f"step: expected a positive integer, got {step!r}")
    dep = as_float_array(depths, "depths", finite=False).reshape(-1)
    if dep.size == 0 or np.any(np.isnan(dep)) or np.any(dep <= 0):
        raise CatadioptricError(f"depths: expected positive depths in metres (inf allowed), got {dep.tolist()}")
    if initial is not None and not isinstance(initial, UnifiedCamera):
        raise CatadioptricError(f"initial: expected a UnifiedCamera or None, got {type(initial).__name__}")
    n_pix, X, w, uv, tags, ray_o, ray_d = _samples(cam, int(step), dep)
    if n_pix < 10:
        raise CatadioptricError(
            f"cam: expected a rig whose image sees the mirror at 10 or more sampled pixels, got {n_pix} (step={step})"
        )
    init = initial if initial is not None else _nearest_central_initial(cam)
    if init is None:
        init = _generic_initial(cam, X, w, uv, ray_o, ray_d)
    R0, c0, xi0 = init.R_sphere_from_mirror, init.center, init.xi
    Rt0 = init.R_tilt if tilt else np.eye(3)
    K0 = init.K if (tilt or init.is_pure) else _linear_K(xi0, R0, c0, Rt0, X, w, uv)
    scale = cam.mirror.scale

    def unpack(x):
        xi = x[0]
        K = np.array([[x[1], x[3], x[4]], [0.0, x[2], x[5]], [0.0, 0.0, 1.0]])
        c = c0 + scale * x[6:9]
        R = Rotation.from_rotvec(x[9:12]).as_matrix() @ R0
        Rt = (Rotation.from_rotvec([x[12], x[13], 0.0]).as_matrix() @ Rt0) if tilt else np.eye(3)
        return xi, K, c, R, Rt

    def residuals(x):
        xi, K, c, R, Rt = unpack(x)
        pr, den = _project_homogeneous(xi, K, R, c, Rt, X, w)
        r = pr - uv
        # samples the model cannot image get a large, smooth penalty instead of a NaN
        bad = ~(np.isfinite(r).all(-1) & (den > 0))
        r = np.where(bad[:, None], 1e3, r)
        return r.reshape(-1)

    x0 = np.concatenate([[xi0, K0[0, 0], K0[1, 1], K0[0, 1], K0[0, 2], K0[1, 2]], np.zeros(6),
                         np.zeros(2) if tilt else []])
    lb = np.full_like(x0, -np.inf)
    lb[0] = 0.0
    x0[0] = max(x0[0], 0.0)
    sol = least_squares(residuals, x0, bounds=(lb, np.full_like(x0, np.inf)), x_scale="jac", method="trf",
                        xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=max_nfev)
    xi, K, c, R, Rt = unpack(sol.x)
    if K[0, 0] < 0:  # the same model with the sphere turned half a turn about z
        Rz = np.diag([-1.0, -1.0, 1.0])
        K = K @ Rz
        K[2, 2] = 1.0
        R = Rz @ R
        Rt = Rz @ Rt @ Rz
    fitted = UnifiedCamera(xi, K, R, c, Rt, cam.pinhole.width, cam.pinhole.height)
    pr, den = _project_homogeneous(xi, K, R, c, Rt, X, w)
    err = np.linalg.norm(pr - uv, axis=-1)
    err = np.where(np.isfinite(err) & (den > 0), err, np.inf)
    per = {}
    for t in dep:
        sel = tags == t
        key = "inf" if not np.isfinite(t) else f"{t:g}"
        per[key] = {"rms_px": float(np.sqrt(np.mean(err[sel] ** 2))), "max_px": float(np.max(err[sel]))}
    return UnifiedFit(fitted, float(np.sqrt(np.mean(err ** 2))), float(np.max(err)), float(np.median(err)), per,
                      int(n_pix), int(len(err)), int(sol.nfev), bool(sol.success), str(sol.message), init,
                      tuple(float(t) for t in dep), bool(tilt))
