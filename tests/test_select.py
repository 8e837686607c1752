"""pose.choose_model: the rotation whose own covariance promises less, never an ambiguous answer,
never one of two answers that disagree beyond their deviations."""
import numpy as np
import pytest

from catadioptric._checks import CatadioptricError
from catadioptric.pose import RelativePose, choose_model
from catadioptric.pose.rotation import rotation_angle_deg


def _rot(axis, deg):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    a = np.radians(deg)
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K


def _pose(R, std_deg, *, ambiguous=False, model="non-central"):
    cov = np.zeros((6, 6))
    cov[:3, :3] = np.eye(3) * np.radians(std_deg) ** 2 / 3.0  # root of the trace = std_deg
    return RelativePose(R=R, t=np.array([1.0, 0, 0]), cov=cov, metric=model == "non-central", ambiguous=ambiguous,
                        margin=100.0, candidates=[], families=[], lines_matched=0, model=model, sigma_px=1.0)


R0 = _rot([0.2, 1.0, 0.1], 20.0)


def test_the_smaller_claimed_deviation_wins():
    exact = _pose(R0, 0.3)
    central = _pose(_rot([1, 0, 0], 0.2) @ R0, 0.2, model="central")
    assert abs(exact.rotation_std_deg - 0.3) < 1e-12
    pick = choose_model(exact, central)
    assert pick.model == "central" and pick.R is central.R and pick.exact is exact
    assert "central deviation 0.2 deg < exact 0.3 deg" in pick.reason
    assert choose_model(_pose(R0, 0.1), central).model == "exact"
    assert choose_model(exact, None).model == "exact"


def test_no_ambiguous_answer_and_no_disagreement_is_chosen():
    central = _pose(R0, 0.01, model="central")
    assert choose_model(_pose(R0, 0.3, ambiguous=True), central).model == "exact"
    assert choose_model(_pose(R0, 0.3), _pose(R0, 0.01, ambiguous=True, model="central")).model == "exact"
    # 3 degrees apart with deviations of 0.3 and 0.01: one of them is wrong, the exact answer stays
    far = _pose(_rot([0, 0, 1], 3.0) @ R0, 0.01, model="central")
    assert abs(rotation_angle_deg(far.R @ R0.T) - 3.0) < 1e-9
    pick = choose_model(_pose(R0, 0.3), far)
    assert pick.model == "exact" and "one of them is wrong" in pick.reason
    assert choose_model(_pose(R0, 0.3), far, agree_sigma=20.0).model == "central"
    nan = _pose(R0, 0.3)
    nan.cov = None
    assert choose_model(nan, central).model == "exact"


def test_bad_input_is_named():
    with pytest.raises(CatadioptricError, match="exact: expected a RelativePose, got dict"):
        choose_model({}, None)
    with pytest.raises(CatadioptricError, match="central: expected a RelativePose or None, got str"):
        choose_model(_pose(R0, 0.3), "central")
    with pytest.raises(CatadioptricError, match="agree_sigma: expected a positive number, got -1.0"):
        choose_model(_pose(R0, 0.3), None, agree_sigma=-1)
