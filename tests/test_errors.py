"""Bad input gets an error that names the argument, what was expected and what was given."""
import numpy as np
import pytest

import catadioptric as cd
from catadioptric.rigs import preset


def test_wrong_shapes():
    cam = preset("hyperboloid")
    with pytest.raises(cd.CatadioptricError, match=r"points: expected an array of shape \(\.\.\., 3\), got an array of shape \(4, 2\)"):
        cam.project(np.zeros((4, 2)))
    with pytest.raises(cd.CatadioptricError, match=r"uv: expected an array of shape \(\.\.\., 2\), got an array of shape \(3,\)"):
        cam.backproject(np.zeros(3))


def test_nan_and_inf():
    cam = preset("sphere")
    with pytest.raises(cd.CatadioptricError, match=r"points: expected finite values, got nan at index \(1, 2\)"):
        cam.project(np.array([[0.1, 0.2, 0.3], [0.0, 0.0, np.nan]]))
    with pytest.raises(cd.CatadioptricError, match=r"uv: expected finite values, got inf at index \(0,\)"):
        cam.backproject(np.array([np.inf, 2.0]))


def test_empty_mirror_surface():
    with pytest.raises(cd.CatadioptricError, match=r"A, B, C: the surface is empty \(an ellipsoid needs C \+ B\^2/\(4A\) > 0, got -1.0"):
        cd.QuadricMirror(2.0, 0.0, -1.0, -1.0, 1.0)
    with pytest.raises(cd.CatadioptricError, match=r"C: a cylinder \(A = B = 0\) needs C > 0, got C=-0.5"):
        cd.QuadricMirror(0.0, 0.0, -0.5, -1.0, 1.0)
    with pytest.raises(cd.CatadioptricError, match=r"z_min, z_max: the patch z in \[2.0, 3.0\] holds no point of the surface"):
        cd.QuadricMirror.sphere(1.0, z_min=2.0, z_max=3.0)


def test_z_range():
    with pytest.raises(cd.CatadioptricError, match=r"z_min, z_max: expected z_min < z_max, got z_min=0.5 >= z_max=0.1"):
        cd.QuadricMirror.sphere(1.0, z_min=0.5, z_max=0.1)
    with pytest.raises(cd.CatadioptricError, match=r"z_max: expected a finite number, got nan"):
        cd.QuadricMirror(1.0, 0.0, 1.0, 0.0, float("nan"))


def test_camera_centre_on_the_mirror():
    m = cd.QuadricMirror.sphere(0.05, z_min=0.0, z_max=0.05)
    pin = cd.PinholeCamera.from_fov(64, 48, 40)
    with pytest.raises(cd.CatadioptricError, match=r"center: the camera centre \[0.0, 0.0, 0.05\] lies on the mirror surface"):
        cd.CatadioptricCamera(m, pin, np.array([0.0, 0.0, 0.05]), np.eye(3))


def test_singular_or_malformed_K():
    with pytest.raises(cd.CatadioptricError, match=r"K: expected an invertible intrinsic matrix, got a singular one"):
        cd.PinholeCamera(np.array([[100.0, 0, 32], [0, 0, 24], [0, 0, 1]]), 64, 48)
    with pytest.raises(cd.CatadioptricError, match=r"K: expected a 3x3 matrix, got an array of shape \(2, 3\)|K: expected an array of shape"):
        cd.PinholeCamera(np.zeros((2, 3)), 64, 48)
    with pytest.raises(cd.CatadioptricError, match=r"width: expected a positive integer number of pixels, got 0"):
        cd.PinholeCamera(np.eye(3), 0, 48)


def test_bad_rotation():
    m = cd.QuadricMirror.sphere(0.05, z_min=0.0, z_max=0.05)
    pin = cd.PinholeCamera.from_fov(64, 48, 40)
    with pytest.raises(cd.CatadioptricError, match=r"R_cam_from_mirror: expected a rotation matrix \(orthonormal, det \+1\), got one with"):
        cd.CatadioptricCamera(m, pin, np.array([0.0, 0.0, 0.3]), np.diag([1.0, 1.0, -1.0]))


def test_constructor_arguments():
    with pytest.raises(cd.CatadioptricError, match=r"radius: expected a positive number, got -1.0"):
        cd.QuadricMirror.sphere(-1.0, z_min=0.0, z_max=1.0)
    with pytest.raises(cd.CatadioptricError, match=r"half_angle: expected an angle in \(0, pi/2\) radians, got 2.0"):
        cd.QuadricMirror.cone(2.0, z_min=-1.0, z_max=0.0)
    with pytest.raises(cd.CatadioptricError, match=r"name: expected one of \["):
        preset("no-such-rig")


# ---------------------------------------------------------------- issue 12: every bad input refused by name
def _cam():
    return preset("hyperboloid_9pct", width=64, height=48)


K = np.array([[100.0, 0, 31.5], [0, 100.0, 23.5], [0, 0, 1]])
P = np.random.default_rng(0).normal(size=(4, 3))
N = np.array([0.0, 0.0, 1.0])
CASES = [
    # hangs that ate memory, and steps or counts of the wrong kind
    (lambda: _cam().vanishing_curve(N, max_step_px=0), r"max_step_px: expected a positive number, got 0.0"),
    (lambda: _cam().vanishing_curve(N, max_step_px=-1), r"max_step_px: expected a positive number, got -1.0"),
    (lambda: _cam().line_image(P[:1], P[1:2], max_step_px=0), r"max_step_px: expected a positive number"),
    (lambda: _cam().vanishing_curve(N, max_step_px=1e-320), r"max_step_px: expected a step of at least 1e-06 px"),
    (lambda: _cam().vanishing_curve(N, max_step_px=np.nan), r"max_step_px: expected a finite number, got nan"),
    (lambda: _cam().line_image(P[:1], P[1:2], max_step_px=np.inf), r"max_step_px: expected a finite number, got inf"),
    (lambda: _cam().vanishing_curve(N, max_step_px="1"), r"max_step_px: expected a real number, got '1'"),
    (lambda: _cam().vanishing_curve(N, n_start=0), r"n_start: expected an integer in \[2, 1000000\], got 0"),
    (lambda: _cam().vanishing_curve(N, n_start=1.5), r"n_start: expected an integer, got 1.5"),
    (lambda: _cam().vanishing_curve(N, n_start=10**12), r"n_start: expected an integer in \[2, 1000000\]"),
    (lambda: _cam().vanishing_curve(N, max_rounds=-3), r"max_rounds: expected an integer in \[0, 10000\], got -3"),
    (lambda: _cam().vanishing_curve(N, max_rounds=True), r"max_rounds: expected an integer, got True"),
    (lambda: _cam().line_image(P[:1], P[1:2], seed_step=0), r"seed_step: expected an integer in \[1, 1000000\], got 0"),
    (lambda: _cam().line_image(P[:1], P[1:2], seed_step=np.nan), r"seed_step: expected an integer, got nan"),
    (lambda: _cam().line_image(P[:1], P[1:2], n_start=-3), r"n_start: expected an integer in \[2, 1000000\], got -3"),
    # accepted though wrong: complex, bool, dates, strings
    (lambda: _cam().project(P + 1j), r"points: expected real numbers, got an array of dtype complex128"),
    (lambda: _cam().project(P > 0), r"points: expected real numbers, got an array of dtype bool"),
    (lambda: _cam().vanishing_points(np.full((2, 3), np.datetime64("2020-01-01"))),
     r"directions: expected real numbers, got an array of dtype datetime64\[D\]"),
    (lambda: _cam().backproject(np.full((2, 2), "1.0")), r"uv: expected real numbers, got an array of dtype <U3"),
    (lambda: _cam().directions_from_vanishing_points(np.zeros((2, 2), bool)),
     r"uv: expected real numbers, got an array of dtype bool"),
    (lambda: cd.PinholeCamera(K, True, 48), r"width: expected a positive integer number of pixels, got True"),
    (lambda: cd.QuadricMirror.paraboloid(0.01, 0.0, 0.02, opening=True), r"opening: expected \+1 \(opens to \+z\) or -1, got True"),
    (lambda: cd.PinholeCamera(np.diag([-100.0, 100.0, 1.0]), 64, 48), r"K: expected positive focal lengths K\[0,0\] > 0 and K\[1,1\] > 0"),
    (lambda: cd.QuadricMirror.sphere(1.0, 1.0, 2.0), r"z_min, z_max: the patch z in \[1.0, 2.0\] touches the surface at one height only"),
    (lambda: cd.QuadricMirror(True, 0.0, 1.0, -1.0, 0.0), r"A: expected a real number, got True"),
    # errors that named the wrong thing or none
    (lambda: cd.PinholeCamera.from_fov(0, 48, 40.0), r"width: expected a positive integer number of pixels, got 0"),
    (lambda: cd.PinholeCamera.from_fov("64", 48, 40.0), r"width: expected a positive integer number of pixels, got '64'"),
    (lambda: cd.CatadioptricCamera.looking_at_mirror(_cam().mirror, _cam().pinhole, [0, 0, -0.05], up=[np.nan, 0, 0]),
     r"up: expected finite values, got nan at index \(0,\)"),
    (lambda: cd.CatadioptricCamera.looking_at_mirror(_cam().mirror, _cam().pinhole, [0, 0, -0.05], up=[0, 0, 0]),
     r"up: expected a non-zero 3-vector, got \[0.0, 0.0, 0.0\]"),
    (lambda: cd.CatadioptricCamera.from_dict({"mirror": {}, "pinhole": {}}),
     r"d: expected a dict with keys \['mirror', 'pinhole', 'center', 'R_cam_from_mirror'\], got one without "
     r"\['center', 'R_cam_from_mirror'\]"),
    (lambda: cd.CatadioptricCamera.from_dict(dict(_cam().to_dict(), pinhole={"K": K.tolist()})),
     r"d\['pinhole'\]: expected a dict with keys \['K', 'width', 'height'\], got one without \['width', 'height'\]"),
    (lambda: _cam().segment_image(P, P[:2] + 1), r"p0, p1: expected the same number of end points, got 4 and 2"),
    (lambda: cd.QuadricMirror(1e300, 0.0, 1.0, -1e-160, 1e-160), r"A: expected \|A\| <= 1e\+06"),
    (lambda: cd.QuadricMirror.cylinder(1e-200, -1.0, 1.0), r"radius: expected a length between 1e-150 and 1e150"),
    (lambda: cd.QuadricMirror.sphere(1e200, -1.0, 1.0), r"radius: expected a length between 1e-150 and 1e150"),
    (lambda: cd.QuadricMirror(1.0, 1e300, 1.0, -1.0, 1.0), r"A, B, C: expected a surface whose size is a finite float"),
]


@pytest.mark.parametrize("call,message", CASES, ids=[str(i) for i in range(len(CASES))])
def test_bad_input_is_refused_by_name(call, message):
    with pytest.raises(cd.CatadioptricError, match=message):
        call()


# ---------------------------------------------------------------- issue 39: API edges
def test_a_camera_matrix_is_judged_relative_to_its_columns():
    """fx = fy = 1e-5 (condition number 1.5e8, determinant 1e-10) is an invertible camera matrix:
    accepted, its inverse exact to rounding; so is the matrix of a field of view near 180 degrees."""
    pin = cd.PinholeCamera(np.array([[1e-5, 0, 32.0], [0, 1e-5, 24.0], [0, 0, 1]]), 64, 48)
    np.testing.assert_allclose(pin.K_inv @ pin.K, np.eye(3), atol=1e-12)
    wide = cd.PinholeCamera.from_fov(64, 48, 179.9999)
    assert wide.K[0, 0] == pytest.approx(32.0 / np.tan(np.radians(179.9999) / 2), rel=1e-12)


ISSUE_39 = [
    (lambda: cd.PinholeCamera.from_fov(64, 48, 1e-320),
     r"fov_x_deg: expected a field of view in \(0, 180\) degrees that gives a finite, invertible focal length, got "
     r"1e-320 \(focal length inf px"),
    (lambda: cd.PinholeCamera.from_fov(64, 48, 180.0), r"fov_x_deg: expected a field of view below 180 degrees"),
    (lambda: cd.PinholeCamera(np.diag([1e-310, 1e-310, 1.0]), 64, 48),
     r"K: expected focal lengths whose inverse is finite \(at least about 1e-308, not subnormal\)"),
    (lambda: cd.PinholeCamera(np.array([[100.0, 0, 32], [0, 0, 24], [0, 0, 1]]), 64, 48),
     r"K: expected an invertible intrinsic matrix, got a singular one"),
    (lambda: __import__("catadioptric.linefit", fromlist=["fit_line"]).fit_line(
        preset("hyperboloid"), np.tile([[200.0, 300.0]], (10, 1))),
     r"uv: expected at least 5 distinct pixels \(a line's image spans several\), got 10 pixels at 1 distinct "
     r"position\(s\)"),
]


@pytest.mark.parametrize("call,message", ISSUE_39, ids=[str(i) for i in range(len(ISSUE_39))])
def test_api_edges_are_refused_by_name(call, message):
    with pytest.raises(cd.CatadioptricError, match=message):
        call()
