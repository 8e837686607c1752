"""Pose of a catadioptric rig from lines: absolute (world lines known) and relative (two views).

Conventions (docs/conventions.md): a world point has mirror coordinates ``x_M = R x_W + t``;
between two views ``x_B = R x_A + t`` (mirror frames). Lines are Pluecker ``(s, m)`` with
``m = q x s``. Rotation covariances are those of the left rotation vector ``R(w) = exp([w]_x) R``.

| solver | module | input | output |
|---|---|---|---|
| `rotation_from_directions` | `rotation.py` | matched directions (signs known), weights | R (orthogonal Procrustes) |
| `refine_rotation` | `rotation.py` | matched directions with covariances | R, covariance, robust per-direction chi2 |
| `sign_candidates` | `signs.py` | directions known up to sign | the sign patterns a rotation fits, refined |
| `translation_from_lines` | `translation.py` | R, world lines, rays of their pixels | t (absolute pose) |
| `relative_translation_from_lines` | `translation.py` | R, lines fitted in each view, rays of both | t (metric, non-central) |
| `refine_two_view` | `bundle.py` (its unknowns and image residuals: `two_view_problem.py`; its first-order residuals, the default: `two_view_rays.py`) | `TwoViewData` (cameras, pixels of both views, their lines' families), `TwoViewStart` (R, t, lines), `TwoViewOptions` | R, t, lines, covariance (non-central) |
| `refine_far_or_free` | `scale.py` | as `refine_two_view`, `ScaleOptions` | its fit with the scene held far (the rig's central limit), or free where the pixels fix the scale |
| `translation_direction_from_crossings` | `central.py` | R, planes of the lines matched in both views | direction between the views' centres |
| `refine_with_crossings` | `epipolar.py` | directions with covariances, inlier meeting rays, R | R and the direction between the centres refined together, covariance |
| `family_matches` | `matching.py` | each view's families (unmatched) | the assignments of B's families to A's a rotation allows |
| `match_lines` | `matching.py` | a family assignment, each view's lines (unmatched) | lines matched where they meet, direction between the centres |
| `static_rotation` | `static.py` | each view's families (unmatched), candidate rotations | the rotation of a camera turned in place, from the lines it sees again unchanged, or None |
| `relative_pose` | `relative.py` (checks, then one of the two below) | the lines each view sees (matched by id, or not) | R, t, covariance, candidates, ambiguity verdict |
| `labelled_pose` | `labelled.py` | the lines each view sees, matched by id; `PoseOptions` | as `relative_pose` |
| `unlabelled_pose` | `unlabelled.py` | the lines each view sees, matched by nothing; `PoseOptions` | families and lines matched, then `labelled_pose`; the evidence that decided |
| `matching_bar` | `unlabelled.py` | the number of family assignments tried without labels | the margin an answer needs |
| `chessboard_pose` | `chessboard.py` | an image of a chessboard (OpenCV's detector), a central camera | the board's R, t, covariance, its families' directions and vanishing points (the paper's Sec. 5.3; `catadioptric absolute-pose`) |
| `choose_model` | `select.py` | the exact and the central answer of one pair | the rotation whose covariance promises less |

See docs/relative_pose.md.
"""
from __future__ import annotations

from .bundle import TwoViewData, TwoViewFit, TwoViewOptions, TwoViewStart, refine_two_view
from .chessboard import ChessboardPose, chessboard_pose, compare_board_poses
from .central import CrossingFit, translation_direction_from_crossings
from .epipolar import EpipolarFit, refine_with_crossings
from .families import FamilyEstimate, ViewLines, fit_view_families
from .matching import FamilyMatch, LineMatch, family_matches, match_lines
from .labelled import PoseOptions, labelled_pose
from .relative import MATCHING_BARS, Candidate, RelativePose, matching_bar, relative_pose
from .scale import ScaleOptions, refine_far_or_free
from .select import ModelChoice, choose_model
from .rotation import DirectionRotation, refine_rotation, rotation_angle_deg, rotation_from_directions
from .signs import SignCandidate, sign_candidates
from .static import StaticRotation, static_rotation
from .translation import relative_translation_from_lines, translation_from_lines
from .unlabelled import unlabelled_pose

__all__ = [
    "rotation_from_directions", "rotation_angle_deg", "refine_rotation", "DirectionRotation",
    "sign_candidates", "SignCandidate", "translation_from_lines", "relative_translation_from_lines",
    "refine_two_view", "TwoViewData", "TwoViewStart", "TwoViewOptions", "TwoViewFit", "refine_far_or_free",
    "ScaleOptions", "translation_direction_from_crossings", "CrossingFit",
    "refine_with_crossings", "EpipolarFit",
    "ViewLines", "FamilyEstimate", "fit_view_families", "relative_pose", "RelativePose", "Candidate",
    "matching_bar", "MATCHING_BARS", "labelled_pose", "unlabelled_pose", "PoseOptions",
    "family_matches", "FamilyMatch", "match_lines", "LineMatch", "choose_model", "ModelChoice",
    "chessboard_pose", "ChessboardPose", "compare_board_poses", "static_rotation", "StaticRotation",
]
