"""The absolute pose of a chessboard (catadioptric.pose.chessboard, ``catadioptric absolute-pose``):
synthetic corners against the pose's own covariance, the real paracatadioptric images of
../shared/real/mei against OpenCV omnidir's extrinsics, and the command end to end."""
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from catadioptric._checks import CatadioptricError
from catadioptric.models import MeiCamera
from catadioptric.pose.chessboard import (board_mask, board_points, chessboard_pose, compare_board_poses,
                                          parse_pattern)

REAL = Path(__file__).resolve().parents[1].parent / "shared" / "real" / "mei"
NEED_REAL = pytest.mark.skipif(not (REAL / "mei_omnidir.yaml").is_file(),
                               reason=f"the real Mei images are not here ({REAL}: ../shared/real/mei from the repo root)")

# the real calibration's numbers (cv2.omnidir.calibrate on the Mei set, rms 0.385 px)
K = [[297.55807774643375, 0.0, 643.2778734231165], [0.0, 297.8498710585175, 520.9394145386369], [0.0, 0.0, 1.0]]
XI = 0.9995122356577931
D = (-0.06586369641024516, 0.00528156175246664, 0.00094188137236625, -4.897558041962309e-05)
PATTERN, SQUARE = (8, 6), 0.042


def _camera():
    return MeiCamera(width=1280, height=1024, xi=XI, K=np.array(K), D=D)


# ----------------------------------------------------------------------------- synthetic
POSES = [  # (rvec, tvec) of boards placed as in the real images (X_cam = R X_board + t)
    ([-0.44, 0.92, -1.99], [0.254, -0.017, 0.286]),
    ([0.011, -0.058, -2.21], [0.233, -0.027, 0.271]),
    ([0.35, 1.76, 2.06], [0.330, 0.207, -0.015]),
]


@pytest.mark.parametrize("k", range(len(POSES)))
def test_synthetic_pose_within_its_covariance(k):
    cam = _camera()
    rvec, tvec = POSES[k]
    R, t = Rotation.from_rotvec(rvec).as_matrix(), np.array(tvec)
    P = board_points(PATTERN, SQUARE)
    uv0 = cam.project(P @ R.T + t).uv[:, 0, :]
    assert np.all(np.isfinite(uv0)) and np.all(cam.in_image(uv0))
    q_rot, q_all = chi2.ppf(0.999, 3), chi2.ppf(0.999, 6)
    for seed in range(4):
        rng = np.random.default_rng(1000 * k + seed)
        uv = uv0 + rng.normal(0.0, 0.3, uv0.shape)
        p = chessboard_pose(None, cam, PATTERN, SQUARE, corners=uv)
        w = Rotation.from_matrix(R @ p.R.T).as_rotvec()  # R = exp([w]_x) R_hat
        e = np.r_[w, t - p.t]
        m_rot = w @ np.linalg.solve(p.cov[:3, :3], w)
        m_all = e @ np.linalg.solve(p.cov, e)
        assert m_rot < q_rot, (seed, m_rot, p.rotation_std_deg)
        assert m_all < q_all, (seed, m_all)
        assert 0.2 < p.sigma_px < 0.4  # the noise, estimated from the residuals
        # the paper's pose (directions, then lines) is close already, and the axes follow their families
        assert np.degrees(np.linalg.norm(Rotation.from_matrix(R @ p.R_lines.T).as_rotvec())) < 1.0
        assert np.all(p.axis_family_deg < 1.0)
        # the vanishing points are the model's images of the families' directions
        vp = cam.vanishing_points(p.directions)
        assert np.allclose(vp.uv[:, 0], p.vanishing_uv[:, 0], atol=1e-9)


def test_noiseless_corners_give_the_pose_exactly():
    cam = _camera()
    R, t = Rotation.from_rotvec(POSES[0][0]).as_matrix(), np.array(POSES[0][1])
    uv = cam.project(board_points(PATTERN, SQUARE) @ R.T + t).uv[:, 0, :]
    p = chessboard_pose(None, cam, PATTERN, SQUARE, corners=uv)
    assert np.allclose(p.R, R, atol=1e-7) and np.allclose(p.t, t, atol=1e-8)
    assert np.allclose(p.R_lines, R, atol=1e-7) and np.allclose(p.t_lines, t, atol=1e-8)
    assert np.allclose(p.directions, R[:, :2].T, atol=1e-7)
    assert p.rms_px < 1e-5


def test_reversed_corner_order_is_the_180_degree_turn_about_z():
    cam = _camera()
    R, t = Rotation.from_rotvec(POSES[1][0]).as_matrix(), np.array(POSES[1][1])
    uv = cam.project(board_points(PATTERN, SQUARE) @ R.T + t).uv[:, 0, :]
    p = chessboard_pose(None, cam, PATTERN, SQUARE, corners=uv[::-1])
    c = compare_board_poses(p.R, p.t, R, t, PATTERN, SQUARE)
    assert c["symmetry"] == "180 about z" and c["rotation_error_deg"] < 1e-5 and c["centre_error_m"] < 1e-8
    assert compare_board_poses(R, t, R, t, PATTERN, SQUARE)["symmetry"] == "identity"


def test_bad_inputs_are_one_line_errors():
    cam = _camera()
    for bad in ("8by6", "8x", "2x6", "x6"):
        with pytest.raises(CatadioptricError, match="pattern: expected"):
            parse_pattern(bad)
    assert parse_pattern("8x6") == (8, 6) and parse_pattern("9X7") == (9, 7)
    img = np.full((1024, 1280), 128, np.uint8)
    with pytest.raises(CatadioptricError, match="mask: expected the image's size 1280x1024, got 640x512"):
        chessboard_pose(img, cam, PATTERN, SQUARE, mask=np.ones((512, 640), np.uint8), method="sb")
    with pytest.raises(CatadioptricError, match="image: expected the camera's size 1280x1024, got 640x512"):
        chessboard_pose(img[:512, :640], cam, PATTERN, SQUARE)
    with pytest.raises(CatadioptricError, match=r"image: no 8x6 chessboard found \(inner corners; tried sb\)"):
        chessboard_pose(img, cam, PATTERN, SQUARE, method="sb")
    with pytest.raises(CatadioptricError, match="square: expected a positive number"):
        chessboard_pose(img, cam, PATTERN, -1.0)


# ----------------------------------------------------------------------------- real images
def _reference():
    views = json.loads((REAL / "board_extrinsics.json").read_text())["views"]
    return {n: (Rotation.from_rotvec(v["rvec"]).as_matrix(), np.array(v["tvec"])) for n, v in views.items()}


@NEED_REAL
@pytest.mark.parametrize("method", ["sb", "classic", "rectified"])
@pytest.mark.parametrize("name", ["img_para_001.png", "img_para_002.png", "img_para_004.png"])
def test_real_pose_against_opencv_extrinsics(name, method):
    """Within 0.5 degree of cv2.omnidir's extrinsics up to the board's symmetries and the centre within
    1 % of its distance. The SB corners are those OpenCV calibrated on (the refined pose reproduces
    its extrinsics); the classic detector's and the rectified views' corners are other measurements."""
    import cv2

    from catadioptric.formats import load_camera

    cam = load_camera(REAL / "mei_omnidir.yaml")
    img = cv2.imread(str(REAL / name), cv2.IMREAD_UNCHANGED)
    mask = cv2.imread(str(REAL / "masks" / name), cv2.IMREAD_UNCHANGED)
    p = chessboard_pose(img, cam, PATTERN, SQUARE, mask=mask, method=method)
    assert p.detector == method and len(p.corners) == 48 and p.rms_px < 0.6
    Rr, tr = _reference()[name]
    for R, t in ((p.R, p.t), (p.R_lines, p.t_lines)):
        c = compare_board_poses(R, t, Rr, tr, PATTERN, SQUARE)
        assert c["symmetry"] in ("identity", "180 about z"), c
        assert c["rotation_error_deg"] < (0.5 if R is p.R else 0.75), c
        assert c["centre_error_relative"] < 0.01, c
    assert np.all(p.axis_family_deg < 1.0)
    assert np.max(p.rotation_std_deg) < 0.3 and np.max(p.translation_std_m) < 1e-3


@NEED_REAL
@pytest.mark.parametrize("name", ["img_para_001.png", "img_para_002.png", "img_para_004.png"])
def test_board_mask_from_the_extrinsics_is_the_shared_one(name):
    """The shared masks are the board's outline projected, filled and dilated by 12 px (the data's
    README): the mask made from OpenCV's extrinsics differs from them only on their boundary (where
    two rasterisations of one curve may disagree by a pixel), nowhere inside or outside it."""
    import cv2

    from catadioptric.formats import load_camera

    ref = cv2.imread(str(REAL / "masks" / name), cv2.IMREAD_GRAYSCALE) > 0
    R, t = _reference()[name]
    m = board_mask(load_camera(REAL / "mei_omnidir.yaml"), R, t, ref.shape, PATTERN, SQUARE)
    boundary = cv2.morphologyEx(ref.astype(np.uint8), cv2.MORPH_GRADIENT, np.ones((3, 3), np.uint8)) > 0
    assert not np.any((m != ref) & ~boundary)
    assert np.sum(m & ref) / np.sum(m | ref) > 0.99
    # a board where a model with xi = 0.5 sees nothing (behind it): one line naming the function
    behind = MeiCamera(width=1280, height=1024, xi=0.5, K=np.array(K), D=D)
    with pytest.raises(CatadioptricError, match="board_mask: 256 of the board outline's 256 points do not project"):
        board_mask(behind, np.eye(3), [-0.1, -0.1, -1.0], ref.shape, PATTERN, SQUARE)


# ----------------------------------------------------------------------------- the command
@NEED_REAL
def test_command_end_to_end(tmp_path, capsys):
    from catadioptric.cli import main

    out = tmp_path / "o"
    code = main(["absolute-pose", str(REAL / "img_para_002.png"), "--rig", str(REAL / "mei_omnidir.yaml"),
                 "--chessboard", "8x6", "--square", "0.042", "--mask", str(REAL / "masks" / "img_para_002.png"),
                 "--reference", str(REAL / "board_extrinsics.json"), "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    pose = json.loads((out / "pose.json").read_text())
    for key in ("R", "t", "cov", "rotation_std_deg", "translation_std_m", "corners_found", "rms_px", "families",
                "vanishing_points", "lines_pose", "reference"):
        assert key in pose, key
    assert np.array(pose["cov"]).shape == (6, 6) and pose["corners_found"] == 48
    assert [f["name"] for f in pose["families"]] == ["x (rows)", "y (columns)"]
    assert pose["reference"]["refined"]["rotation_error_deg"] < 0.5
    assert (out / "overlay.png").stat().st_size > 0 and "Absolute pose" in (out / "report.md").read_text()


@NEED_REAL
@pytest.mark.parametrize("argv, message", [
    (["--chessboard", "8by6"], "--chessboard: expected COLSxROWS (inner corners, e.g. 8x6), got '8by6'"),
    (["--chessboard", "8x6", "--mask", "SMALL"], "--mask: expected the image's size 1280x1024, got 64x48"),
])
def test_command_errors_are_one_line(argv, message, tmp_path, capsys):
    import cv2

    from catadioptric.cli import main

    small = tmp_path / "small.png"
    cv2.imwrite(str(small), np.full((48, 64), 255, np.uint8))
    argv = [str(small) if a == "SMALL" else a for a in argv]
    code = main(["absolute-pose", str(REAL / "img_para_001.png"), "--rig", str(REAL / "mei_omnidir.yaml"),
                 "--square", "0.042", "--out", str(tmp_path / "o")] + argv)
    err = capsys.readouterr().err.strip()
    assert code == 2 and err == f"catadioptric: error: {message}"
    assert not (tmp_path / "o" / "pose.json").exists()


@NEED_REAL
def test_command_board_not_found_is_one_line(tmp_path, capsys):
    import cv2

    from catadioptric.cli import main

    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((1024, 1280), 90, np.uint8))
    mask = tmp_path / "mask.png"
    m = np.zeros((1024, 1280), np.uint8)
    m[600:800, 700:900] = 255
    cv2.imwrite(str(mask), m)
    code = main(["absolute-pose", str(blank), "--rig", str(REAL / "mei_omnidir.yaml"), "--chessboard", "8x6",
                 "--square", "0.042", "--mask", str(mask), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith("catadioptric: error: image: no 8x6 chessboard found") and "\n" not in err
