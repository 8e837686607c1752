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
