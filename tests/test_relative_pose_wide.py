"""Relative pose of a wide pair (issue 39, item 1): two views 36 m apart along a street, turned by 85
degrees, see few lines in both views and few of them meet. Where lines meet then cannot tell the
half-turns apart, and neither, on a (near-)central rig, can the pixels of the lines: the answer must be
right or ``ambiguous`` with every candidate listed, never a decisive half-turn
(docs/relative_pose.md, "The verdict at wide baselines")."""
import numpy as np
import pytest

from catadioptric.frames import RigPose
from catadioptric.linefit import segment_pixels
from catadioptric.pose import ViewLines, relative_pose, rotation_angle_deg
from catadioptric.pose.bundle import TwoViewFit
from catadioptric.pose.relative import MIN_MEETINGS, WEAK_BAR_PER_PIXEL
from catadioptric.rigs import preset
from catadioptric.scenes.spec import view_rotation


def _street(seed):
    """Facades on both sides of a street along x: vertical edges, floor lines along the street, roof
    edges across it (three families)."""
    rng = np.random.default_rng(seed)
    segs, fam = [], []
    for side in (-7.0, 7.0):
        x = -60.0
        while x < 60.0:
            w, h = rng.uniform(8, 16), rng.uniform(6, 18)
            for xe in (x, x + w):
                segs.append(((xe, side, 0.0), (xe, side, h)))
                fam.append(2)
                segs.append(((xe, side, h), (xe, side + np.sign(side) * 10, h)))
                fam.append(1)
            for z in [*np.arange(3.0, h, 3.0), h]:
                segs.append(((x, side, z), (x + w, side, z)))
                fam.append(0)
            x += w + rng.uniform(1, 4)
    return [(np.array(a), np.array(b)) for a, b in segs], fam


def _wide_pair(rig, seed=0, noise=2.0, n=60):
    """View A at x = -6 m sees the segments between x = -30 and 16 m, view B at x = 30 m, turned by 85
    degrees, those between 12 and 60 m (what the buildings let each see): three lines in both views,
    two meeting rays (the issue's rendered pair: 10 lines, 12 meeting rays)."""
    cam = preset(rig)
    segs, fam = _street(seed)
    pA = RigPose.from_mirror_in_world(view_rotation(5, 0, 0), [-6.0, -1.5, 2.0])
    pB = RigPose.from_mirror_in_world(view_rotation(90, 0, -2), [30.0, 2.0, 2.4])
    rng = np.random.default_rng(seed)
    views = []
    for pose, (lo, hi) in ((pA, (-30.0, 16.0)), (pB, (12.0, 60.0))):
        uv, fl, ids = [], [], []
        for i, ((a, b), f) in enumerate(zip(segs, fam)):
            if not lo <= 0.5 * (a[0] + b[0]) <= hi:
                continue
            u, _ = segment_pixels(cam, pose.to_mirror(a), pose.to_mirror(b), n)
            if len(u) < 15:
                continue
            uv.append(u + rng.normal(0.0, noise, u.shape))
            fl.append(f)
            ids.append(i)
        views.append(ViewLines(cam, uv, fl, ids))
    return views[0], views[1], pB.R @ pA.R.T


def _right_or_ambiguous(res, R_gt):
    err = rotation_angle_deg(res.R @ R_gt.T)
    assert res.ambiguous or err < 10.0, (err, res.margin, res.notes)
    if res.ambiguous:  # every candidate listed, the right one among them
        assert len(res.candidates) >= 2
        assert min(rotation_angle_deg(c.R @ R_gt.T) for c in res.candidates) < 10.0


def test_a_wide_pair_is_never_a_decisive_half_turn():
    """The non-central rig: before the fix a half-turn (179.5 degrees off) won this pair by 189
    chi-square units on the pixels (179.5 degrees off, decisive). The first stage rests on fewer than
    MIN_MEETINGS meeting rays, so every sign candidate is refined, and the margin must clear the bar
    of a weak first stage (WEAK_BAR_PER_PIXEL per pixel fitted)."""
    va, vb, R_gt = _wide_pair("hyperboloid")
    res = relative_pose(va, vb, max_pixels=None)
    assert res.meeting_rays < MIN_MEETINGS
    assert all(isinstance(c.fit, TwoViewFit) for c in res.candidates)
    assert res.bar == pytest.approx(max(25.0, WEAK_BAR_PER_PIXEL * float(np.sum(res.candidates[0].fit.n_pixels))))
    _right_or_ambiguous(res, R_gt)


def test_a_wide_pair_of_a_central_rig_is_decided_by_its_directions_alone():
    """The central rig has no refinement on the pixels: with few meeting rays its margin is the
    directions' alone, which the half-turns of a street (every family horizontal or vertical) fit
    equally (this pair was ambiguous before the fix too, by a stage-1 margin of 1.7: the test pins the
    rule, the rendered pair of the issue shows its need, validate/NOTES.md)."""
    va, vb, R_gt = _wide_pair("hyperboloid_central")
    res = relative_pose(va, vb)
    assert res.meeting_rays < MIN_MEETINGS
    gaps = [c.direction_cost - res.candidates[0].direction_cost for c in res.candidates[1:]
            if rotation_angle_deg(c.R @ res.R.T) > 5.0]
    assert res.margin == pytest.approx(max(0.0, min(gaps)))
    _right_or_ambiguous(res, R_gt)
