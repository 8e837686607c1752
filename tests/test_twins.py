"""A chessboard's half-turn twins (catadioptric.pose.twins): the board's lines alone cannot tell its
motion from the motion turned by a half-turn about one of its axes, so an answer whose twin is listed
is ambiguous when the lines are known to be a board's. Synthetic board lines seen by the Mei camera of
../shared/real/mei (its calibration's model), nothing matched across the views, as masked photographs
of a board give them."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from catadioptric.linefit.synthetic import segment_pixels
from catadioptric.models import MeiCamera
from catadioptric.pose import ViewLines, relative_pose, rotation_angle_deg
from catadioptric.pose.twins import TWIN_DEG, flag_twins, half_turn, target_axes, twins

K = np.array([[297.558, 0.0, 643.278], [0.0, 297.850, 520.939], [0.0, 0.0, 1.0]])
CAM = MeiCamera(1280, 1024, 0.9995, K, (-0.0659, 0.00528, 0.00094, -4.9e-05))


def _board_view(R_board, t_board, rng, suffix):
    """The lines of a board of 8 x 6 squares of 42 mm (9 and 7 lines) at ``X_cam = R_board X + t_board``,
    pixels with 0.5 px of noise, families named with ``suffix`` and no line ids."""
    xs, ys = 0.042 * np.arange(9) - 0.168, 0.042 * np.arange(7) - 0.126
    segs = [("x", [xs[0], y, 0.0], [xs[-1], y, 0.0]) for y in ys]
    segs += [("y", [x, ys[0], 0.0], [x, ys[-1], 0.0]) for x in xs]
    uv, fam = [], []
    for f, a, b in segs:
        a_c, b_c = R_board @ np.array(a) + t_board, R_board @ np.array(b) + t_board
        u, _ = segment_pixels(CAM, a_c, b_c, 200, sigma=0.5, rng=rng)
        if len(u) >= 30:
            uv.append(u)
            fam.append(f + suffix)
    return ViewLines(CAM, uv, fam, None)


@pytest.fixture(scope="module")
def board_pair():
    rng = np.random.default_rng(11)
    R_i = Rotation.from_euler("xyz", [100.0, 10.0, 30.0], degrees=True).as_matrix()
    R_j = Rotation.from_euler("xyz", [80.0, -15.0, 60.0], degrees=True).as_matrix()
    t_i, t_j = np.array([0.25, 0.1, -0.3]), np.array([-0.1, 0.3, -0.28])
    va, vb = _board_view(R_i, t_i, rng, "a"), _board_view(R_j, t_j, rng, "b")
    assert len(va.uv) >= 12 and len(vb.uv) >= 12
    pose = relative_pose(va, vb)
    truths = [R_j @ S @ R_i.T for S in (np.eye(3), np.diag([1.0, -1, -1]), np.diag([-1.0, 1, -1]), np.diag([-1.0, -1, 1]))]
    return pose, truths, R_i


def _error(R, truths):
    return min(rotation_angle_deg(R @ T.T) for T in truths)


def test_the_twins_of_a_boards_answer_are_its_symmetric_truths(board_pair):
    pose, truths, R_i = board_pair
    assert _error(pose.R, truths) < 1.0
    # the board's axes in A's frame: its two families' directions and their normal
    axes = target_axes(pose)
    assert len(axes) == 3
    board_axes = R_i.T  # rows: the board's x, y, z in A's frame
    for b in board_axes:
        assert min(np.degrees(np.arccos(min(1.0, abs(float(a @ b))))) for a in axes) < 1.0
    found = twins(pose)
    assert found, [rotation_angle_deg(c.R @ pose.R.T) for c in pose.candidates]
    for t in found:
        R = pose.candidates[t["candidate"]].R
        # each twin is the answer turned by a half-turn about an axis of the board, and a truth too
        assert t["deg"] <= TWIN_DEG
        assert rotation_angle_deg(R @ (pose.R @ half_turn(t["axis"])).T) == pytest.approx(t["deg"])
        assert _error(R, truths) < 1.0


def test_a_listed_twin_makes_the_answer_ambiguous(board_pair):
    import copy

    pose = copy.copy(board_pair[0])
    pose.notes, pose.evidence = list(pose.notes), dict(pose.evidence or {})
    found = flag_twins(pose)
    assert found and pose.ambiguous
    assert pose.evidence["ambiguous_by"][-1] == "symmetric_target"
    assert [t["candidate"] for t in pose.evidence["twins"]] == [t["candidate"] for t in found]
    assert "symmetric target's twin" in pose.notes[-1]


def test_no_twin_leaves_the_answer_alone(board_pair):
    import copy

    pose = copy.copy(board_pair[0])
    pose.candidates = pose.candidates[:1]
    pose.notes, pose.evidence, pose.ambiguous = list(pose.notes), dict(pose.evidence or {}), False
    assert flag_twins(pose) == [] and not pose.ambiguous and "twins" not in pose.evidence


def test_half_turn_is_a_rotation_by_180_degrees():
    a = np.array([1.0, 2.0, -2.0])
    H = half_turn(a)
    assert np.allclose(H @ H.T, np.eye(3)) and np.isclose(np.linalg.det(H), 1.0)
    assert rotation_angle_deg(H) == pytest.approx(180.0)
    assert np.allclose(H @ a, a)
