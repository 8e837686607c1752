"""Pinhole cameras and catadioptric cameras (a quadric mirror seen by a pinhole placed anywhere).

Frames (docs/conventions.md): the camera frame is OpenCV's (x right, y down,
z forward); a point ``X_M`` of the mirror frame has camera coordinates
``X_cam = R_cam_from_mirror @ (X_M - center)``; the centre of pixel
(col, row) is (u, v) = (col, row).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ._checks import CatadioptricError, as_count, as_float_array, as_rotation, as_scalar
from ._numeric import rowdot, unit
from .mirrors import QuadricMirror

__all__ = ["PinholeCamera", "CatadioptricCamera", "look_at_rotation"]


@dataclass(frozen=True, eq=False)
class PinholeCamera:
    """Intrinsics ``K`` (3x3, upper triangular, K[2,2] = 1) and image size in pixels."""

    K: np.ndarray
    width: int
    height: int

    def __post_init__(self):
        K = as_float_array(self.K, "K", (3, 3))
        if K.shape != (3, 3):
            raise CatadioptricError(f"K: expected a 3x3 matrix, got an array of shape {K.shape}")
        # singular relative to its columns' scales (|det| over the product of their largest entries, which no
        # choice of units for the focal lengths changes): fx = fy = 1e-5 is a fine camera matrix, whose
        # absolute determinant (1e-10) says nothing about its conditioning
        cols = np.max(np.abs(K), axis=0)  # (not the 2-norm, whose squares underflow for 1e-300)
        if np.any(cols == 0) or abs(np.linalg.det(K / cols)) < 1e-12:
            raise CatadioptricError(f"K: expected an invertible intrinsic matrix, got a singular one: {K.tolist()}")
        if not (K[2, 0] == 0 and K[2, 1] == 0 and K[1, 0] == 0 and K[2, 2] == 1):
            raise CatadioptricError(
                f"K: expected an upper-triangular intrinsic matrix with K[2,2] = 1, got {K.tolist()}"
            )
        if not (K[0, 0] > 0 and K[1, 1] > 0):
            # a negative focal length mirrors the image (u decreasing with x_cam): no camera of the OpenCV
            # convention (x right, y down, z forward, right-handed) takes such pictures
            raise CatadioptricError(
                f"K: expected positive focal lengths K[0,0] > 0 and K[1,1] > 0 (a negative one mirrors the image; "
                f"turn the camera with R_cam_from_mirror instead), got {K.tolist()}"
            )
        for name in ("width", "height"):
            object.__setattr__(self, name, _pixels(getattr(self, name), name))
        K = K.copy()
        K.setflags(write=False)
        object.__setattr__(self, "K", K)
        Kinv = np.linalg.inv(K)
        if not np.all(np.isfinite(Kinv)):
            raise CatadioptricError(f"K: expected focal lengths whose inverse is finite (at least about 1e-308, not "
                                    f"subnormal), got {K.tolist()}")
        Kinv.setflags(write=False)
        object.__setattr__(self, "K_inv", Kinv)

    @classmethod
    def from_fov(cls, width: int, height: int, fov_x_deg: float) -> "PinholeCamera":
        """Square pixels, centred principal point ((W-1)/2, (H-1)/2), horizontal field of view in degrees."""
        width, height = _pixels(width, "width"), _pixels(height, "height")
        fov = as_scalar(fov_x_deg, "fov_x_deg", positive=True)
        if not fov < 180:
            raise CatadioptricError(f"fov_x_deg: expected a field of view below 180 degrees, got {fov!r}")
        with np.errstate(over="ignore", divide="ignore"):
            f = float((width / 2.0) / np.tan(np.radians(fov) / 2.0))
        try:
            return cls(np.array([[f, 0, (width - 1) / 2.0], [0, f, (height - 1) / 2.0], [0, 0, 1.0]]), width, height)
        except CatadioptricError as exc:  # the focal length the field of view gives is no camera's
            raise CatadioptricError(f"fov_x_deg: expected a field of view in (0, 180) degrees that gives a finite, "
                                    f"invertible focal length, got {fov!r} (focal length {f!r} px: {exc})") from None

    def pixel_rays(self, uv) -> np.ndarray:
        """Unnormalised camera-frame rays ``K^-1 [u, v, 1]`` for pixels ``(..., 2)``."""
        uv = as_float_array(uv, "uv", 2)
        return uv[..., 0:1] * self.K_inv[:, 0] + uv[..., 1:2] * self.K_inv[:, 1] + self.K_inv[:, 2]

    def project(self, X_cam) -> np.ndarray:
        """Pixels of camera-frame points ``(..., 3)`` (no check of the sign of z)."""
        X = np.asarray(X_cam, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            x = X[..., 0] / X[..., 2]
            y = X[..., 1] / X[..., 2]
        K = self.K
        return np.stack([K[0, 0] * x + K[0, 1] * y + K[0, 2], K[1, 1] * y + K[1, 2]], axis=-1)

    def in_image(self, uv) -> np.ndarray:
        """True where pixel coordinates fall on the image (pixel centres span 0..W-1, 0..H-1;
        the image covers -0.5..W-0.5)."""
        uv = np.asarray(uv, dtype=float)
        return (uv[..., 0] >= -0.5) & (uv[..., 0] < self.width - 0.5) & (uv[..., 1] >= -0.5) & (
            uv[..., 1] < self.height - 0.5)

    def pixel_grid(self, step: int = 1) -> np.ndarray:
        """Pixel centres ``(H', W', 2)`` of every ``step``-th row and column."""
        step = as_count(step, "step")
        u, v = np.meshgrid(np.arange(0, self.width, step, dtype=float), np.arange(0, self.height, step, dtype=float))
        return np.stack([u, v], axis=-1)

    def to_dict(self) -> dict:
        return {"K": self.K.tolist(), "width": self.width, "height": self.height}


def _pixels(v, name: str) -> int:
    if isinstance(v, (bool, np.bool_)) or not (isinstance(v, (int, np.integer)) and v > 0):
        raise CatadioptricError(f"{name}: expected a positive integer number of pixels, got {v!r}")
    return int(v)


def _keys(d, name: str, keys) -> None:
    if not isinstance(d, dict):
        raise CatadioptricError(f"{name}: expected a dict with keys {list(keys)}, got {type(d).__name__}")
    missing = [k for k in keys if k not in d]
    if missing:
        raise CatadioptricError(f"{name}: expected a dict with keys {list(keys)}, got one without {missing}")


def look_at_rotation(center, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """``R_cam_from_mirror`` of an OpenCV camera at ``center`` looking at ``target``;
    image 'up' (-y_cam) is as close as possible to ``up``."""
    c = as_float_array(center, "center", 3)
    t = as_float_array(target, "target", 3)
    for name, v in (("center", c), ("target", t)):
        if v.shape != (3,):
            raise CatadioptricError(f"{name}: expected a 3-vector, got an array of shape {v.shape}")
    z = unit(t - c)
    if not np.all(np.isfinite(z)):
        raise CatadioptricError(f"target: expected a point other than the centre {c.tolist()}, got {t.tolist()}")
    up = as_float_array(up, "up", 3)
    if up.shape != (3,) or not np.any(up != 0):
        raise CatadioptricError(f"up: expected a non-zero 3-vector, got {up.tolist()}")
    up = unit(up)
    if np.linalg.norm(np.cross(z, up)) < 1e-9:
        up = np.array([0.0, 1.0, 0.0]) if abs(z[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(z, up)  # y_cam = -up-ish, x_cam = y_cam x z_cam ... keep right-handed: x = y cross z
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z])  # rows: camera axes in M


@dataclass(frozen=True, eq=False)
class CatadioptricCamera:
    """A pinhole camera at ``center`` (mirror frame M) with ``X_cam = R_cam_from_mirror @ (X_M - center)``,
    looking at a quadric mirror."""

    mirror: QuadricMirror
    pinhole: PinholeCamera
    center: np.ndarray
    R_cam_from_mirror: np.ndarray = field(default_factory=lambda: np.eye(3))

    def __post_init__(self):
        if not isinstance(self.mirror, QuadricMirror):
            raise CatadioptricError(f"mirror: expected a QuadricMirror, got {type(self.mirror).__name__}")
        if not isinstance(self.pinhole, PinholeCamera):
            raise CatadioptricError(f"pinhole: expected a PinholeCamera, got {type(self.pinhole).__name__}")
        c = as_float_array(self.center, "center", 3)
        if c.shape != (3,):
            raise CatadioptricError(f"center: expected a 3-vector, got an array of shape {c.shape}")
        R = as_rotation(self.R_cam_from_mirror, "R_cam_from_mirror")
        m = self.mirror
        omega = float(m.implicit(c))
        if abs(omega) <= 1e-9 * m.scale**2 and m.in_patch(c, 1e-9):
            raise CatadioptricError(
                f"center: the camera centre {c.tolist()} lies on the mirror surface (Omega = {omega:.3g})"
            )
        c = c.copy()
        c.setflags(write=False)
        R = R.copy()
        R.setflags(write=False)
        object.__setattr__(self, "center", c)
        object.__setattr__(self, "R_cam_from_mirror", R)

    # ---------------------------------------------------------------- builders
    @classmethod
    def looking_at_mirror(cls, mirror: QuadricMirror, pinhole: PinholeCamera, center, *, target=None,
                          up=(0.0, 1.0, 0.0)) -> "CatadioptricCamera":
        """A camera at ``center`` whose optical axis points at ``target`` (default: the
        middle of the mirror patch on the axis)."""
        if not isinstance(mirror, QuadricMirror):
            raise CatadioptricError(f"mirror: expected a QuadricMirror, got {type(mirror).__name__}")
        c = as_float_array(center, "center", 3)
        if target is None:
            target = np.array([0.0, 0.0, 0.5 * (mirror.z_min + mirror.z_max)])
        return cls(mirror, pinhole, c, look_at_rotation(c, target, up))

    # ---------------------------------------------------------------- geometry
    @property
    def is_central(self) -> bool:
        """True when every back-projected ray passes through one point: the camera at a
        focus of an ellipsoid or a two-sheet hyperboloid (the viewpoint is the other
        focus), or at the centre of a sphere."""
        return self.viewpoint is not None

    @property
    def viewpoint(self):
        """The single effective viewpoint of a central configuration (None otherwise)."""
        foci = self.mirror.foci
        if self.mirror.kind not in ("sphere", "ellipsoid", "hyperboloid") or len(foci) != 2:
            return None
        tol = 1e-9 * self.mirror.scale
        for i, f in enumerate(foci):
            if np.linalg.norm(self.center - f) <= tol:
                return foci[1 - i].copy()
        return None

    def same_geometry(self, other) -> bool:
        """True when ``other`` is a :class:`CatadioptricCamera` with the same mirror, pinhole
        (intrinsics and image size), centre and orientation, to the bit: the two project every
        point alike (e.g. two views of one rig)."""
        if other is self:
            return True
        if type(other) is not type(self):
            return False
        p, q = self.pinhole, other.pinhole
        return (self.mirror == other.mirror and type(p) is type(q) and np.array_equal(p.K, q.K)
                and (p.width, p.height) == (q.width, q.height) and np.array_equal(self.center, other.center)
                and np.array_equal(self.R_cam_from_mirror, other.R_cam_from_mirror))

    @property
    def is_axial(self) -> bool:
        """True when the camera centre lies on the mirror's axis (every reflected ray meets the axis)."""
        from .solvers import on_axis

        return on_axis(self.mirror, self.center)

    @cached_property
    def solver(self):
        """The reflection-point solver of lowest degree for this configuration (docs/solvers.md)."""
        from .solvers import select_solver

        try:
            return select_solver(self.mirror, self.center, viewpoint=self.viewpoint)
        except ArithmeticError as exc:
            raise CatadioptricError(f"mirror, center: this configuration is beyond the solvers' float64 accuracy "
                                    f"({exc})") from None

    def to_camera(self, X_M) -> np.ndarray:
        X = np.asarray(X_M, dtype=float)
        return rowdot(X - self.center, self.R_cam_from_mirror.T)

    def pixels_of_mirror_points(self, X_M) -> np.ndarray:
        return self.pinhole.project(self.to_camera(X_M))

    # ------------------------------------------------------------ the mappings
    def backproject(self, uv):
        """Pixels ``(..., 2)`` -> reflected rays: ``.origins``, ``.directions`` (unit), ``.valid``."""
        from .projection import backproject

        return backproject(self, uv)

    def project(self, points):
        """3-D points ``(..., 3)`` in M -> every image: ``.uv (..., K, 2)``, ``.mirror_points``, ``.valid``."""
        from .projection import project

        return project(self, points)

    def vanishing_points(self, directions, *, which: str = "+s"):
        """Vanishing points of directions ``(..., 3)`` in M (see :func:`catadioptric.vanishing.vanishing_points`)."""
        from .vanishing import vanishing_points

        return vanishing_points(self, directions, which=which)

    def directions_from_vanishing_points(self, uv):
        """Unit oriented directions ``(..., 3)`` whose vanishing point is pixel ``uv (..., 2)``."""
        from .vanishing import directions_from_vanishing_points

        return directions_from_vanishing_points(self, uv)

    def vanishing_curve(self, normal, **kwargs):
        """The vanishing curve of the plane with ``normal`` (M): a list of polylines."""
        from .vanishing import vanishing_curve

        return vanishing_curve(self, normal, **kwargs)

    def line_image(self, points, directions, **kwargs):
        """Exact images of 3-D lines (see :func:`catadioptric.lines.line_image`)."""
        from .lines import line_image

        return line_image(self, points, directions, **kwargs)

    def segment_image(self, p0, p1, **kwargs):
        """Exact images of 3-D segments (see :func:`catadioptric.lines.segment_image`)."""
        from .lines import segment_image

        return segment_image(self, p0, p1, **kwargs)

    def to_dict(self) -> dict:
        return {
            "mirror": self.mirror.to_dict(),
            "pinhole": self.pinhole.to_dict(),
            "center": self.center.tolist(),
            "R_cam_from_mirror": self.R_cam_from_mirror.tolist(),
        }

    @classmethod
    def from_dict(cls, d: dict) -> "CatadioptricCamera":
        """The camera of :meth:`to_dict`'s dictionary."""
        _keys(d, "d", ("mirror", "pinhole", "center", "R_cam_from_mirror"))
        _keys(d["mirror"], "d['mirror']", ("A", "B", "C", "z_min", "z_max"))
        _keys(d["pinhole"], "d['pinhole']", ("K", "width", "height"))
        m, p = d["mirror"], d["pinhole"]
        return cls(QuadricMirror(m["A"], m["B"], m["C"], m["z_min"], m["z_max"]),
                   PinholeCamera(p["K"], p["width"], p["height"]), d["center"], d["R_cam_from_mirror"])
