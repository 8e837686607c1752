"""The world frame W and the rig pose: ``x_M = R @ x_W + t`` (docs/conventions.md)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._checks import as_float_array, as_rotation, CatadioptricError

__all__ = ["RigPose"]


@dataclass(frozen=True, eq=False)
class RigPose:
    """Pose of a rig in the world: a world point ``x_W`` has mirror coordinates ``x_M = R x_W + t``.

    Directions transform with ``R`` alone. ``R`` is a rotation matrix (det +1).
    """

    R: np.ndarray
    t: np.ndarray

    def __post_init__(self):
        R = as_rotation(self.R, "R").copy()
        t = as_float_array(self.t, "t", 3).copy()
        if t.shape != (3,):
            raise CatadioptricError(f"t: expected a 3-vector, got an array of shape {t.shape}")
        R.setflags(write=False)
        t.setflags(write=False)
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "t", t)

    @classmethod
    def identity(cls) -> "RigPose":
        return cls(np.eye(3), np.zeros(3))

    @classmethod
    def from_mirror_in_world(cls, R_world_from_mirror, mirror_origin_in_world) -> "RigPose":
        """The pose of a rig whose mirror frame has axes ``R_world_from_mirror`` (columns) and origin
        ``mirror_origin_in_world`` in W."""
        Rw = as_rotation(R_world_from_mirror, "R_world_from_mirror")
        o = as_float_array(mirror_origin_in_world, "mirror_origin_in_world", 3)
        return cls(Rw.T, -Rw.T @ o)

    def to_mirror(self, x_W) -> np.ndarray:
        x = as_float_array(x_W, "x_W", 3)
        return x @ self.R.T + self.t

    def to_world(self, x_M) -> np.ndarray:
        x = as_float_array(x_M, "x_M", 3)
        return (x - self.t) @ self.R

    def directions_to_mirror(self, s_W) -> np.ndarray:
        return as_float_array(s_W, "s_W", 3) @ self.R.T

    def directions_to_world(self, s_M) -> np.ndarray:
        return as_float_array(s_M, "s_M", 3) @ self.R

    @property
    def origin_in_world(self) -> np.ndarray:
        """The mirror frame's origin in W."""
        return -self.R.T @ self.t

    def compose(self, other: "RigPose") -> "RigPose":
        """``self`` after ``other``: x -> self(other(x))."""
        return RigPose(self.R @ other.R, self.R @ other.t + self.t)

    def inverse(self) -> "RigPose":
        return RigPose(self.R.T, -self.R.T @ self.t)

    def to_dict(self) -> dict:
        return {"R": self.R.tolist(), "t": self.t.tolist()}
