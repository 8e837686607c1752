"""Kalibr's camera models (eucm, ds, pinhole + radtan / equidistant / none) against their
published formulas written here independently (Usenko, Demmel, Cremers, "The Double Sphere
Camera Model", 3DV 2018; Kalibr's wiki; OpenCV's ``cv2.projectPoints`` and
``cv2.fisheye.projectPoints``), their closed-form or iterative inverses, their validity regions,
and the camchain reader (``read_kalibr``, ``load_camera``), including the project's own export
read back.

Tolerances: pixels agree to float64 rounding of the formulas, bounded by ``ROUND_PX`` (a few
hundred ulps of the pixel coordinates, which are below 1e4 here); directions round-trip to 1e-12
(the brief's bound) away from the validity boundary, where the inverse is well conditioned (a
margin of 5 degrees)."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from catadioptric._checks import CatadioptricError
from catadioptric.formats import load_camera
from catadioptric.formats.kalibr import kalibr_camchain, read_kalibr
from catadioptric.formats.rigmodel import FLIP_Y
from catadioptric.models import (MODELS, DoubleSphereCamera, EUCMCamera, KalibrPinholeCamera, MeiCamera,
                                 model_from_dict)
from catadioptric.rigs import preset
from catadioptric.unified import unified_from_central

EPS = np.finfo(float).eps
#: float64 rounding of a pixel coordinate below 1e4 through a dozen operations (with margin)
ROUND_PX = 1e4 * EPS * 256
#: the round trip of a unit direction, away from the validity boundary
ROUND_TRIP = 1e-12
MARGIN = np.radians(5.0)

FU, FV, PU, PV = 310.0, 305.0, 322.5, 241.25


def _directions(n, theta_lo, theta_hi, seed):
    """``n`` random unit directions whose angle from +z lies in ``[theta_lo, theta_hi]``."""
    rng = np.random.default_rng(seed)
    ct = rng.uniform(np.cos(theta_hi), np.cos(theta_lo), n)
    phi = rng.uniform(-np.pi, np.pi, n)
    st = np.sqrt(1.0 - ct * ct)
    return np.stack([st * np.cos(phi), st * np.sin(phi), ct], axis=-1)


def _boundary(valid_of_theta):
    """The first angle from the axis (in [0, pi]) where a validity condition of the angle fails,
    found on a fine scan (1e-5 rad) of the condition written in the test."""
    t = np.linspace(0.0, np.pi, 314160)
    ok = valid_of_theta(t)
    assert ok[0]
    bad = np.nonzero(~ok)[0]
    return float(t[bad[0]]) if bad.size else np.pi


# ------------------------------------------------------------------ the published formulas
def eucm_formula(X, alpha, beta, fu, fv, pu, pv):
    """Usenko et al. 2018, eq. for the EUCM: d = sqrt(beta (x^2 + y^2) + z^2)."""
    x, y, z = X.T
    d = np.sqrt(beta * (x ** 2 + y ** 2) + z ** 2)
    den = alpha * d + (1 - alpha) * z
    return np.column_stack([fu * x / den + pu, fv * y / den + pv])


def eucm_valid(X, alpha, beta):
    x, y, z = X.T
    w = alpha / (1 - alpha) if alpha <= 0.5 else (1 - alpha) / alpha
    return z > -w * np.sqrt(beta * (x ** 2 + y ** 2) + z ** 2)


def ds_formula(X, xi, alpha, fu, fv, pu, pv):
    """Usenko et al. 2018, the double sphere projection."""
    x, y, z = X.T
    d1 = np.sqrt(x ** 2 + y ** 2 + z ** 2)
    d2 = np.sqrt(x ** 2 + y ** 2 + (xi * d1 + z) ** 2)
    den = alpha * d2 + (1 - alpha) * (xi * d1 + z)
    return np.column_stack([fu * x / den + pu, fv * y / den + pv])


def ds_valid(X, xi, alpha):
    x, y, z = X.T
    w1 = alpha / (1 - alpha) if alpha <= 0.5 else (1 - alpha) / alpha
    w2 = (w1 + xi) / np.sqrt(2 * w1 * xi + xi ** 2 + 1)
    return z > -w2 * np.sqrt(x ** 2 + y ** 2 + z ** 2)


def radtan_formula(X, k1, k2, r1, r2):
    """Kalibr's pinhole + radtan (OpenCV's k1, k2, p1, p2) on (x/z, y/z)."""
    mx, my = X[:, 0] / X[:, 2], X[:, 1] / X[:, 2]
    rr = mx ** 2 + my ** 2
    rad = 1 + k1 * rr + k2 * rr ** 2
    xd = mx * rad + 2 * r1 * mx * my + r2 * (rr + 2 * mx ** 2)
    yd = my * rad + r1 * (rr + 2 * my ** 2) + 2 * r2 * mx * my
    return np.column_stack([FU * xd + PU, FV * yd + PV])


def equidistant_formula(X, k1, k2, k3, k4):
    """Kannala-Brandt as Kalibr's equidistant and cv2.fisheye: theta_d = theta (1 + k1 theta^2 +
    k2 theta^4 + k3 theta^6 + k4 theta^8), along the direction of (x, y)."""
    rho = np.hypot(X[:, 0], X[:, 1])
    th = np.arctan2(rho, X[:, 2])
    td = th * (1 + k1 * th ** 2 + k2 * th ** 4 + k3 * th ** 6 + k4 * th ** 8)
    return np.column_stack([FU * td * X[:, 0] / rho + PU, FV * td * X[:, 1] / rho + PV])


def _K():
    return np.array([[FU, 0.0, PU], [0.0, FV, PV], [0.0, 0.0, 1.0]])


# ------------------------------------------------------------------ the cameras tested
EUCMS = [(0.6, 1.1), (0.4, 0.9), (0.75, 0.5)]
DSS = [(-0.2, 0.6), (0.5, 0.4), (0.9, 0.7)]
RADTAN = (-0.28, 0.07, 1e-3, -2e-3)
EQUI = [(-0.01, 0.002, -0.003, 0.0005), (0.1, -0.05, 0.0, 0.0)]


def _assert_round_trip(cam, X):
    uv, ok = cam.project_unit(X)
    assert ok.all()
    Y, okl = cam.lift(uv)
    assert okl.all()
    assert np.max(np.linalg.norm(Y - X, axis=-1)) <= ROUND_TRIP
    # and through the public API
    r = cam.backproject(uv)
    assert r.valid.all() and np.max(np.linalg.norm(r.directions - X, axis=-1)) <= ROUND_TRIP


@pytest.mark.parametrize("alpha,beta", EUCMS)
def test_eucm_against_the_papers_formula_round_trip_and_validity(alpha, beta):
    cam = EUCMCamera(640, 480, alpha, beta, FU, FV, PU, PV)
    tb = _boundary(lambda t: eucm_valid(np.column_stack([np.sin(t), 0 * t, np.cos(t)]), alpha, beta))
    X = _directions(4000, 0.0, tb - MARGIN, 1)
    uv, ok = cam.project_unit(X)
    assert ok.all()
    assert np.max(np.abs(uv - eucm_formula(X, alpha, beta, FU, FV, PU, PV))) <= ROUND_PX
    _assert_round_trip(cam, X)
    if tb < np.pi:
        out = _directions(2000, tb + np.radians(0.01), np.pi, 2)
        assert not cam.project_unit(out)[1].any()
        assert not eucm_valid(out, alpha, beta).any()
    if alpha > 0.5:  # pixels beyond r^2 = 1 / (beta (2 alpha - 1)) have no ray
        rmax = 1.0 / np.sqrt(beta * (2 * alpha - 1))
        phi = np.linspace(0, 2 * np.pi, 50)
        m = 1.001 * rmax * np.column_stack([np.cos(phi), np.sin(phi)])
        assert not cam.lift(m * [FU, FV] + [PU, PV])[1].any()
    else:
        far = np.array([[1e5, -3e4], [PU, PV]])
        assert cam.lift(far)[1].all()


def test_eucm_with_beta_one_is_meis_model():
    alpha = 0.62
    xi = alpha / (1 - alpha)
    cam = EUCMCamera(640, 480, alpha, 1.0, FU, FV, PU, PV)
    mei = MeiCamera(640, 480, xi, np.array([[FU * (1 + xi), 0, PU], [0, FV * (1 + xi), PV], [0, 0, 1]]))
    X = _directions(2000, 0.0, np.radians(120), 3)
    assert np.max(np.abs(cam.project_unit(X)[0] - mei.project_unit(X)[0])) <= ROUND_PX


@pytest.mark.parametrize("xi,alpha", DSS)
def test_double_sphere_against_the_papers_formula_round_trip_and_validity(xi, alpha):
    cam = DoubleSphereCamera(640, 480, xi, alpha, FU, FV, PU, PV)
    tb = _boundary(lambda t: ds_valid(np.column_stack([np.sin(t), 0 * t, np.cos(t)]), xi, alpha))
    X = _directions(4000, 0.0, tb - MARGIN, 4)
    uv, ok = cam.project_unit(X)
    assert ok.all()
    assert np.max(np.abs(uv - ds_formula(X, xi, alpha, FU, FV, PU, PV))) <= ROUND_PX
    _assert_round_trip(cam, X)
    if tb < np.pi:
        out = _directions(2000, tb + np.radians(0.01), np.pi, 5)
        assert not cam.project_unit(out)[1].any()
    if alpha > 0.5:
        rmax = 1.0 / np.sqrt(2 * alpha - 1)
        phi = np.linspace(0, 2 * np.pi, 50)
        m = 1.001 * rmax * np.column_stack([np.cos(phi), np.sin(phi)])
        assert not cam.lift(m * [FU, FV] + [PU, PV])[1].any()


def test_pinhole_radtan_against_the_formula_and_cv2_projectPoints():
    cam = KalibrPinholeCamera(640, 480, FU, FV, PU, PV, "radtan", RADTAN)
    X = _directions(4000, 0.0, np.radians(60), 6)
    uv, ok = cam.project_unit(X)
    assert ok.all()
    assert np.max(np.abs(uv - radtan_formula(X, *RADTAN))) <= ROUND_PX
    cv, _ = cv2.projectPoints(X.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), _K(), np.array(RADTAN))
    assert np.max(np.abs(uv - cv.reshape(-1, 2))) <= ROUND_PX
    _assert_round_trip(cam, X)
    behind = _directions(1000, np.pi / 2, np.pi, 7)
    assert not cam.project_unit(behind)[1].any()


@pytest.mark.parametrize("k", EQUI)
def test_pinhole_equidistant_against_the_formula_and_cv2_fisheye(k):
    cam = KalibrPinholeCamera(640, 480, FU, FV, PU, PV, "equidistant", k)
    k1, k2, k3, k4 = k
    tb = _boundary(lambda t: 1 + 3 * k1 * t ** 2 + 5 * k2 * t ** 4 + 7 * k3 * t ** 6 + 9 * k4 * t ** 8 > 0)
    assert cam.theta_max == pytest.approx(tb, abs=2e-5)  # the scan's step
    X = _directions(4000, 1e-3, tb - MARGIN, 8)
    uv, ok = cam.project_unit(X)
    assert ok.all()
    assert np.max(np.abs(uv - equidistant_formula(X, *k))) <= ROUND_PX
    front = X[:, 2] > 0.05  # cv2.fisheye goes through (x/z, y/z): points in front only
    cv, _ = cv2.fisheye.projectPoints(X[front].reshape(-1, 1, 3), np.zeros(3), np.zeros(3), _K(), np.array(k))
    # through x/z the angle is atan(r) for r up to 1/0.05: rounding grows with 1/z
    assert np.max(np.abs(uv[front] - cv.reshape(-1, 2))) <= ROUND_PX / 0.05
    _assert_round_trip(cam, X)
    if tb < np.pi:
        out = _directions(1000, tb + np.radians(0.01), np.pi, 9)
        assert not cam.project_unit(out)[1].any()
        td_max = tb * (1 + k1 * tb ** 2 + k2 * tb ** 4 + k3 * tb ** 6 + k4 * tb ** 8)
        assert not cam.lift(np.array([[PU + FU * td_max * 1.001, PV]]))[1].any()
    # the axis
    Y, okl = cam.lift(np.array([[PU, PV]]))
    assert okl.all() and np.array_equal(Y, [[0.0, 0.0, 1.0]])


def test_pinhole_none_is_the_plain_pinhole():
    cam = KalibrPinholeCamera(640, 480, FU, FV, PU, PV, "none")
    X = _directions(2000, 0.0, np.radians(80), 10)
    uv, ok = cam.project_unit(X)
    cv, _ = cv2.projectPoints(X.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), _K(), np.zeros(4))
    assert ok.all() and np.max(np.abs(uv - cv.reshape(-1, 2))) <= ROUND_PX / np.cos(np.radians(80))
    _assert_round_trip(cam, X)
    assert not cam.project_unit(_directions(100, np.pi / 2, np.pi, 11))[1].any()


def test_models_are_registered_and_read_back_from_their_dicts():
    cams = [EUCMCamera(64, 48, 0.6, 1.1, FU, FV, PU, PV), DoubleSphereCamera(64, 48, -0.2, 0.6, FU, FV, PU, PV),
            KalibrPinholeCamera(64, 48, FU, FV, PU, PV, "radtan", RADTAN),
            KalibrPinholeCamera(64, 48, FU, FV, PU, PV, "equidistant", EQUI[1]),
            KalibrPinholeCamera(64, 48, FU, FV, PU, PV, "none")]
    for cam in cams:
        assert MODELS[cam.model] is type(cam)
        again = model_from_dict(cam.to_dict())
        assert type(again) is type(cam) and again.to_dict() == cam.to_dict()
    assert {"eucm", "ds", "pinhole", "ocamcalib"} <= set(MODELS)


@pytest.mark.parametrize("make,msg", [
    (lambda: EUCMCamera(64, 48, 1.5, 1.0, FU, FV, PU, PV), r"^alpha: expected a number in \[0, 1\], got 1.5$"),
    (lambda: EUCMCamera(64, 48, 0.5, 0.0, FU, FV, PU, PV), r"^beta: expected a positive number, got 0.0$"),
    (lambda: DoubleSphereCamera(64, 48, 0.1, 0.5, 0.0, FV, PU, PV), r"^fu: expected a non-zero focal length"),
    (lambda: KalibrPinholeCamera(64, 48, FU, FV, PU, PV, "fov", (0.9,)), r"^distortion_model: expected one of"),
    (lambda: KalibrPinholeCamera(64, 48, FU, FV, PU, PV, "radtan", (0.1,)),
     r"^distortion_coeffs: expected 4 numbers for distortion_model radtan, got 1$"),
])
def test_model_parameter_errors(make, msg):
    with pytest.raises(CatadioptricError, match=msg):
        make()


# ------------------------------------------------------------------ the camchain reader
CAM_OMNI = """\
  camera_model: omni
  intrinsics: [0.9, 400.5, 401.25, 320.0, 240.5]
  distortion_model: radtan
  distortion_coeffs: [-0.1, 0.02, 0.001, -0.0005]
  resolution: [640, 480]
  rostopic: /cam0/image_raw
"""
CAM_DS = """\
  camera_model: ds
  intrinsics: [-0.2, 0.6, 310.0, 305.0, 322.5, 241.25]
  distortion_model: none
  distortion_coeffs: []
  resolution: [640, 480]
"""
CAM_EUCM = """\
  camera_model: eucm
  intrinsics: [0.6, 1.1, 310.0, 305.0, 322.5, 241.25]
  distortion_model: none
  distortion_coeffs: []
  resolution: [640, 480]
"""
CAM_PINHOLE_EQ = """\
  camera_model: pinhole
  intrinsics: [310.0, 305.0, 322.5, 241.25]
  distortion_model: equidistant
  distortion_coeffs: [0.1, -0.05, 0.0, 0.0]
  resolution: [640, 480]
"""


def _write(tmp_path, text, name="camchain.yaml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_reads_one_camera_of_each_model(tmp_path):
    cam = read_kalibr(_write(tmp_path, "cam0:\n" + CAM_OMNI))
    assert isinstance(cam, MeiCamera) and cam.size == (640, 480) and cam.xi == 0.9
    np.testing.assert_array_equal(cam.K, [[400.5, 0, 320.0], [0, 401.25, 240.5], [0, 0, 1]])
    assert cam.D == (-0.1, 0.02, 0.001, -0.0005)
    ds = read_kalibr(_write(tmp_path, "cam0:\n" + CAM_DS))
    assert isinstance(ds, DoubleSphereCamera) and ds.params() == {"xi": -0.2, "alpha": 0.6, "fu": 310.0,
                                                                  "fv": 305.0, "pu": 322.5, "pv": 241.25}
    eu = read_kalibr(_write(tmp_path, "cam0:\n" + CAM_EUCM))
    assert isinstance(eu, EUCMCamera) and (eu.alpha, eu.beta, eu.fu) == (0.6, 1.1, 310.0)
    ph = load_camera(_write(tmp_path, "cam0:\n" + CAM_PINHOLE_EQ))
    assert isinstance(ph, KalibrPinholeCamera) and ph.distortion_model == "equidistant"
    assert ph.distortion_coeffs == (0.1, -0.05, 0.0, 0.0)
    # a file holding one camera's keys at the top level, and omni + none
    top = CAM_OMNI.replace("  ", "").replace("radtan", "none").replace("[-0.1, 0.02, 0.001, -0.0005]", "[]")
    one = load_camera(_write(tmp_path, top, "one.yaml"))
    assert isinstance(one, MeiCamera) and one.D == (0.0, 0.0, 0.0, 0.0)
    # numbers PyYAML reads as strings (YAML 1.1 wants a dot): 1e-05
    odd = read_kalibr(_write(tmp_path, "cam0:\n" + CAM_OMNI.replace("0.001,", "1e-05,")))
    assert odd.D[2] == 1e-05


def test_two_cameras_need_a_choice(tmp_path):
    text = "cam0:\n" + CAM_OMNI + "cam1:\n" + CAM_DS + "  T_cn_cnm1:\n  - [1, 0, 0, 0.1]\n  - [0, 1, 0, 0]\n" \
        "  - [0, 0, 1, 0]\n  - [0, 0, 0, 1]\n"
    p = _write(tmp_path, text)
    cam1 = read_kalibr(p, camera="cam1")
    assert isinstance(cam1, DoubleSphereCamera) and cam1.xi == -0.2
    assert isinstance(load_camera(p, camera="cam1"), DoubleSphereCamera)
    assert isinstance(load_camera(p, camera="cam0"), MeiCamera)
    with pytest.raises(CatadioptricError) as ei:
        read_kalibr(p)
    msg = str(ei.value)
    assert msg.startswith(f"{p}: ") and "cam0, cam1" in msg and "--camera camN" in msg and "\n" not in msg
    with pytest.raises(CatadioptricError, match=r": cam2: missing; the camchain holds cam0, cam1$"):
        read_kalibr(p, camera="cam2")


@pytest.mark.parametrize("text,msg", [
    ("cam0:\n" + CAM_OMNI.replace("[0.9, 400.5, 401.25, 320.0, 240.5]", "[400.5, 401.25, 320.0, 240.5]"),
     "cam0.intrinsics: expected 5 numbers for camera_model omni ([xi, fu, fv, pu, pv]), got 4"),
    ("cam1:\n" + CAM_DS.replace("  camera_model: ds\n", ""), "cam1.camera_model: missing"),
    ("cam0:\n" + CAM_OMNI.replace("omni", "fov"), "cam0.camera_model: expected one of omni, eucm, ds, pinhole, "
                                                   "got 'fov'"),
    ("cam0:\n" + CAM_OMNI.replace("  resolution: [640, 480]\n", ""), "cam0.resolution: missing"),
    ("cam0:\n" + CAM_OMNI.replace("  intrinsics: [0.9, 400.5, 401.25, 320.0, 240.5]\n", ""),
     "cam0.intrinsics: missing"),
    ("cam0:\n" + CAM_OMNI.replace("  distortion_coeffs: [-0.1, 0.02, 0.001, -0.0005]\n", ""),
     "cam0.distortion_coeffs: missing"),
    ("cam0:\n" + CAM_OMNI.replace("  distortion_model: radtan\n", ""), "cam0.distortion_model: missing"),
    ("cam0:\n" + CAM_OMNI.replace("radtan", "equidistant"),
     "cam0.distortion_model: omni with equidistant is not a model this reader can express"),
    ("cam0:\n" + CAM_EUCM.replace("none", "radtan").replace("[]", "[0.1, 0, 0, 0]"),
     "cam0.distortion_model: expected none for camera_model eucm, got 'radtan'"),
    ("cam0:\n" + CAM_OMNI.replace("0.001,", "abc,"), "cam0.distortion_coeffs: expected a list of numbers"),
    ("cam0:\n" + CAM_OMNI.replace("[640, 480]", "[640.5, 480]"), "cam0.resolution: expected [width, height]"),
    ("cam0:\n" + CAM_EUCM.replace("[0.6, 1.1,", "[1.6, 1.1,"),
     "cam0.intrinsics: alpha: expected a number in [0, 1], got 1.6"),
    ("cam0:\n" + CAM_DS.replace("[]", "[0.5]"), "cam0.distortion_coeffs: expected none (or zeros)"),
    ("other: 1\n", "cam0: missing (a Kalibr camchain holds cam0, cam1, ..."),
    ("[1, 2]\n", "expected a Kalibr camchain"),
    ("cam0: [unclosed\n", "not a YAML file"),
])
def test_reader_errors_name_the_file_and_the_key(tmp_path, text, msg):
    p = _write(tmp_path, text, "calib.yaml")
    with pytest.raises(CatadioptricError) as ei:
        read_kalibr(p)
    got = str(ei.value)
    assert got.startswith(f"{p}: ") and msg in got and "\n" not in got


def test_the_projects_own_export_reads_back_exactly(tmp_path):
    rig = preset("hyperboloid_central", width=160, height=120)
    p = _write(tmp_path, kalibr_camchain(rig))
    cam = load_camera(p)
    assert isinstance(cam, MeiCamera) and cam.size == (160, 120)
    u = unified_from_central(rig)
    assert u.K[0, 1] == 0.0  # the export drops the skew: zero for this rig
    uv = rig.pinhole.pixel_grid()
    exact = rig.backproject(uv)
    model = cam.backproject(uv)
    ok = exact.valid
    assert ok.sum() > 0.5 * ok.size and model.valid[ok].all()
    want = exact.directions[ok] @ (FLIP_Y @ u.R_sphere_from_mirror).T
    assert np.max(np.abs(model.directions[ok] - want)) <= 1e-12
