"""The scene's scale in the two-view refinement (catadioptric.pose.scale): the free fit where the
pixels tell the scale, otherwise the fit with the scene held far, scaled to the free fit's length."""
import numpy as np
import pytest

from catadioptric._checks import CatadioptricError
from catadioptric.pose import relative_pose, rotation_angle_deg
from catadioptric.pose import scale as scale_mod
from catadioptric.pose.scale import FAR, refine_far_or_free

from test_relative_pose import _pair


def _spy(monkeypatch):
    """Record every refine_two_view call refine_far_or_free makes: (kwargs, fit)."""
    calls = []
    real = scale_mod.refine_two_view

    def spy(*args, **kwargs):
        fit = real(*args, **kwargs)
        calls.append((dict(kwargs), fit, args))
        return fit

    monkeypatch.setattr(scale_mod, "refine_two_view", spy)
    return calls


def _length(fit, ca, cb):
    return float(np.linalg.norm(fit.R @ ca + fit.t - cb))


def test_exact_pixels_keep_the_free_fit(monkeypatch):
    """The far fit misses exact pixels by the rig's non-centrality: the gap, in units of the
    pixels' own noise, is far beyond tau and the answer is the free fit (exact)."""
    calls = _spy(monkeypatch)
    va, vb, R_gt, t_gt = _pair("hyperboloid")
    res = relative_pose(va, vb)
    fit = res.candidates[0].fit
    assert not fit.scale_held and fit.far_gap > 1e6
    assert np.radians(rotation_angle_deg(res.R @ R_gt.T)) < 1e-9 and np.linalg.norm(res.t - t_gt) < 1e-9
    # both fits were made: the free one, then the far one held at FAR mirror sizes
    held = [(kw, f, a) for kw, f, a in calls if kw.get("hold_scale")]
    assert held and len(calls) == 2 * len(held)
    kw, f, _ = held[0]
    ca, cb = kw["centres"]
    assert _length(f, ca, cb) == pytest.approx(FAR * va.cam.mirror.scale, rel=1e-12)


def test_the_far_fit_is_scaled_to_the_free_fit_s_length(monkeypatch):
    """Box scene, hyperbolic rig 7 mm off the focus, 2 px: the far fit's cost is the lower (the
    scale is not told), so the answer is its rotation, with the free fit's baseline length and the
    lines moved with it."""
    calls = _spy(monkeypatch)
    va, vb, R_gt, t_gt = _pair("hyperboloid", noise=2.0, seed=4)
    res = relative_pose(va, vb)
    fit = res.candidates[0].fit
    assert fit.scale_held and fit.far_gap < -scale_mod.TAU
    (kw_free, free, _), (kw_held, held, _) = calls[-2:]
    assert kw_held.get("hold_scale") and not kw_free.get("hold_scale")
    ca, cb = kw_held["centres"]
    assert np.array_equal(fit.R, held.R)
    assert _length(fit, ca, cb) == pytest.approx(_length(free, ca, cb), rel=1e-12)
    # the baseline's direction is the far fit's
    d = lambda f: (f.R @ ca + f.t - cb) / _length(f, ca, cb)
    assert np.allclose(d(fit), d(held), atol=1e-12)
    # each line's point is nearest A's origin, on the far line scaled about c_A
    s = fit.directions[fit.line_family]
    assert np.max(np.abs(np.sum(fit.points * s, axis=1))) < 1e-9
    r = _length(free, ca, cb) / _length(held, ca, cb)
    scaled = ca + r * (held.points - ca)
    assert np.max(np.linalg.norm(np.cross(fit.points - scaled, s), axis=1)) < 1e-9 * np.max(np.linalg.norm(scaled, axis=1))
    # the baseline length's deviation is the free fit's
    u = d(fit)
    assert u @ fit.cov[3:, 3:] @ u == pytest.approx(u @ free.cov[3:, 3:] @ u, rel=1e-9)


@pytest.mark.parametrize("kwargs, error, match", [
    ({"far": 0.0}, CatadioptricError, r"far: expected a positive number, got 0\.0"),
    ({"tau": -1.0}, CatadioptricError, r"tau: expected a cost difference of at least 0, got -1\.0"),
    ({"hold_scale": True}, TypeError, "hold_scale is set by the function itself"),
    ({"release_scale": 0.1}, TypeError, "release_scale is set by the function itself"),
])
def test_bad_arguments_are_named(kwargs, error, match):
    z = np.zeros((3, 3))
    with pytest.raises(error, match=match):
        refine_far_or_free(None, None, np.eye(3), np.zeros(3), z, z, [0, 1, 2], z[:, :2], [0, 1, 2], z[:, :2],
                           [0, 1, 2], centres=(np.zeros(3), np.zeros(3)), **kwargs)
