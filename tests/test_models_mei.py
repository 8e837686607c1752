"""Mei's model (catadioptric.models.MeiCamera) against OpenCV's own cv2.omnidir, the OpenCV
omnidir reader (files written by cv2.FileStorage, YAML and XML, and the project's own export) and
calibration files as --rig."""
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from catadioptric._checks import CatadioptricError
from catadioptric.cli import main
from catadioptric.cliargs import resolve_rig
from catadioptric.formats import calibration_format, calibration_rms, load_camera
from catadioptric.formats.opencv import opencv_yaml
from catadioptric.models import MeiCamera, model_from_dict
from catadioptric.rigs import preset
from catadioptric.unified import unified_from_central

# the real calibration of ../shared/real/mei (cv2.omnidir.calibrate, rms 0.385 px), with a skew added
K = np.array([[297.55807774643375, 0.37, 643.27787342311649], [0.0, 297.84987105851752, 520.93941453863692],
              [0.0, 0.0, 1.0]])
XI = 0.99951223565779312
D = (-0.065863696410245157, 0.0052815617524666399, 0.00094188137236625002, -4.8975580419623088e-05)
EPS = np.finfo(float).eps


@pytest.fixture(scope="module")
def cam():
    return MeiCamera(1280, 1024, XI, K, D)


def _directions(n, seed=0, min_z=-0.8):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, 3))
    X /= np.linalg.norm(X, axis=1, keepdims=True)
    return X[X[:, 2] > min_z]


def test_projection_is_cv2_omnidir(cam):
    X = _directions(3000) * np.random.default_rng(1).uniform(0.5, 20.0, (1, 1))
    uv_cv, _ = cv2.omnidir.projectPoints(X.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, XI, np.array(D))
    pr = cam.project(X)
    assert pr.uv.shape == (len(X), 1, 2) and pr.valid.all()
    # both evaluate one formula in float64: a few ulps of the pixel coordinates (about 1e3)
    assert np.max(np.abs(pr.uv[:, 0] - uv_cv[:, 0])) < 64 * EPS * 2000


def test_lift_inverts_the_projection(cam):
    X = _directions(3000, seed=2)
    uv = cam.project(X).uv[:, 0]
    r = cam.backproject(uv)
    assert r.valid.all()
    assert np.allclose(r.origins, 0.0)
    # Newton's method stops at 1e-15 of the normalised point; the lift is closed-form
    assert np.max(np.linalg.norm(r.directions - X, axis=1)) < 1e-12
    s = cam.directions_from_vanishing_points(uv)
    assert np.max(np.linalg.norm(s - X, axis=1)) < 1e-12


def test_vanishing_points_of_both_ends(cam):
    s = _directions(50, seed=3, min_z=0.0)
    vp = cam.vanishing_points(s, which="both")
    assert vp.uv.shape == (len(s), 2, 2)
    assert np.array_equal(vp.sign[:, 0], np.ones(len(s)))
    assert np.allclose(vp.uv[:, 0], cam.project(10.0 * s).uv[:, 0], atol=1e-9)
    assert vp.valid[:, 0].all() and not vp.valid[:, 1].any()


def test_invalid_where_the_formula_has_no_image():
    c = MeiCamera(640, 480, 0.8, [[200.0, 0, 320], [0, 200.0, 240], [0, 0, 1]])
    behind = np.array([[0.0, 0.0, -1.0], [0.1, 0.0, -1.0]])  # z_s + xi <= 0
    assert not c.project(behind).valid.any()
    assert np.isnan(c.project(behind).uv).all()
    # a pixel far beyond the sphere's image (1 + (1 - xi^2) r^2 < 0 when xi > 1)
    c2 = MeiCamera(640, 480, 1.5, [[200.0, 0, 320], [0, 200.0, 240], [0, 0, 1]])
    assert not c2.backproject([[320.0 + 1e4, 240.0]]).valid[0]


def test_region_leaves_out_where_the_distortion_folds():
    # a strong negative k1 folds the image over beyond r^2 = 1 / (3 |k1|): those pixels are not the model's
    c = MeiCamera(400, 400, 0.0, [[100.0, 0, 199.5], [0, 100.0, 199.5], [0, 0, 1]], (-0.3, 0.0, 0.0, 0.0))
    reg = c.region()
    r_fold = np.sqrt(1.0 / (3 * 0.3))  # normalised radius where d(r (1 + k1 r^2))/dr = 0
    rd_fold = r_fold * (1 - 0.3 * r_fold**2) * 100.0  # its pixel radius
    v, u = np.mgrid[:400, :400]
    rad = np.hypot(u - 199.5, v - 199.5)
    assert reg[rad < rd_fold - 1].all()
    assert not reg[rad > rd_fold + 1].any()


def test_bad_parameters_name_themselves():
    with pytest.raises(CatadioptricError, match=r"^xi: expected a number >= 0, got -0.5"):
        MeiCamera(10, 10, -0.5, K)
    with pytest.raises(CatadioptricError, match=r"^D: expected 4 distortion coefficients"):
        MeiCamera(10, 10, 0.5, K, (0.1, 0.2))
    with pytest.raises(CatadioptricError, match=r"^K: expected"):
        MeiCamera(10, 10, 0.5, np.eye(2))
    with pytest.raises(CatadioptricError, match=r"^width: expected a positive number of pixels, got 0"):
        MeiCamera(0, 10, 0.5, K)


def test_to_dict_round_trip(cam):
    c = model_from_dict(json.loads(json.dumps(cam.to_dict())))
    uv = cam.pixel_grid(37).reshape(-1, 2)
    assert np.array_equal(c.backproject(uv).directions, cam.backproject(uv).directions, equal_nan=True)


# ------------------------------------------------------------------ the reader
def _write_filestorage(path, **nodes):
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for k, v in nodes.items():
        fs.write(k, v)
    fs.release()


@pytest.mark.parametrize("ext", ["yaml", "xml"])
def test_reads_a_file_cv2_filestorage_wrote(tmp_path, ext, cam):
    p = tmp_path / f"calib.{ext}"
    _write_filestorage(p, camera_matrix=K, xi=np.array([[XI]]), distortion_coefficients=np.array([D]),
                       image_width=1280, image_height=1024, rms=0.385)
    assert calibration_format(p) == "opencv"
    c = load_camera(p)
    assert isinstance(c, MeiCamera) and (c.width, c.height) == (1280, 1024)
    assert np.array_equal(c.K, K) and c.xi == XI and c.D == D  # FileStorage writes 17 digits: exact
    # the rms OpenCV's omnidir sample keeps in its file, for relative_pose(..., calibration_rms_px=)
    assert calibration_rms(p) == 0.385


def test_the_calibrations_rms_is_read_when_kept(tmp_path):
    p = tmp_path / "no_rms.yaml"
    _write_filestorage(p, camera_matrix=K, xi=np.array([[XI]]), distortion_coefficients=np.array([D]),
                       image_width=1280, image_height=1024)
    assert calibration_rms(p) is None
    assert calibration_rms(Path(__file__).parent / "data" / "ocamcalib" / "calib_results.txt") is None
    assert calibration_rms(tmp_path) is None  # a folder (a dataset view) keeps none
    q = tmp_path / "bad_rms.yaml"
    _write_filestorage(q, camera_matrix=K, xi=np.array([[XI]]), distortion_coefficients=np.array([D]),
                       image_width=1280, image_height=1024, rms=-1.0)
    with pytest.raises(CatadioptricError, match=r"bad_rms.yaml: rms: expected a non-negative number of pixels, "
                                                r"got -1.0"):
        calibration_rms(q)


def test_a_partial_file_names_the_file_and_the_key(tmp_path):
    p = tmp_path / "partial.yaml"
    _write_filestorage(p, camera_matrix=K, xi=XI, image_width=1280, image_height=1024)
    with pytest.raises(CatadioptricError, match=r"partial.yaml: distortion_coefficients: missing"):
        load_camera(p)
    q = tmp_path / "bad.yaml"
    _write_filestorage(q, camera_matrix=np.eye(2), xi=XI, distortion_coefficients=np.zeros(4), image_width=3,
                       image_height=3)
    with pytest.raises(CatadioptricError, match=r"bad.yaml: camera_matrix: expected 3x3 numbers, got 4"):
        load_camera(q)
    r = tmp_path / "notes.txt"
    r.write_text("hello\n")
    with pytest.raises(CatadioptricError, match=r"notes.txt: not a calibration file"):
        load_camera(r)
    with pytest.raises(CatadioptricError, match=r"expected a calibration file, found a folder"):
        load_camera(tmp_path)


def test_the_projects_own_export_reads_back_exactly(tmp_path):
    rig = preset("hyperboloid_central", width=160, height=120)
    p = tmp_path / "export.yaml"
    p.write_text(opencv_yaml(rig, rig="hyperboloid_central"))
    c = load_camera(p)
    u = unified_from_central(rig)
    uv = rig.pinhole.pixel_grid(3).reshape(-1, 2)
    r, q = rig.backproject(uv), c.backproject(uv)
    ok = r.valid
    assert q.valid[ok].all()
    # omnidir's frame is the unified model's sphere frame (the export's rvec/tvec map M into it)
    d = r.directions[ok] @ u.R_sphere_from_mirror.T
    assert np.max(np.linalg.norm(d - q.directions[ok], axis=1)) < 1e-12


def test_calibration_as_rig_checks_the_image_size(tmp_path):
    p = tmp_path / "calib.yml"
    _write_filestorage(p, camera_matrix=K, xi=XI, distortion_coefficients=np.array([D]), image_width=1280,
                       image_height=1024)
    cam, desc = resolve_rig(str(p), width=1280, height=1024, calibrations=True)
    with pytest.raises(CatadioptricError, match=r"^--rig: expected a rig name or a rig spec file \(this command needs an exact rig"):
        resolve_rig(str(p))
    assert isinstance(cam, MeiCamera) and desc["spec"]["calibration"] == "opencv"
    with pytest.raises(CatadioptricError, match=r"^--rig: the calibration .* is of 1280x1024 images, got an image "
                                                r"of 640x480$"):
        resolve_rig(str(p), width=640, height=480, calibrations=True)
    with pytest.raises(CatadioptricError, match=r"^--camera: only for a Kalibr camchain"):
        resolve_rig("hyperboloid", camera="cam1")


def test_detect_takes_a_calibration_and_a_mask(tmp_path, capsys):
    # a synthetic photograph of a few straight edges seen through the model; the mask must match the image
    p = tmp_path / "calib.yaml"
    _write_filestorage(p, camera_matrix=np.array([[60.0, 0, 79.5], [0, 60.0, 59.5], [0, 0, 1]]), xi=0.9,
                       distortion_coefficients=np.zeros((1, 4)), image_width=160, image_height=120)
    img = np.full((120, 160), 128, np.uint8)
    cv2.imwrite(str(tmp_path / "img.png"), img)
    cv2.imwrite(str(tmp_path / "mask.png"), np.ones((60, 80), np.uint8))
    rc = main(["detect", str(tmp_path / "img.png"), "--rig", str(p), "--mask", str(tmp_path / "mask.png"),
               "--out", str(tmp_path / "d")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1
    assert "--mask: expected 160x120 pixels (the image's size), got 80x60" in err
    cv2.imwrite(str(tmp_path / "mask.png"), np.ones((120, 160), np.uint8))
    rc = main(["detect", str(tmp_path / "img.png"), "--rig", str(p), "--mask", str(tmp_path / "mask.png"),
               "--out", str(tmp_path / "d")])
    assert rc == 0
    out = json.loads((tmp_path / "d" / "lines.json").read_text())
    assert out["camera"]["model"] == "mei" and out["lines"] == []


def test_vanishing_curves_of_a_model(cam):
    m = np.array([0.3, -0.2, 0.93])
    pieces = cam.vanishing_curve(m)
    assert pieces
    for p in pieces:
        d = cam.backproject(p.uv).directions
        # every vertex is an exact vanishing point of a direction in the plane (rays normal to m)
        assert np.max(np.abs(d @ (m / np.linalg.norm(m)))) < 1e-12
        assert np.max(np.linalg.norm(np.diff(p.uv, axis=0), axis=1)) <= 1.0 + 1e-9


def test_the_unified_fit_of_a_calibration(cam):
    # a model with no distortion is the unified model itself: the fit recovers it to rounding
    pure = MeiCamera(cam.width, cam.height, XI, K)
    from catadioptric.unified import fit_unified

    f = fit_unified(pure, step=32)
    assert f.rms_px < 1e-9 and abs(f.camera.xi - XI) < 1e-9
    # with its lens distortion it is not: the fit says how far (pixels), finite and positive
    g = fit_unified(cam, step=32)
    assert np.isfinite(g.rms_px) and g.rms_px > 1e-3


def test_a_partial_camchain_is_named_as_such(tmp_path, capsys):
    p = tmp_path / "camchain.yaml"
    p.write_text("cam0:\n  camera_model: omni\n  distortion_model: radtan\n  distortion_coeffs: [0, 0, 0, 0]\n"
                 "  resolution: [160, 120]\n")
    img = tmp_path / "img.png"
    cv2.imwrite(str(img), np.zeros((120, 160), np.uint8))
    rc = main(["detect", str(img), "--rig", str(p), "--out", str(tmp_path / "d")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "cam0.intrinsics: missing" in err, err
