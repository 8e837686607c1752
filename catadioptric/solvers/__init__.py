"""Polynomial kernels and the reflection-point solvers behind projection and vanishing points.

``select_solver`` picks the solver of lowest degree that applies to a mirror and
a camera position (docs/solvers.md has the table):

=================  ======  =========================================================
solver             degree  applies to
=================  ======  =========================================================
central            2       camera at a focus of an ellipsoid or two-sheet hyperboloid
cone_axial         2       cone, camera on the axis
cylinder_axial     2       cylinder, camera on the axis
sphere             4       sphere, any camera position
paraboloid_axial   5 (4)   paraboloid, camera on the axis (4 for directions)
axial              6       any quadric, camera on the axis
general            8       any quadric, any camera position
=================  ======  =========================================================
"""
from __future__ import annotations

import numpy as np

from .axial import AxialSolver, ConeSolver, CylinderSolver, ParaboloidSolver
from .central import CentralSolver
from .general import GeneralSolver
from .sphere import SphereSolver

SOLVERS = {cls.name: cls for cls in (CentralSolver, ConeSolver, CylinderSolver, SphereSolver, ParaboloidSolver,
                                    AxialSolver, GeneralSolver)}

__all__ = ["select_solver", "on_axis", "SOLVERS"]


def on_axis(mirror, center) -> bool:
    """True when ``center`` lies on the mirror's axis to rounding: its distance from the axis is
    below 1e-12 of the larger of the mirror's scale and its distance from the origin (relative,
    so that the answer does not depend on the length unit)."""
    c = np.asarray(center, float)
    return bool(np.hypot(c[0], c[1]) <= 1e-12 * max(mirror.scale, float(np.max(np.abs(c)))))


def select_solver(mirror, center, *, viewpoint=None, force: str | None = None):
    """The solver for a :class:`~catadioptric.mirrors.QuadricMirror` seen from ``center``.

    ``viewpoint``: the single viewpoint when the configuration is central.
    ``force``: a solver name from :data:`SOLVERS` (for tests and benchmarks); it must apply.
    """
    args = (mirror.A, mirror.B, mirror.C, mirror.z_min, mirror.z_max, np.asarray(center, float), mirror.scale)
    axial = on_axis(mirror, center)
    kind = mirror.kind
    if force is not None:
        if force == "central":
            if viewpoint is None:
                raise ValueError("solver 'central' needs a central configuration")
            return CentralSolver(*args, viewpoint)
        if force in ("axial", "paraboloid_axial", "cylinder_axial", "cone_axial") and not axial:
            raise ValueError(f"solver {force!r} needs a camera on the axis")
        return SOLVERS[force](*args)
    if viewpoint is not None:
        return CentralSolver(*args, viewpoint)
    if kind == "sphere":
        return SphereSolver(*args)
    if axial:
        if kind == "cone":
            return ConeSolver(*args)
        if kind == "cylinder":
            return CylinderSolver(*args)
        if kind == "paraboloid":
            return ParaboloidSolver(*args)
        return AxialSolver(*args)
    return GeneralSolver(*args)
