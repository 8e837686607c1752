"""Relative pose of two views of one rig (or two rigs) from the pixels of families of parallel
lines: rotation and, for a non-central rig, metric translation, with covariance and an explicit
verdict when the answer is ambiguous.

The front door, :func:`relative_pose`: it checks its arguments (:class:`PoseOptions`) and sends
the views to one of two paths (docs/relative_pose.md):

* lines matched across the views by ``line_id``: :func:`~catadioptric.pose.labelled.labelled_pose`
  (each view's families, the rotation candidates their signs allow, where lines meet, the
  refinement on the pixels of both views, the verdict; its module docstring lists the steps);
* lines matched by nothing (each image's own detections):
  :func:`~catadioptric.pose.unlabelled.unlabelled_pose` matches the families and lines first
  ("Without labels"), then takes the labelled path.
"""
from __future__ import annotations

from .._checks import CatadioptricError
from .families import ViewLines, is_central
from .labelled import MIN_MEETINGS, WEAK_BAR_PER_PIXEL, Candidate, PoseOptions, RelativePose, labelled_pose
from .unlabelled import MATCHING_BARS, matching_bar, unlabelled_pose

__all__ = ["Candidate", "RelativePose", "relative_pose", "matching_bar", "MATCHING_BARS", "MIN_MEETINGS",
           "WEAK_BAR_PER_PIXEL", "PoseOptions"]


def relative_pose(view_a: ViewLines, view_b: ViewLines, *, ends: dict | None = None, seed=0, f_scale: float = 1.0,
                  pixel_sigma: float | None = None, decisive: float = 25.0, max_pixels: int | None = 40,
                  min_families: int = 2, max_rotation_deg: float | None = None,
                  model_error_px: float = 0.0, decisive_matching: float | None = None,
                  calibration_rms_px: float = 0.0, threads: int = 2, residuals: str = "first_order") -> RelativePose:
    """The relative pose ``x_B = R x_A + t`` of two views from the lines they see.

    ``view_a``, ``view_b``: :class:`ViewLines`. ``ends``: ``{family: (hint_a, hint_b)}``, for
    each family a direction in each view's mirror frame pointing to the same end (matched
    vanishing points, e.g. ``cam.directions_from_vanishing_points``); then the signs are
    known and nothing is searched. ``f_scale``: pixel scale of the robust losses;
    ``pixel_sigma``: known pixel noise (default: estimated). ``decisive``: the margin (chi-square
    units) the best candidate needs over the second. ``max_pixels``: pixels per line and view
    used (evenly spaced). ``max_rotation_deg``: a prior on the motion (views a short walk apart,
    frames of a video): candidates that turn by more than this are not considered; the symmetric
    answers of a Manhattan scene (half-turns, quarter-turns) are then ruled out by the prior
    rather than by the lines, and the notes say so. ``model_error_px``: the camera model's own
    error in pixels (e.g. the rms of the best central approximation of a non-central rig): an
    error the pixels of a line share, added to the planes' covariances so that a model that does
    not fit exact pixels is not trusted beyond its own precision. ``calibration_rms_px``: a
    calibrated camera's reprojection rms in pixels, as its calibration tool reports it (0: an exact
    model, as a rendered rig's): an error the lines of a family share, added across each family's
    direction (:func:`~catadioptric.pose.families.fit_view_families`), so that the rotation does not
    lean on directions beyond what the calibration knows (docs/cameras.md). ``decisive_matching``: when
    nothing is matched across the views (no ``line_id``: each image's own detections), the margin
    the best assignment of families and lines needs over the next different answer (at least
    ``decisive``; None: :func:`matching_bar` of the number of family assignments tried, 25 for at
    most 24 and 40 beyond): the matching's cost counts meeting points that agree by chance, and
    the more rival assignments, the larger the chance margin: on the relative-pose benchmark and on
    100 held-out pairs, wrong answers won by up to 10.2 units among at most 24 assignments and by up
    to 29.7 among more, counting the smaller of the matching's margin and its margin by the RANSAC's
    matchings alone, which both must reach the bar (docs/relative_pose.md, "The bar on the matching"). Raises :class:`CatadioptricError` naming the
    cause when fewer than ``min_families`` families are seen in both views, or when no candidate
    is within ``max_rotation_deg``. ``threads``: a non-central rig's two refinements (the scene free
    and held far, :func:`~catadioptric.pose.scale.refine_far_or_free`) side by side in two threads
    (the same answers, sooner with a core to spare), or one after the other (1: for a process among
    others that keep every core busy, as the benchmark's workers). ``residuals``: those of a
    non-central rig's two-view refinement (:attr:`~catadioptric.pose.bundle.TwoViewOptions.residuals`):
    "first_order" (each pixel's first-order image distance to its line, from its ray) or "image"
    (the exact images): the same rotations and translation directions on the relative-pose
    benchmark, the first in 0.6-0.8 times the time, the second with the better metric
    length where the pixels tell it at all (the sphere at 1 px, in one run: a median length error
    of 2.8 m against 5.7 m; docs/relative_pose.md, "How good it is").
    """
    from threadpoolctl import threadpool_limits

    if not isinstance(view_a, ViewLines) or not isinstance(view_b, ViewLines):
        raise CatadioptricError(f"view_a, view_b: expected ViewLines, got {type(view_a).__name__} and "
                                f"{type(view_b).__name__}")
    opts = PoseOptions(seed, f_scale, pixel_sigma, decisive, max_pixels, min_families, max_rotation_deg,
                       model_error_px, decisive_matching, calibration_rms_px, threads=threads,
                       residuals=residuals).checked()
    if is_central(view_a.cam) != is_central(view_b.cam):
        raise CatadioptricError("view_a, view_b: expected two central or two non-central cameras, got one of each")
    unmatched = all(i is None for i in view_a.line_id) or all(i is None for i in view_b.line_id)
    if unmatched and ends is not None:
        raise CatadioptricError("ends: the ends of families can only be given for families matched across "
                                "the views; these views' lines carry no line_id (nothing is matched)")
    # every linear solve here is small: a multithreaded BLAS only fights other work for the cores
    with threadpool_limits(1):
        res = unlabelled_pose(view_a, view_b, opts) if unmatched else labelled_pose(view_a, view_b, ends, opts)
    if opts.calibration_rms_px:
        res.notes = [*res.notes, f"each family's direction carries the calibration's rms, {opts.calibration_rms_px:g} "
                                 f"px, beyond its fit (an error its lines share)"]
    return res
