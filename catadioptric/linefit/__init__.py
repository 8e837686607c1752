"""3-D lines from the pixels of one non-central catadioptric image; families of parallel lines;
vanishing points from image curves.

A non-central camera sees a 3-D line from many viewpoints at once (the reflection
points), so one image fixes the whole line, position included (Miraldo, Eiras,
Ramalingam, CVPR 2018, Sec. 5.4, who found the route brittle). The fit here:

1. **Linear start.** Each pixel's reflected ray, Pluecker ``(d_j, o_j x d_j)``, meets the
   line ``(s, m)``: ``s . (o_j x d_j) + d_j . m = 0``, homogeneous and linear in
   ``(s, m)``. The two smallest right singular vectors span the candidates; the
   Pluecker constraint ``s . m = 0`` on their combination is a quadratic whose two real
   roots are lines meeting every ray. Axial rigs (camera on the mirror axis, and every
   sphere rig: all rays meet the line through the camera and the sphere's centre) have
   that axis as a second exact solution; the candidate with the smaller image error
   is kept. Four pixels are the minimal set (RANSAC).
   Near-central rigs make that system nearly rank-deficient (all rays nearly meet at
   one point); lines in the plane through that point that best holds the rays are
   added as candidates.
2. **Refinement** by ``scipy.optimize.least_squares`` over the line (4 DOF: direction in
   its tangent plane; the foot of the perpendicular from the rays' centre in inverse
   distance coordinates) and one depth per pixel: residual ``project(q + lambda_j s) - uv_j``
   (the image branch nearest the observed pixel), sparse analytic Jacobian from
   Fermat's principle (or finite differences with ``jac_sparsity``).
3. **Robustness**: RANSAC over minimal sets, a robust loss, inliers by image distance,
   then a plain least-squares polish on the inliers so that the reported covariance
   (Schur complement over the depths) describes the estimator actually used.

Central cameras (every ray through one viewpoint) see a line only through its
interpretation plane: its position and its direction within that plane are lost,
and the fits raise :class:`CatadioptricError` (use :func:`fit_interpretation_plane`;
parallel lines still give their direction and vanishing points). See docs/linefit.md.
"""
from __future__ import annotations

from .accuracy import REFERENCE_FAMILIES, REFERENCE_SEGMENTS, accuracy_table
from .central import direction_from_planes, fit_interpretation_plane, fit_interpretation_planes
from .distances import image_distances
from .fits import fit_line, fit_parallel_lines
from .jacobian import project_with_jacobian
from .linear import line_candidates
from .results import CurveVanishingPoints, FamilyFit, InterpretationPlane, LineFit
from .synthetic import family_pixels, segment_pixels
from .vanishing import vanishing_points_from_curves

__all__ = [
    "LineFit", "FamilyFit", "CurveVanishingPoints", "InterpretationPlane",
    "fit_line", "fit_parallel_lines", "vanishing_points_from_curves", "fit_interpretation_plane",
    "fit_interpretation_planes",
    "direction_from_planes",
    "line_candidates", "image_distances", "project_with_jacobian", "segment_pixels", "family_pixels",
    "accuracy_table", "REFERENCE_SEGMENTS", "REFERENCE_FAMILIES",
]
