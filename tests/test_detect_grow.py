"""``detect.grow``: lines grown along their own curves over the image's points."""
from __future__ import annotations

import numpy as np
import pytest

from catadioptric._checks import CatadioptricError
from catadioptric.detect import detect_lines
from catadioptric.detect.curves import LinePiece
from catadioptric.detect.grow import grow_lines
from catadioptric.linefit.planes import pixel_rays_with_jacobian, plane_distances, refine_plane
from catadioptric.rigspec import load_rig


def _curve(cam, a, b):
    """The exact image of segment ``a``-``b``, one point per pixel of arc length, and the unit
    normals across it."""
    li = cam.segment_image(np.asarray(a, float), np.asarray(b, float))
    uv = max((p.uv for x in li for p in x.pieces), key=len)
    uv = uv[np.all(np.isfinite(uv), axis=1)]
    s = np.r_[0, np.cumsum(np.linalg.norm(np.diff(uv, axis=0), axis=1))]
    t = np.arange(0.0, s[-1], 1.0)
    pts = np.stack([np.interp(t, s, uv[:, 0]), np.interp(t, s, uv[:, 1])], 1)
    tan = np.gradient(pts, axis=0)
    tan /= np.linalg.norm(tan, axis=1)[:, None]
    return pts, np.stack([-tan[:, 1], tan[:, 0]], 1)


def _piece(cam, uv):
    rays = pixel_rays_with_jacobian(cam, uv)
    n = refine_plane(rays, np.cross(rays.d[0], rays.d[-1]))
    r = plane_distances(n, rays)
    return LinePiece(uv=uv, rays=rays, normal=n, rms=float(np.sqrt(np.mean(r**2))), sources=[0], polarity=0)


@pytest.fixture(scope="module")
def cam():
    return load_rig("hyperboloid_central", width=320, height=240)


def test_a_line_grows_to_its_whole_curve_and_stops_at_a_gap(cam):
    uv, nrm = _curve(cam, (3.0, -4.0, -1.0), (3.0, 4.0, -1.0))
    other, other_n = _curve(cam, (-3.0, 1.0, -1.5), (-3.0, 1.0, 1.5))  # another line, elsewhere
    M = len(uv)
    assert M > 80
    gap = np.arange(M // 5, M // 5 + 6)  # six pixels the edges lost on one side
    seed = np.arange(2 * M // 5, 3 * M // 5)  # the chain found: the middle fifth
    pool = np.setdiff1d(np.arange(M), gap)
    pts = np.concatenate([uv[pool], other])
    normals = np.concatenate([nrm[pool], other_n])
    piece = _piece(cam, uv[seed])
    (grown,) = grow_lines([piece], pts, normals, pixel_rays_with_jacobian(cam, pts), max_gap=3.0)
    took = np.unique(np.argmin(np.linalg.norm(uv[None] - grown.uv[:, None], axis=2), axis=1))
    assert took.min() == gap[-1] + 1  # not across the six-pixel gap
    assert took.max() == M - 1  # to the curve's end on the other side
    assert len(grown.uv) == M - gap[-1] - 1
    # nothing of the other line, and the refitted plane holds the whole curve
    assert np.min(np.linalg.norm(grown.uv[:, None] - other[None], axis=2)) > 1.0
    assert np.max(plane_distances(grown.normal, pixel_rays_with_jacobian(cam, uv))) < 0.05
    # with a longer bridge, the whole curve
    (whole,) = grow_lines([piece], pts, normals, pixel_rays_with_jacobian(cam, pts), max_gap=8.0)
    assert len(whole.uv) == len(pool)


def test_points_whose_gradient_runs_along_the_curve_are_not_taken(cam):
    uv, nrm = _curve(cam, (3.0, -4.0, -1.0), (3.0, 4.0, -1.0))
    M = len(uv)
    seed = np.arange(2 * M // 5, 3 * M // 5)
    along = np.stack([nrm[:, 1], -nrm[:, 0]], 1)  # turned by 90 degrees: an edge across the curve
    rest = np.setdiff1d(np.arange(M), seed)
    (grown,) = grow_lines([_piece(cam, uv[seed])], uv[rest], along[rest], pixel_rays_with_jacobian(cam, uv[rest]))
    assert len(grown.uv) == len(seed)


def test_two_pieces_of_one_line_grow_into_one(cam):
    uv, nrm = _curve(cam, (3.0, -4.0, -1.0), (3.0, 4.0, -1.0))
    M = len(uv)
    a, b = _piece(cam, uv[: M // 4]), _piece(cam, uv[-M // 4:])
    out = grow_lines([a, b], uv, nrm, pixel_rays_with_jacobian(cam, uv))
    assert len(out) == 1 and len(out[0].uv) == M


def test_bad_points_are_named(cam):
    uv, nrm = _curve(cam, (3.0, -4.0, -1.0), (3.0, 4.0, -1.0))
    with pytest.raises(CatadioptricError, match=r"uv, normal, rays: expected one row per point, got \d+, 3, \d+"):
        grow_lines([_piece(cam, uv[:20])], uv, nrm[:3], pixel_rays_with_jacobian(cam, uv))
    with pytest.raises(CatadioptricError, match="grow_gap_px: expected a number >= 0, got -1.0"):
        detect_lines(np.zeros((240, 320, 3), np.uint8), cam, grow_gap_px=-1.0)
