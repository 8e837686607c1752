"""The scene's scale in the two-view refinement (catadioptric.pose.scale): the free fit where the
pixels tell the scale, otherwise the fit with the scene held far, scaled to the free fit's length."""
import re
from dataclasses import replace

import numpy as np
import pytest

from catadioptric._checks import CatadioptricError
from catadioptric.pose import relative_pose, rotation_angle_deg
from catadioptric.pose import scale as scale_mod
from catadioptric.pose.bundle import TwoViewData, TwoViewOptions, TwoViewStart
from catadioptric.pose.scale import FAR, ScaleOptions, refine_far_or_free

from test_relative_pose import _pair


def _spy(monkeypatch):
    """Record every refine_two_view call refine_far_or_free makes: (options, fit, data, start)."""
    calls = []
    real = scale_mod.refine_two_view

    def spy(data, start, options):
        fit = real(data, start, options)
        calls.append((options, fit, data, start))
        return fit

    monkeypatch.setattr(scale_mod, "refine_two_view", spy)
    return calls


def _free_and_held(calls):
    """The last refine_far_or_free's two calls, the free one first (the far one runs in a thread of
    its own and may finish first)."""
    return sorted(calls[-2:], key=lambda c: c[0].hold_scale)


def _length(fit, ca, cb):
    return float(np.linalg.norm(fit.R @ ca + fit.t - cb))


@pytest.fixture(scope="module")
def exact():
    """The box scene's hyperbolic pair with exact pixels, its pose and every refine_two_view call
    made for it (computed once: the tests below read them, none changes them)."""
    with pytest.MonkeyPatch.context() as mp:
        calls = _spy(mp)
        va, vb, R_gt, t_gt = _pair("hyperboloid")
        res = relative_pose(va, vb)
    return va, vb, R_gt, t_gt, res, calls


def test_exact_pixels_keep_the_free_fit(exact):
    """The far fit misses exact pixels by the rig's non-centrality: in units of the pixels' own
    noise (the free fit's estimate, 1e-13 px: rounding) nearly every pixel is beyond the cap of
    the common-ground cost, the gap is far beyond tau and the answer is the free fit (exact). The
    gap itself is not pinned: the free fit's own distances, recomputed by Gauss-Newton on each
    depth, sit at that same rounding floor, some beyond the cap."""
    va, vb, R_gt, t_gt, res, calls = exact
    fit = res.candidates[0].fit
    (_, free, _, _), (_, held, data, _) = _free_and_held(calls)
    d_held = scale_mod.pixel_distances(held, data.cam_a, data.cam_b, data.uv_a, data.owner_a, data.uv_b, data.owner_b)
    assert np.mean(d_held > 3.5 * free.sigma) > 0.99 and free.sigma < 1e-9
    assert not fit.scale_held and fit.far_gap > 1000 * scale_mod.TAU
    assert np.radians(rotation_angle_deg(res.R @ R_gt.T)) < 1e-9 and np.linalg.norm(res.t - t_gt) < 1e-9
    # both fits were made: the free one, then the far one held at FAR mirror sizes
    held = [(o, f, d) for o, f, d, _ in calls if o.hold_scale]
    assert held and len(calls) == 2 * len(held)
    _, f, data = held[0]
    ca, cb = data.centres
    assert _length(f, ca, cb) == pytest.approx(FAR * va.cam.mirror.scale, rel=1e-12)


def test_the_far_fit_is_scaled_to_the_free_fit_s_length(monkeypatch):
    """Box scene, hyperbolic rig 7 mm off the focus, 2 px: the free fit explains the pixels no
    better than the far one by tau (the scale is not told), so the answer is the far fit's
    rotation, with the free fit's baseline length and the lines moved with it."""
    calls = _spy(monkeypatch)
    va, vb, R_gt, t_gt = _pair("hyperboloid", noise=2.0, seed=4)
    res = relative_pose(va, vb)
    fit = res.candidates[0].fit
    assert fit.scale_held and fit.far_gap < scale_mod.TAU
    (o_free, free, _, _), (o_held, held, data_held, _) = _free_and_held(calls)
    assert o_held.hold_scale and not o_free.hold_scale
    ca, cb = data_held.centres
    assert np.array_equal(fit.R, held.R)
    assert _length(fit, ca, cb) == pytest.approx(_length(free, ca, cb), rel=1e-12)
    # the baseline's direction is the far fit's
    d = lambda f: (f.R @ ca + f.t - cb) / _length(f, ca, cb)
    assert np.allclose(d(fit), d(held), atol=1e-12)
    # each line's point is nearest A's origin (to rounding: the lines are up to 2e4 m away), on the far
    # line scaled about c_A
    s = fit.directions[fit.line_family]
    assert np.max(np.abs(np.sum(fit.points * s, axis=1))) < 1e-12 * np.max(np.linalg.norm(fit.points, axis=1))
    r = _length(free, ca, cb) / _length(held, ca, cb)
    scaled = ca + r * (held.points - ca)
    assert np.max(np.linalg.norm(np.cross(fit.points - scaled, s), axis=1)) < 1e-9 * np.max(np.linalg.norm(scaled, axis=1))
    # the baseline length's deviation is the free fit's
    u = d(fit)
    assert u @ fit.cov[3:, 3:] @ u == pytest.approx(u @ free.cov[3:, 3:] @ u, rel=1e-9)


def test_a_gap_with_the_length_unknown_keeps_the_far_fit(monkeypatch):
    """The free fit is kept only when its own covariance also tells the scale: box scene,
    hyperbolic rig, 2 px, where the free fit's baseline length has a relative deviation of about 40
    (100 times the bar; where the free fit stops along its flat scale moves it by a tenth).
    With the common-ground gap forced far above tau (as a free fit stopped in another minimum of
    its lines gives it), the answer is still the far fit; it is the free fit only when the bar on
    the length's deviation is lifted above that deviation."""
    va, vb, R_gt, t_gt = _pair("hyperboloid", noise=2.0, seed=4)
    monkeypatch.setattr(scale_mod, "common_gap", lambda *a, **k: 1e6)
    calls = _spy(monkeypatch)
    fit = relative_pose(va, vb).candidates[0].fit
    (_, free, _, _), (_, held, _, _) = _free_and_held(calls)
    assert fit.far_gap == 1e6 and fit.scale_std > 10.0 > 25 * scale_mod.MAX_SCALE_STD
    assert fit.scale_held and np.array_equal(fit.R, held.R)
    real = scale_mod.refine_far_or_free
    monkeypatch.setattr("catadioptric.pose.labelled.refine_far_or_free",
                        lambda data, start, options: real(data, start, replace(options, max_scale_std=1e3)))
    fit = relative_pose(va, vb).candidates[0].fit
    (_, free, _, _), _ = _free_and_held(calls)
    assert not fit.scale_held and np.array_equal(fit.R, free.R)


def test_the_bar_on_the_length_is_the_gap_s_level():
    """``MAX_SCALE_STD`` asks of the length's Wald test what ``TAU`` asks of the likelihood ratio:
    a normal variable beyond sqrt(TAU) deviations is as rare as a chi-square of one degree of
    freedom beyond TAU (99 %)."""
    from scipy.stats import chi2, norm

    assert scale_mod.MAX_SCALE_STD == pytest.approx(1.0 / np.sqrt(scale_mod.TAU), rel=1e-15)
    assert 2 * norm.sf(1.0 / scale_mod.MAX_SCALE_STD) == pytest.approx(chi2.sf(scale_mod.TAU, 1), rel=1e-12)
    assert chi2.sf(scale_mod.TAU, 1) == pytest.approx(0.01, abs=1e-4)


def test_the_two_fits_side_by_side_are_the_fits_one_after_the_other(monkeypatch):
    """``threads=2`` runs the far fit in a thread of its own beside the free one; each fit depends on
    nothing the other does, so the answer is the same to the bit as with ``threads=1`` (one thread,
    one after the other). Box scene, hyperbolic rig, 2 px."""
    import threading

    va, vb, _, _ = _pair("hyperboloid", noise=2.0, seed=4)
    real = scale_mod.refine_two_view
    seen = []

    def spy(data, start, options):
        seen.append((options.hold_scale, threading.get_ident()))
        return real(data, start, options)

    monkeypatch.setattr(scale_mod, "refine_two_view", spy)
    answers = {}
    for threads in (1, 2):
        seen.clear()
        res = relative_pose(va, vb, threads=threads)
        fit = res.candidates[0].fit
        answers[threads] = (res.R, res.t, res.cov, fit.points, fit.far_gap, fit.scale_std, fit.cost)
        idents = {held: ident for held, ident in seen}
        assert sorted(idents) == [False, True]
        assert (idents[True] != idents[False]) == (threads == 2), (threads, seen)
    for a, b in zip(answers[1], answers[2]):
        assert np.array_equal(a, b, equal_nan=True)


@pytest.mark.parametrize("threads, says", [(0, "an integer in [1, 2], got 0"), (3, "an integer in [1, 2], got 3"),
                                           (1.0, "an integer, got 1.0"), ("2", "an integer, got '2'"),
                                           (True, "an integer, got True")])
def test_threads_other_than_one_or_two_are_named(threads, says):
    va, vb, _, _ = _pair("hyperboloid")
    with pytest.raises(CatadioptricError, match="^threads: expected " + re.escape(says) + "$"):
        relative_pose(va, vb, threads=threads)


@pytest.mark.parametrize("options, match", [
    (ScaleOptions(far=0.0), r"far: expected a positive number, got 0\.0"),
    (ScaleOptions(tau=-1.0), r"tau: expected a cost difference of at least 0, got -1\.0"),
    (ScaleOptions(max_scale_std=0.0), r"max_scale_std: expected a positive number, got 0\.0"),
    (ScaleOptions(refine=TwoViewOptions(hold_scale=True)), "options.refine.hold_scale: set by refine_far_or_free itself"),
    (ScaleOptions(refine=TwoViewOptions(release_scale=0.1)),
     "options.refine.release_scale: set by refine_far_or_free itself"),
    (ScaleOptions(threads=0), r"threads: expected an integer in \[1, 2\], got 0"),
])
def test_bad_arguments_are_named(options, match):
    z = np.zeros((3, 3))
    data = TwoViewData(None, None, z[:, :2], [0, 1, 2], z[:, :2], [0, 1, 2], [0, 1, 2],
                       centres=(np.zeros(3), np.zeros(3)))
    with pytest.raises(CatadioptricError, match=match):
        refine_far_or_free(data, TwoViewStart(np.eye(3), np.zeros(3), z, z), options)


def test_the_centres_are_required():
    z = np.zeros((3, 3))
    data = TwoViewData(None, None, z[:, :2], [0, 1, 2], z[:, :2], [0, 1, 2], [0, 1, 2])
    with pytest.raises(CatadioptricError, match=r"data.centres: expected \(c_A, c_B\)"):
        refine_far_or_free(data, TwoViewStart(np.eye(3), np.zeros(3), z, z))


def _exact_fit_and_pixels(exact):
    """The exact two-view fit of the box scene's hyperbolic pair (exact pixels) and the pixels it
    was refined on: ``(fit, cam_a, cam_b, (uv_a, owner_a, uv_b, owner_b))``."""
    *_, res, calls = exact
    fit = res.candidates[0].fit
    d = calls[-2][2]
    return fit, d.cam_a, d.cam_b, (d.uv_a, d.owner_a, d.uv_b, d.owner_b)


def test_pixel_distances_are_those_of_the_pixels_noise(exact):
    """On the exact fit, its inlier pixels lie on their lines' images (to 1e-6 px; the few pixels
    it left out, 80 of 4256, within 0.05 px); with Gaussian noise of 1 px added, each distance is
    the noise across the curve, whose median is 0.674 px."""
    fit, cam_a, cam_b, (uv_a, own_a, uv_b, own_b) = _exact_fit_and_pixels(exact)
    d = scale_mod.pixel_distances(fit, cam_a, cam_b, uv_a, own_a, uv_b, own_b)
    inl = np.concatenate([fit.inliers_a, fit.inliers_b])
    assert d.shape == (len(uv_a) + len(uv_b),) and np.max(d[inl]) < 1e-6 and np.max(d) < 0.05
    assert inl.sum() > 0.95 * len(inl)
    rng = np.random.default_rng(0)
    noisy = [uv + rng.normal(size=uv.shape) for uv in (uv_a, uv_b)]
    d = scale_mod.pixel_distances(fit, cam_a, cam_b, noisy[0], own_a, noisy[1], own_b)
    assert np.median(d) == pytest.approx(0.6745, rel=0.05)


def test_common_gap_scores_both_fits_on_every_pixel(exact):
    """A fit against itself: 0. A fit with one line moved 10 m away: each of that line's pixels
    costs the cap squared, the others nothing more (sigma given)."""
    from dataclasses import replace

    fit, cam_a, cam_b, pix = _exact_fit_and_pixels(exact)
    assert scale_mod.common_gap(fit, fit, cam_a, cam_b, *pix) == 0.0
    s = fit.directions[fit.line_family[0]]
    away = np.cross(s, [0.0, 0.0, 1.0]) if abs(s[2]) < 0.9 else np.cross(s, [1.0, 0.0, 0.0])
    points = fit.points.copy()
    points[0] += 10.0 * away / np.linalg.norm(away)
    moved = replace(fit, points=points)
    n0 = int(np.sum(pix[1] == 0) + np.sum(pix[3] == 0))
    gap = scale_mod.common_gap(fit, moved, cam_a, cam_b, *pix, sigma=1.0, cap=3.5)
    assert n0 > 0 and gap == pytest.approx(3.5 ** 2 * n0, rel=1e-9)


def test_a_start_far_too_long_keeps_every_line_in_front_of_both_views(monkeypatch):
    """The start's length comes from a search a near-central rig can barely guide (on the benchmark
    it ends at its bound of 64 m against true baselines of 2-8 m). Triangulated at that length, the
    planes of a line nearly parallel to the baseline can meet behind a view, where the refinement
    cannot explain a single pixel of it (the line is lost in that view). The start places such a
    line in its plane through A's centre on the side A's rays see instead: every line starts in
    front of both views, near its pixels in both."""
    import catadioptric.pose.labelled as relative_mod
    from catadioptric.pose.translation import ray_depths

    calls = _spy(monkeypatch)
    monkeypatch.setattr(relative_mod, "scale_by_search", lambda *a, **k: 64.0)
    va, vb, R_gt, t_gt = _pair("hyperboloid", noise=1.0, seed=4)
    relative_pose(va, vb)
    _, fit, data, start = next(c for c in calls if not c[0].hold_scale)
    cam_a, cam_b, uv_a, own_a, uv_b, own_b, fam = (data.cam_a, data.cam_b, data.uv_a, data.owner_a, data.uv_b,
                                                   data.owner_b, data.line_family)
    R0, t0, dirs0, points0 = start.R, start.t, start.directions, start.points
    behind = []
    for line in range(len(points0)):
        s = dirs0[fam[line]]
        for view, (cam, uv, own) in enumerate(((cam_a, uv_a, own_a), (cam_b, uv_b, own_b))):
            if not np.any(own == line):
                continue
            r = cam.backproject(uv[own == line])
            o, d = r.origins[r.valid], r.directions[r.valid]
            if view == 1:  # B's rays in A's frame
                o, d = (o - t0) @ R0, d @ R0
            if np.median(ray_depths(points0[line], s, o, d)) <= 0:
                behind.append((line, "AB"[view]))
    assert behind == []


def test_the_residuals_asked_reach_both_refinements(monkeypatch):
    """``relative_pose(residuals=...)`` sets the residuals of both two-view refinements (the free
    and the far one); first-order by default; any other name is refused, named."""
    va, vb, R_gt, t_gt = _pair("hyperboloid", noise=1.0, seed=4)
    calls = _spy(monkeypatch)
    relative_pose(va, vb, residuals="image")
    assert calls and len(calls) % 2 == 0 and {c[0].residuals for c in calls} == {"image"}
    assert {c[0].hold_scale for c in calls} == {True, False}
    calls.clear()
    relative_pose(va, vb)
    assert calls and {c[0].residuals for c in calls} == {"first_order"}
    with pytest.raises(CatadioptricError, match=re.escape("residuals: expected one of 'first_order', 'image', "
                                                          "got 'exact'")):
        relative_pose(va, vb, residuals="exact")
