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

from .fit import UnifiedFit, fit_unified, unified_from_central
from .model import (DEFAULT_DEPTHS, LineImageSamples, UnifiedCamera, UnifiedProjection, UnifiedRays,
                    UnifiedVanishingPoints, conic_from_plane_normal)

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
