"""Families found in two views at once (catadioptric.detect.joint_families): exact line images of
a central rig, each line's plane fitted from its pixels, two views related by a known motion."""
from __future__ import annotations

import numpy as np
import pytest

from catadioptric.detect import DetectedLines, Family
from catadioptric.detect.joint_families import joint_families, with_families
from catadioptric.linefit import fit_interpretation_plane
from catadioptric.pose import rotation_angle_deg
from catadioptric.rigspec import load_rig
from scipy.spatial.transform import Rotation

SMALL = np.array([np.cos(np.radians(30)), np.sin(np.radians(30)), 0.0])  # the two-line family's direction


def _scene(rng):
    """Six vertical lines around the rig, two lines along ``SMALL`` and eight of random
    directions (points in view A's mirror frame)."""
    segs = [((4 * np.cos(a), 4 * np.sin(a), -1.5), (4 * np.cos(a), 4 * np.sin(a), 1.5))
            for a in np.radians([10, 70, 130, 190, 250, 310])]
    across = np.cross([0, 0, 1.0], SMALL)
    segs += [tuple(c + 2.5 * s * SMALL for s in (-1, 1)) for c in (-3.5 * across + [0, 0, -1.2], 4 * across + [0, 0, 1.0])]
    for _ in range(8):
        c = rng.uniform(-1, 1, 3) * [5, 5, 1.5]
        c[:2] += 3.5 * np.sign(c[:2])
        d = rng.normal(size=3)
        segs.append((c - 1.5 * d / np.linalg.norm(d), c + 1.5 * d / np.linalg.norm(d)))
    return [(np.asarray(a, float), np.asarray(b, float)) for a, b in segs]


def _detection(cam, segs, R=np.eye(3), t=np.zeros(3), vertical=range(6)):
    """The lines of ``segs`` seen from a view with ``x = R x_A + t``, as a detection whose one
    family is the vertical lines; returns it and each of its lines' segment index."""
    uv, normals, covs, which = [], [], [], []
    for k, (a, b) in enumerate(segs):
        pts = [p.uv[np.all(np.isfinite(p.uv), axis=1)] for li in cam.segment_image(R @ a + t, R @ b + t)
               for p in li.pieces]
        pts = [p for p in pts if len(p) >= 30]
        if not pts:
            continue
        u = max(pts, key=len)
        fit = fit_interpretation_plane(cam, u, pixel_sigma=0.3, ransac=False)
        uv.append(u)
        normals.append(fit.normal)
        covs.append(fit.normal_cov)
        which.append(k)
    n = len(uv)
    family = np.array([0 if k in vertical else -1 for k in which])
    lines = np.flatnonzero(family == 0).tolist()
    fam = Family(direction=np.array([0, 0, 1.0]), cov=np.eye(3) * 1e-8, lines=lines, pixels=0)
    det = DetectedLines(cam=cam, uv=uv, normal=np.array(normals), normal_cov=np.array(covs), rms=np.zeros(n),
                        polarity=np.zeros(n, int), width=np.zeros(n), family=family, families=[fam],
                        image_size=(cam.pinhole.width, cam.pinhole.height))
    return det, which


@pytest.fixture(scope="module")
def views():
    cam = load_rig("hyperboloid_central", width=640, height=480)
    segs = _scene(np.random.default_rng(3))
    R = Rotation.from_rotvec(np.radians([2.0, -1.0, 12.0])).as_matrix()
    t = np.array([0.4, 2.2, 0.05])
    det_a, wa = _detection(cam, segs)
    det_b, wb = _detection(cam, segs, R, t)
    # the two-line family is seen in both views, and one image alone cannot tell it from chance
    assert {6, 7} <= set(wa) and {6, 7} <= set(wb)
    return cam, segs, R, det_a, wa, det_b, wb


def test_two_lines_in_each_view_make_a_family(views):
    cam, segs, R, det_a, wa, det_b, wb = views
    found = joint_families(det_a, det_b, R, taken_a=det_a.families[0].lines, taken_b=det_b.families[0].lines,
                           rotation_std_deg=0.05, known_directions=[[0, 0, 1.0]])
    assert len(found) == 1
    f = found[0]
    assert np.degrees(np.arccos(min(1.0, abs(f.direction @ SMALL)))) < 0.5
    # both lines in both views; a random line whose plane happens to hold the direction may join
    for lines, w in ((f.lines_a, wa), (f.lines_b, wb)):
        assert {6, 7} <= {w[i] for i in lines} and len(lines) <= 3
    # added to each view as a family of its own, the vertical family untouched
    new_b, idx = with_families(det_b, [(f.lines_b, R @ f.direction)])
    assert idx == [1] and new_b.families[0].lines == det_b.families[0].lines
    assert sorted(new_b.families[1].lines) == sorted(f.lines_b) and all(new_b.family[f.lines_b] == 1)
    assert np.degrees(np.arccos(min(1.0, abs(new_b.families[1].direction @ (R @ SMALL))))) < 0.5


def test_a_wrong_rotation_finds_no_such_family(views):
    cam, segs, R, det_a, wa, det_b, wb = views
    wrong = R @ Rotation.from_rotvec(np.radians([0, 0, 20.0])).as_matrix()
    assert rotation_angle_deg(wrong @ R.T) > 19
    found = joint_families(det_a, det_b, wrong, taken_a=det_a.families[0].lines, taken_b=det_b.families[0].lines,
                           rotation_std_deg=0.05, known_directions=[[0, 0, 1.0]])
    for f in found:
        assert np.degrees(np.arccos(min(1.0, abs(f.direction @ SMALL)))) > 2.0


def test_one_line_seen_twice_is_not_a_second_line(views):
    """Two views from the same place see each line in the same plane: two random lines then agree
    with the direction where their planes meet, in both views, a family of four planes that says
    nothing. Counted over distinct planes it is not significant."""
    cam, segs, R, det_a, wa, det_b, wb = views
    same, w = _detection(cam, segs)
    k = [i for i in range(len(w)) if w[i] >= 8][:2]  # two of the random lines
    taken = [i for i in range(len(w)) if i not in k]
    assert joint_families(det_a, same, np.eye(3), taken_a=taken, taken_b=taken, rotation_std_deg=0.05) == []


def test_a_bad_rotation_is_named(views):
    from catadioptric._checks import CatadioptricError

    cam, segs, R, det_a, wa, det_b, wb = views
    with pytest.raises(CatadioptricError, match=r"R: expected a finite 3x3 rotation, got an array of shape \(2, 2\)"):
        joint_families(det_a, det_b, np.eye(2))
