"""The unified central model of catadioptric cameras (Geyer and Daniilidis 2000; Barreto and
Araujo 2001; Mei and Rives 2007): the camera (:class:`UnifiedCamera`), its results and the image
conic of a plane. Its exact parameters for a central rig and the best central approximation of a
non-central one are in :mod:`catadioptric.unified.fit`.
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

from .._checks import CatadioptricError, as_count, as_float_array, as_rotation, as_scalar
from .._numeric import max_abs, rowdot, unit

__all__ = [
    "UnifiedCamera",
    "UnifiedProjection",
    "UnifiedRays",
    "UnifiedVanishingPoints",
    "LineImageSamples",
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
