"""Axially symmetric quadric mirrors ``x^2 + y^2 + A z^2 + B z - C = 0`` clipped to ``z_min <= z <= z_max``.

Frame M: right-handed, z is the axis of revolution. The kind of mirror follows
from the parameters (see docs/conventions.md): A = 1 sphere, A > 0 ellipsoid,
A = 0 paraboloid (cylinder when B = 0 too), A < 0 hyperboloid, cone when the
hyperboloid degenerates (``C + B^2/(4A) = 0``; with B = 0 that is C = 0).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ._checks import CatadioptricError, as_float_array, as_scalar

__all__ = ["QuadricMirror"]

_REL = 1e-12
_MAX_A = 1e6  # |A| = (across / along)^2 of the semi-axes: beyond, the solvers lose float64 accuracy


def _length(value, name: str) -> float:
    """A positive length whose square is a normal float (the mirror equation holds squares)."""
    v = as_scalar(value, name, positive=True)
    if not 1e-150 <= v <= 1e150:
        raise CatadioptricError(f"{name}: expected a length between 1e-150 and 1e150 (its square must be a normal "
                                f"float), got {v!r}")
    return v


@dataclass(frozen=True)
class QuadricMirror:
    """The patch ``z_min <= z <= z_max`` of ``x^2 + y^2 + A z^2 + B z - C = 0``."""

    A: float
    B: float
    C: float
    z_min: float
    z_max: float

    def __post_init__(self):
        for name in ("A", "B", "C", "z_min", "z_max"):
            object.__setattr__(self, name, as_scalar(getattr(self, name), name))
        if not self.z_min < self.z_max:
            raise CatadioptricError(
                f"z_min, z_max: expected z_min < z_max, got z_min={self.z_min!r} >= z_max={self.z_max!r}"
            )
        A, B, C = self.A, self.B, self.C
        if abs(A) > _MAX_A:
            raise CatadioptricError(
                f"A: expected |A| <= {_MAX_A:g} (A is the squared ratio of the semi-axes across and along the axis; "
                f"a mirror that flat or that slender is beyond float64 accuracy), got {A!r}"
            )
        with np.errstate(over="ignore", invalid="ignore"):
            k = C + B * B / (4 * A) if A != 0 else C
            ends = [float(self.radius_squared(z)) for z in (self.z_min, self.z_max)]
        if not (np.isfinite(k) and all(np.isfinite(ends))):
            raise CatadioptricError(
                f"A, B, C: expected a surface whose size is a finite float, got C + B^2/(4A) = {k!r} and "
                f"x^2 + y^2 = {ends} at z_min, z_max for A={A!r}, B={B!r}, C={C!r}"
            )
        if A > 0 and k <= 0:
            raise CatadioptricError(
                f"A, B, C: the surface is empty (an ellipsoid needs C + B^2/(4A) > 0, "
                f"got {k!r} for A={A!r}, B={B!r}, C={C!r})"
            )
        if A == 0 and B == 0 and C <= 0:
            raise CatadioptricError(f"C: a cylinder (A = B = 0) needs C > 0, got C={C!r}")
        widest = self._patch_widest()
        if widest < 0:
            raise CatadioptricError(
                f"z_min, z_max: the patch z in [{self.z_min!r}, {self.z_max!r}] holds no point of the surface "
                f"(x^2 + y^2 = C - A z^2 - B z is negative there)"
            )
        if widest == 0:
            raise CatadioptricError(
                f"z_min, z_max: the patch z in [{self.z_min!r}, {self.z_max!r}] touches the surface at one height "
                f"only (x^2 + y^2 = C - A z^2 - B z is zero there to rounding): expected a patch with an area"
            )

    # ------------------------------------------------------------------ geometry
    def radius_squared(self, z):
        """``x^2 + y^2`` of the surface at height ``z`` (negative: no point there)."""
        z = np.asarray(z, dtype=float)
        return self.C - self.A * z * z - self.B * z

    def _patch_widest(self) -> float:
        """The largest ``x^2 + y^2`` over the patch; 0 when it is zero to the rounding of its terms."""
        zs = [self.z_min, self.z_max]
        if self.A != 0:
            zc = -self.B / (2 * self.A)
            if self.z_min < zc < self.z_max:
                zs.append(zc)
        best, size = max((float(self.radius_squared(z)), abs(self.C) + abs(self.B * z) + abs(self.A) * z * z)
                         for z in zs)
        return 0.0 if abs(best) <= 16 * np.finfo(float).eps * size else best

    def implicit(self, points) -> np.ndarray:
        """``Omega(r)`` for points ``(..., 3)``: zero on the surface."""
        p = as_float_array(points, "points", 3, finite=False)
        return p[..., 0] ** 2 + p[..., 1] ** 2 + self.A * p[..., 2] ** 2 + self.B * p[..., 2] - self.C

    def normal(self, points) -> np.ndarray:
        """Half-gradient ``[x, y, A z + B/2]`` (not unit) at points ``(..., 3)``."""
        p = as_float_array(points, "points", 3, finite=False)
        n = p.copy()
        n[..., 2] = self.A * p[..., 2] + 0.5 * self.B
        return n

    def in_patch(self, points, tol: float = 0.0) -> np.ndarray:
        z = np.asarray(points, dtype=float)[..., 2]
        t = tol * self.scale
        return (z >= self.z_min - t) & (z <= self.z_max + t)

    @property
    def scale(self) -> float:
        """A length typical of the patch, used to normalise computations."""
        r2 = [max(float(self.radius_squared(z)), 0.0) for z in (self.z_min, self.z_max)]
        return float(max(np.sqrt(max(r2)), abs(self.z_min), abs(self.z_max), self.z_max - self.z_min))

    @property
    def kind(self) -> str:
        A, B, C = self.A, self.B, self.C
        if A == 1:
            return "sphere"
        if A > 0:
            return "ellipsoid"
        if A == 0:
            return "cylinder" if B == 0 else "paraboloid"
        k = C + B * B / (4 * A)
        if abs(k) <= _REL * max(abs(C), B * B / (4 * abs(A)), 1e-300):
            return "cone"
        return "hyperboloid" if k < 0 else "hyperboloid_one_sheet"

    @property
    def center_z(self) -> Optional[float]:
        """Centre on the axis of a sphere, ellipsoid or hyperboloid (apex of a cone)."""
        if self.A == 0:
            return None
        return -self.B / (2 * self.A)

    @property
    def foci(self) -> tuple[np.ndarray, ...]:
        """Foci on the axis, as points in M: two for a prolate ellipsoid or a
        two-sheet hyperboloid, one for a paraboloid, the centre (twice) for a
        sphere, none otherwise. A camera at one focus of an ellipsoid or
        hyperboloid sees the world from the other: the configuration is central."""
        A, B, C = self.A, self.B, self.C
        kind = self.kind
        if kind == "paraboloid":
            # x^2 + y^2 = -B (z - C/B): focal length f with 4 f = -B (opening to +z when B < 0)
            zv = C / B
            return (np.array([0.0, 0.0, zv - B / 4.0]),)
        if kind in ("sphere", "ellipsoid", "hyperboloid"):
            z0 = -B / (2 * A)
            K = C + B * B / (4 * A)  # x^2 + y^2 + A (z - z0)^2 = K
            # semi-axis across: a^2 = K (ellipsoid) or -K (hyperboloid); along: c^2 = |K / A|
            c2 = abs(K / A)
            a2 = abs(K)
            if kind == "hyperboloid":
                f = np.sqrt(a2 + c2)
            else:
                if c2 < a2 - 1e-15 * a2:
                    return ()  # oblate ellipsoid: the foci form a ring, not on the axis
                f = np.sqrt(max(c2 - a2, 0.0))
            return (np.array([0.0, 0.0, z0 - f]), np.array([0.0, 0.0, z0 + f]))
        return ()

    # ------------------------------------------------------------- constructors
    @classmethod
    def sphere(cls, radius, z_min, z_max, *, center_z=0.0) -> "QuadricMirror":
        """Sphere of ``radius`` centred at ``(0, 0, center_z)``."""
        r = _length(radius, "radius")
        z0 = as_scalar(center_z, "center_z")
        return cls(1.0, -2.0 * z0, r * r - z0 * z0, z_min, z_max)

    @classmethod
    def ellipsoid(cls, a, c, z_min, z_max, *, center_z=0.0) -> "QuadricMirror":
        """Ellipsoid with semi-axis ``a`` across the axis and ``c`` along it, centred at ``center_z``
        (prolate when c > a: foci at ``center_z +- sqrt(c^2 - a^2)``)."""
        a = _length(a, "a")
        c = _length(c, "c")
        z0 = as_scalar(center_z, "center_z")
        A = (a / c) ** 2
        return cls(A, -2.0 * A * z0, a * a - A * z0 * z0, z_min, z_max)

    @classmethod
    def ellipsoid_from_foci(cls, z_focus1, z_focus2, a, z_min, z_max) -> "QuadricMirror":
        """Prolate ellipsoid with foci on the axis at ``z_focus1``, ``z_focus2`` and semi-axis ``a`` across."""
        f1 = as_scalar(z_focus1, "z_focus1")
        f2 = as_scalar(z_focus2, "z_focus2")
        a = _length(a, "a")
        if f1 == f2:
            raise CatadioptricError(f"z_focus1, z_focus2: expected two distinct foci, got both {f1!r}")
        f = abs(f2 - f1) / 2
        return cls.ellipsoid(a, float(np.hypot(a, f)), z_min, z_max, center_z=(f1 + f2) / 2)

    @classmethod
    def hyperboloid(cls, a, c, z_min, z_max, *, center_z=0.0) -> "QuadricMirror":
        """Two-sheet hyperboloid ``(z - center_z)^2 / c^2 - (x^2 + y^2) / a^2 = 1``
        (foci at ``center_z +- sqrt(a^2 + c^2)``, vertices at ``center_z +- c``)."""
        a = _length(a, "a")
        c = _length(c, "c")
        z0 = as_scalar(center_z, "center_z")
        A = -((a / c) ** 2)
        return cls(A, -2.0 * A * z0, -a * a - A * z0 * z0, z_min, z_max)

    @classmethod
    def hyperboloid_from_foci(cls, z_focus1, z_focus2, c, z_min, z_max) -> "QuadricMirror":
        """Two-sheet hyperboloid with foci at ``z_focus1``, ``z_focus2`` and vertices ``c`` from the centre."""
        f1 = as_scalar(z_focus1, "z_focus1")
        f2 = as_scalar(z_focus2, "z_focus2")
        c = _length(c, "c")
        f = abs(f2 - f1) / 2
        if not c < f:
            raise CatadioptricError(f"c: a hyperboloid needs c < half the focal distance {f!r}, got {c!r}")
        return cls.hyperboloid(float(np.sqrt(f * f - c * c)), c, z_min, z_max, center_z=(f1 + f2) / 2)

    @classmethod
    def paraboloid(cls, focal_length, z_min, z_max, *, vertex_z=0.0, opening=+1) -> "QuadricMirror":
        """Paraboloid ``x^2 + y^2 = 4 f opening (z - vertex_z)``, focus at ``vertex_z + opening f``."""
        f = _length(focal_length, "focal_length")
        zv = as_scalar(vertex_z, "vertex_z")
        if isinstance(opening, (bool, np.bool_)) or opening not in (1, -1):
            raise CatadioptricError(f"opening: expected +1 (opens to +z) or -1, got {opening!r}")
        return cls(0.0, -4.0 * f * opening, -4.0 * f * opening * zv, z_min, z_max)

    @classmethod
    def cone(cls, half_angle, z_min, z_max) -> "QuadricMirror":
        """Cone with apex at the origin, ``x^2 + y^2 = tan(half_angle)^2 z^2`` (half_angle in radians)."""
        h = as_scalar(half_angle, "half_angle", positive=True)
        if not h < np.pi / 2:
            raise CatadioptricError(f"half_angle: expected an angle in (0, pi/2) radians, got {h!r}")
        return cls(-np.tan(h) ** 2, 0.0, 0.0, z_min, z_max)

    @classmethod
    def cylinder(cls, radius, z_min, z_max) -> "QuadricMirror":
        r = _length(radius, "radius")
        return cls(0.0, 0.0, r * r, z_min, z_max)

    def to_dict(self) -> dict:
        return {"A": self.A, "B": self.B, "C": self.C, "z_min": self.z_min, "z_max": self.z_max}
