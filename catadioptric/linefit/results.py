"""What the line fits return: :class:`LineFit`, :class:`FamilyFit`, :class:`CurveVanishingPoints`,
:class:`InterpretationPlane`."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


# --------------------------------------------------------------------------- results
@dataclass
class LineFit:
    """A 3-D line fitted to the pixels of its image (mirror frame M, metres).

    ``direction`` (unit ``s``), ``moment`` (``m = q x s``), ``point`` (``q``, the point of
    the line closest to the origin of M). Per input pixel (M of them): ``depths``
    (``point + depths[j] * direction`` is the point pixel j sees), ``points (M, 3)``,
    ``uv_fit (M, 2)`` (its image, the branch nearest the pixel), ``distances`` (pixels),
    ``inliers`` (bool). ``rms``: root mean square image distance over the inliers.
    ``sigma``: pixel noise used for the covariances (given, or estimated from the
    inlier residuals). ``direction_cov (3, 3)`` (rank 2, tangent to the unit sphere) and
    ``pluecker_cov (6, 6)`` of ``(s, m)``; ``dof`` = inliers - 4 (two residuals and one depth
    per pixel, four line parameters). ``n_hypotheses``: candidate lines scored; ``nfev``:
    residual evaluations of the least-squares stages.
    The direction is oriented from the first inlier's point towards the last one's.
    """

    direction: np.ndarray
    moment: np.ndarray
    point: np.ndarray
    depths: np.ndarray
    points: np.ndarray
    uv_fit: np.ndarray
    distances: np.ndarray
    inliers: np.ndarray
    rms: float
    sigma: float
    direction_cov: np.ndarray
    pluecker_cov: np.ndarray
    dof: int
    n_hypotheses: int = 0
    nfev: int = 0

    @property
    def pluecker(self) -> np.ndarray:
        """``(s, m)`` as a 6-vector."""
        return np.concatenate([self.direction, self.moment])

    @property
    def moment_cov(self) -> np.ndarray:
        return self.pluecker_cov[3:, 3:]

    @property
    def direction_std(self) -> float:
        """Root of the trace of ``direction_cov``: the direction's standard error in radians."""
        return float(np.sqrt(max(np.trace(self.direction_cov), 0.0)))


@dataclass
class FamilyFit:
    """Parallel 3-D lines fitted jointly: one ``direction`` (unit, ``direction_cov (3, 3)``),
    per line a ``moment`` and ``point`` ``(L, 3)``; per line lists (one entry per pixel set)
    of ``depths``, ``points``, ``uv_fit``, ``distances``, ``inliers``. ``rms`` over all inliers,
    ``rms_per_line (L,)``; ``sigma`` as in :class:`LineFit`; ``pluecker_cov (L, 6, 6)`` of each
    line's ``(s, m)``; ``cov`` is the covariance of the (2 + 2 L) parameters of the fit (the
    direction's tangent coordinates, then each line's angle and inverse distance about
    the rays' centre, see ``Problem``) after the Schur complement over the depths;
    ``dof`` = inliers - 2 - 2 L. The direction is oriented as line 0's first inlier to its
    last one."""

    direction: np.ndarray
    moments: np.ndarray
    points: np.ndarray
    depths: list
    line_points: list
    uv_fit: list
    distances: list
    inliers: list
    rms: float
    rms_per_line: np.ndarray
    sigma: float
    direction_cov: np.ndarray
    pluecker_cov: np.ndarray
    cov: np.ndarray
    dof: int
    nfev: int = 0

    @property
    def n_lines(self) -> int:
        return len(self.moments)

    @property
    def direction_std(self) -> float:
        return float(np.sqrt(max(np.trace(self.direction_cov), 0.0)))

    def line(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """``(point, direction)`` of line ``i``."""
        return self.points[i], self.direction


@dataclass
class CurveVanishingPoints:
    """Vanishing points of a family of parallel lines found from their image curves.

    ``direction`` and ``direction_cov`` from the joint fit (``family``). ``uv (K, 2)``,
    ``sign (K,)`` (+1 the point of ``+direction``, -1 of ``-direction``, 0 empty), ``visible``,
    ``in_image`` as :meth:`CatadioptricCamera.vanishing_points` with ``which="both"``.
    ``individual`` holds each line's own fit; ``individual_uv (L, K, 2)`` the vanishing
    point of each individually fitted direction (oriented like the joint one) matched
    to each joint point (same sign, nearest pixel; NaN when that line's curve has none
    there). ``spread_max (K,)`` and ``spread_rms (K,)``: max and rms pixel distance of the
    individual points from the joint one (NaN where none matched). ``uv_cov (K, 2, 2)``:
    the joint point's covariance in pixels, propagated from ``direction_cov``.
    Central cameras: ``family`` is None, ``individual`` holds each curve's
    :class:`InterpretationPlane` and ``individual_uv (L (L - 1) / 2, K, 2)`` the vanishing points
    of each pair of curves (where the two fitted curves cross).
    """

    direction: np.ndarray
    direction_cov: np.ndarray
    uv: np.ndarray
    sign: np.ndarray
    visible: np.ndarray
    in_image: np.ndarray
    uv_cov: np.ndarray
    individual_uv: np.ndarray
    spread_max: np.ndarray
    spread_rms: np.ndarray
    family: FamilyFit | None
    individual: list

    def observable(self) -> np.ndarray:
        """Indices of the vanishing points that are visible and on the image."""
        return np.nonzero(self.visible & self.in_image)[0]


@dataclass
class InterpretationPlane:
    """The plane through a central camera's viewpoint that holds a 3-D line:
    unit ``normal``, ``viewpoint``, ``normal_cov (3, 3)``, ``rms`` (pixels), ``inliers``."""

    normal: np.ndarray
    viewpoint: np.ndarray
    normal_cov: np.ndarray
    rms: float
    distances: np.ndarray
    inliers: np.ndarray


