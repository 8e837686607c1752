"""Preset catadioptric rigs: the four configurations of the paper's experiments and a few more.

Lengths in metres. The paper (Miraldo, Eiras, Ramalingam, CVPR 2018) does not
publish its simulated mirrors' dimensions; these presets use mirrors of the
size of commercial catadioptric heads (a few centimetres) and state where each
number comes from. ``preset(name)`` builds a :class:`CatadioptricCamera`.
"""
from __future__ import annotations

import numpy as np

from ._checks import CatadioptricError
from .cameras import CatadioptricCamera, PinholeCamera
from .mirrors import QuadricMirror

__all__ = ["PRESETS", "preset", "preset_names"]


def _pin(width=640, height=480, fov=40.0):
    return PinholeCamera.from_fov(width, height, fov)


def _sphere(offset=(0.0, 0.0), width=640, height=480):
    # upper cap of a 5 cm sphere seen from 25 cm above (non-central, axial when offset = 0)
    m = QuadricMirror.sphere(0.05, z_min=0.015, z_max=0.05)
    c = np.array([offset[0], offset[1], 0.25])
    return CatadioptricCamera.looking_at_mirror(m, _pin(width, height, 26.0), c, target=(0, 0, 0.03))


def _ellipsoid(offset=(0.0, 0.0, 0.0), width=640, height=480):
    # concave prolate ellipsoid (a = 4 cm, c = 6 cm): foci at z = -+4.47 cm; the camera near the
    # lower focus sees the upper cap from inside; the cap starts above the upper focus so that the
    # reflected rays, which cross that focus, leave through the open bottom
    m = QuadricMirror.ellipsoid(0.04, 0.06, z_min=0.048, z_max=0.06)
    f = m.foci[0]
    c = f + np.asarray(offset, dtype=float)
    return CatadioptricCamera.looking_at_mirror(m, _pin(width, height, 36.0), c, target=(0, 0, 0.06))


def _hyperboloid(offset=(0.0, 0.0, 0.0), width=640, height=480):
    # two-sheet hyperboloid a = 3 cm, c = 4 cm (foci at z = -+5 cm); upper sheet patch, camera near
    # the lower (outer) focus: central there, non-central when offset
    m = QuadricMirror.hyperboloid(0.03, 0.04, z_min=0.04, z_max=0.075)
    c = m.foci[0] + np.asarray(offset, dtype=float)
    return CatadioptricCamera.looking_at_mirror(m, _pin(width, height, 54.0), c, target=(0, 0, 0.06))


def _paraboloid(width=640, height=480):
    # convex side of a paraboloid opening to +z (focal length 1.5 cm) seen by a perspective
    # camera 30 cm below the vertex
    m = QuadricMirror.paraboloid(0.015, z_min=0.0, z_max=0.02, vertex_z=0.0, opening=+1)
    return CatadioptricCamera.looking_at_mirror(m, _pin(width, height, 20.0), (0.0, 0.0, -0.30),
                                                target=(0, 0, 0.01))


def _cone(width=640, height=480):
    # cone of half-angle 35 degrees, apex up at the origin, patch 1-5 cm below the apex, camera
    # 25 cm above the apex on the axis
    m = QuadricMirror.cone(np.radians(35.0), z_min=-0.05, z_max=-0.01)
    return CatadioptricCamera.looking_at_mirror(m, _pin(width, height, 20.0), (0.0, 0.0, 0.25),
                                                target=(0, 0, -0.03))


# The paper's four simulated configurations (Sec. 5.1, Fig. 5 and 6): spherical, ellipsoidal and
# hyperbolic non-central cameras and a central hyperbolic one. Its real rig is a hyperbolic mirror
# with the camera "about 9 % away from the central configuration" (Sec. 5.5): 9 % of the focal
# distance 2 f = 10 cm gives the 9 mm offset of "hyperboloid_9pct".
PRESETS = {
    "sphere": lambda **k: _sphere((0.004, 0.003), **k),
    "sphere_axial": lambda **k: _sphere((0.0, 0.0), **k),
    "ellipsoid": lambda **k: _ellipsoid((0.003, 0.002, -0.004), **k),
    "ellipsoid_central": lambda **k: _ellipsoid((0.0, 0.0, 0.0), **k),
    "hyperboloid": lambda **k: _hyperboloid((0.004, 0.0, -0.006), **k),
    "hyperboloid_9pct": lambda **k: _hyperboloid((0.009, 0.0, 0.0), **k),
    "hyperboloid_central": lambda **k: _hyperboloid((0.0, 0.0, 0.0), **k),
    "paraboloid": _paraboloid,
    "cone": _cone,
}


def preset_names() -> list[str]:
    return sorted(PRESETS)


def preset(name: str, *, width: int = 640, height: int = 480) -> CatadioptricCamera:
    """The preset rig ``name`` (see :data:`PRESETS`) with an image of ``width`` x ``height`` pixels."""
    try:
        build = PRESETS[name]
    except KeyError:
        raise CatadioptricError(f"name: expected one of {preset_names()}, got {name!r}") from None
    return build(width=width, height=height)
