"""Each convention of docs/conventions.md, pinned by a test."""
import numpy as np

import catadioptric as cd
from catadioptric.rigs import preset


def test_mirror_kinds_follow_the_parameters():
    assert cd.QuadricMirror(1.0, 0.0, 1.0, -1, 1).kind == "sphere"
    assert cd.QuadricMirror(0.5, 0.0, 1.0, -1, 1).kind == "ellipsoid"
    assert cd.QuadricMirror(0.0, -1.0, 0.0, 0, 1).kind == "paraboloid"  # the paper's Table 1 says ellipsoid
    assert cd.QuadricMirror(-0.5, 0.0, -1.0, 2, 3).kind == "hyperboloid"
    assert cd.QuadricMirror(-0.5, 0.0, 0.0, 0, 1).kind == "cone"
    assert cd.QuadricMirror(0.0, 0.0, 1.0, 0, 1).kind == "cylinder"
    assert cd.QuadricMirror.sphere(1.0, z_min=-1, z_max=1, center_z=0.3).kind == "sphere"


def test_named_constructors_and_foci():
    m = cd.QuadricMirror.hyperboloid(0.03, 0.04, z_min=0.04, z_max=0.08)
    assert np.allclose([f[2] for f in m.foci], [-0.05, 0.05])
    # a point of the surface: the vertex
    assert abs(m.implicit(np.array([0, 0, 0.04]))) < 1e-15
    e = cd.QuadricMirror.ellipsoid_from_foci(-0.03, 0.05, 0.02, z_min=0.0, z_max=0.05)
    assert np.allclose([f[2] for f in e.foci], [-0.03, 0.05])
    h = cd.QuadricMirror.hyperboloid_from_foci(-0.05, 0.05, 0.04, z_min=0.04, z_max=0.08)
    assert np.allclose([h.A, h.B, h.C], [m.A, m.B, m.C])
    p = cd.QuadricMirror.paraboloid(0.01, z_min=0.0, z_max=0.02, vertex_z=0.0, opening=+1)
    assert np.allclose(p.foci[0], [0, 0, 0.01])
    # a ray parallel to the axis reflects through the paraboloid's focus
    r = np.array([0.006, 0.0, 0.006**2 / 0.04])
    n = p.normal(r)
    n /= np.linalg.norm(n)
    d = np.array([0, 0, 1.0])
    out = d - 2 * (d @ n) * n
    assert np.linalg.norm(np.cross(out, p.foci[0] - r)) < 1e-15


def test_camera_frame_is_opencv_and_pixel_centres_are_integers():
    """x right, y down, z forward; the centre of pixel (col, row) is (u, v) = (col, row)."""
    pin = cd.PinholeCamera.from_fov(640, 480, 60)
    assert np.allclose(pin.K[:2, 2], [319.5, 239.5])  # centred principal point ((W-1)/2, (H-1)/2)
    assert np.allclose(pin.project(np.array([0, 0, 1.0])), [319.5, 239.5])
    f = pin.K[0, 0]
    assert np.allclose(pin.project(np.array([1.0, 0, 1.0])), [319.5 + f, 239.5])  # +x goes right
    assert np.allclose(pin.project(np.array([0, 1.0, 1.0])), [319.5, 239.5 + f])  # +y goes down
    assert pin.in_image(np.array([-0.5, -0.5])) and not pin.in_image(np.array([639.5, 0]))


def test_camera_placement():
    """X_cam = R_cam_from_mirror @ (X_M - center); look_at gives a right-handed OpenCV frame."""
    cam = preset("hyperboloid")
    X = np.array([0.01, 0.02, 0.05])
    assert np.allclose(cam.to_camera(X), cam.R_cam_from_mirror @ (X - cam.center))
    R = cd.look_at_rotation([0, 0, -1.0], [0, 0, 0], up=[0, 1, 0])
    assert np.allclose(R[2], [0, 0, 1])  # forward
    assert np.allclose(R[1], [0, -1, 0])  # image down = -up
    assert np.isclose(np.linalg.det(R), 1.0)


def test_world_frame_and_rig_pose():
    """x_M = R x_W + t; directions rotate only."""
    rng = np.random.default_rng(0)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.linalg.det(q))
    pose = cd.RigPose(q, np.array([0.1, -0.2, 0.3]))
    xw = rng.normal(size=(5, 3))
    assert np.allclose(pose.to_mirror(xw), xw @ q.T + [0.1, -0.2, 0.3])
    assert np.allclose(pose.to_world(pose.to_mirror(xw)), xw)
    assert np.allclose(pose.directions_to_mirror(xw), xw @ q.T)
    p2 = cd.RigPose.from_mirror_in_world(q.T, [1.0, 2.0, 3.0])
    assert np.allclose(p2.to_mirror([1.0, 2.0, 3.0]), 0)


def test_validity_flags():
    """valid: in the patch, unobstructed both ways, in front of the camera; padding is NaN."""
    cam = preset("sphere")
    behind = np.array([[0.0, 0.0, -1.0]])  # behind the sphere as seen from the camera: not seen
    pr = cam.project(behind)
    assert not pr.valid.any()
    rays = cam.backproject(np.array([[320.0, 240.0], [0.0, 0.0]]))
    assert rays.valid[0] and not rays.hit[1] and np.all(np.isnan(rays.origins[1]))


def test_central_flag():
    assert preset("hyperboloid_central").is_central
    assert preset("ellipsoid_central").is_central
    assert not preset("hyperboloid_9pct").is_central
    assert not preset("sphere").is_central and not preset("paraboloid").is_central
    assert preset("sphere_axial").is_axial and not preset("sphere").is_axial
