"""The images' agreement under a rotation (catadioptric.photometric), on the OCamCalib room
committed in tests/data/ocamcalib (MIT): its photograph against itself, and against itself turned by
a known rotation through its own calibration."""
from pathlib import Path

import cv2
import numpy as np
import pytest

from catadioptric import CatadioptricError
from catadioptric.formats import load_camera
from catadioptric.photometric import rotation_agreement

OCAM = Path(__file__).resolve().parent / "data" / "ocamcalib"


@pytest.fixture(scope="module")
def room():
    cam = load_camera(OCAM / "calib_results.txt")
    img = cv2.cvtColor(cv2.imread(str(OCAM / "example.jpg")), cv2.COLOR_BGR2RGB)
    return cam, img


def _rot(axis, deg):
    from scipy.spatial.transform import Rotation

    return Rotation.from_rotvec(np.radians(deg) * np.asarray(axis, float) / np.linalg.norm(axis)).as_matrix()


def _turned(cam, img, R, parallax=(0.0, 0.0, 0.0)):
    """The photograph that the camera turned by ``R`` (``x_B = R x_A + t``) would take of the room at
    infinity (or, with a ``parallax`` ``t / D``, of a room at one distance ``D`` from B): each pixel of
    B shows what A sees along ``R^T (d_B - t / D)`` (black where A sees nothing)."""
    H, W = img.shape[:2]
    uv = np.stack(np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float)), -1).reshape(-1, 2)
    rays = cam.backproject(uv)
    d = np.where(rays.valid[:, None], rays.directions, [0.0, 0.0, 1.0]) - np.asarray(parallax, float)
    vp = cam.vanishing_points(d / np.linalg.norm(d, axis=-1, keepdims=True) @ R)
    ok = rays.valid & vp.valid[:, 0] & vp.in_image[:, 0]
    m = np.where(ok[:, None], vp.uv[:, 0], -1e4).astype(np.float32)
    out = cv2.remap(img, m[:, 0].reshape(H, W), m[:, 1].reshape(H, W), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    return out, ok.reshape(H, W)


def test_an_image_agrees_with_itself_under_the_identity_only(room):
    cam, img = room
    turns = [np.eye(3), _rot([0, 0, 1], 90), _rot([0, 0, 1], 180), _rot([1, 0, 0], 180)]
    a = rotation_agreement(img, img, cam, cam, turns)
    # the identity: each sampled pixel read back at its own centre (the model's round trip, bilinear)
    assert a[0] > 0.999
    assert np.all(a[1:] < a[0] - 0.2), a


def test_the_turn_is_x_b_equals_r_x_a(room):
    """Image B made from A by a known turn ``R`` agrees with A under ``R``, not under ``R^T`` nor
    ``R`` followed by the half-turns a Manhattan room's directions allow."""
    cam, img = room
    R = _rot([0.3, -0.2, 1.0], 35)
    img_b, seen = _turned(cam, img, R)
    mask_b = (seen * 255).astype(np.uint8)
    rivals = [R, R.T, R @ _rot([0, 0, 1], 180), R @ _rot([1, 0, 0], 180), R @ _rot([0, 0, 1], 90)]
    a = rotation_agreement(img, img_b, cam, cam, rivals, masks=(None, mask_b))
    assert a[0] > 0.98, a
    assert np.all(a[1:] < a[0] - 0.2), a


def test_bad_input_is_named(room):
    cam, img = room
    with pytest.raises(CatadioptricError, match="rotations: expected finite"):
        rotation_agreement(img, img, cam, cam, np.eye(3))
    with pytest.raises(CatadioptricError, match="image_b's mask: expected the image's size"):
        rotation_agreement(img, img, cam, cam, [np.eye(3)], masks=(None, np.ones((10, 10), np.uint8)))
    with pytest.raises(CatadioptricError, match="image_a: expected the camera's size"):
        rotation_agreement(img[:100], img, cam, cam, [np.eye(3)])
    from catadioptric.photometric import RotationAgreement

    judge = RotationAgreement(img, img, cam, cam)
    bad = r"R_other: expected a finite \(3, 3\) rotation matrix, got shape \(1, 3, 3\)"
    with pytest.raises(CatadioptricError, match=bad):
        judge.margin(np.eye(3), np.eye(3)[None])
    with pytest.raises(CatadioptricError, match="R: expected a finite"):
        judge.agreement(np.full((3, 3), np.nan))
    # nothing of B seen in A: no agreement measured
    none = np.zeros(img.shape[:2], np.uint8)
    assert np.isnan(rotation_agreement(img, img, cam, cam, [np.eye(3)], masks=(none, None))[0])


def test_the_rotation_where_the_images_agree_best_is_found_near_a_wrong_one(room):
    """:meth:`RotationAgreement.best_near` from a rotation 8 degrees off the turn that made image B
    comes back to that turn (within a degree) and its agreement."""
    from catadioptric.photometric import RotationAgreement
    from catadioptric.pose import rotation_angle_deg

    cam, img = room
    R = _rot([0.3, -0.2, 1.0], 35)
    img_b, seen = _turned(cam, img, R)
    judge = RotationAgreement(img, img_b, cam, cam, masks=(None, (seen * 255).astype(np.uint8)))
    R_off = _rot([1.0, 1.0, 0.0], 8) @ R
    R_best, a_best = judge.best_near(R_off)
    assert rotation_angle_deg(R_best @ R.T) < 1.0, rotation_angle_deg(R_best @ R.T)
    assert a_best > 0.98 and a_best > judge(R_off[None])[0] + 0.2



def test_the_parallax_where_the_images_agree_best_is_the_one_that_made_b(room):
    """Image B made from A by a turn ``R`` and a parallax ``p = t / D`` (the room at one distance ``D``
    from B): :meth:`RotationAgreement.parallax` under ``R`` finds ``p`` (within 0.05, a sixth of the
    spacing of its grid of directions at that length: its search from the grid's best converged) and
    the images agree there far better than with the room at infinity; with no parallax given,
    :meth:`~RotationAgreement.at` is the call's agreement."""
    from catadioptric.photometric import RotationAgreement

    cam, img = room
    R, p = _rot([0.3, -0.2, 1.0], 35), 0.3 * np.array([0.6, 0.8, 0.0])
    img_b, seen = _turned(cam, img, R, p)
    # every 16th pixel of B: the search's few hundred agreements in seconds
    judge = RotationAgreement(img, img_b, cam, cam, masks=(None, (seen * 255).astype(np.uint8)), step=16)
    assert judge.at(R) == judge(R[None])[0]
    assert judge.at(R, np.zeros(3)) == pytest.approx(judge.at(R), abs=1e-12)  # B's rays normalised again
    here, found = judge.parallax(R)
    assert np.linalg.norm(found - p) < 0.05, found
    assert here > 0.98 and here > judge.at(R) + 0.1 and here == judge.at(R, found)
    assert judge.at(R, -p) < here - 0.1  # the other way round is another picture
    with pytest.raises(CatadioptricError, match=r"parallax: expected a finite \(3,\) vector, got shape \(2,\)"):
        judge.at(R, np.zeros(2))


def test_the_turned_image_shows_what_a_sees_along_r_transposed_d_b(room):
    """:func:`turned_image` of an image A whose every pixel shows its own ray's direction (three
    levels, ``128 + 100 d_A``): at each pixel of B it shows ``128 + 100 R^T d_B``, to within the most
    the field changes between two neighbouring pixels of A (what a bilinear read can miss), and
    nothing (NaN) where B sees nothing; a step repeats its top-left pixel over each block."""
    from catadioptric.detect.region import mirror_region
    from catadioptric.photometric import turned_image

    cam, img = room
    H, W = img.shape[:2]
    uv = np.stack(np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float)), -1).reshape(-1, 2)
    rays = cam.backproject(uv)
    d = np.where(rays.valid[:, None], rays.directions, np.nan).reshape(H, W, 3)
    field = 128.0 + 100.0 * d
    step_px = max(np.nanmax(np.abs(np.diff(field, axis=0))), np.nanmax(np.abs(np.diff(field, axis=1))))
    assert step_px < 2.0  # a smooth field: the bound below is a fraction of its range (200 levels)
    image_a = np.nan_to_num(field, nan=0.0) / 255.0
    R = _rot([0.3, -0.2, 1.0], 35)
    out = turned_image(image_a, cam, cam, R)
    want = 128.0 + 100.0 * d @ R  # R^T d_B for each pixel's ray
    shown = np.isfinite(out[..., 0])
    assert shown.mean() > 0.3 and not np.any(shown & ~mirror_region(cam, erode_px=0))
    assert np.nanmax(np.abs(out - want)[shown]) <= step_px
    # the other way round it is not: the turn is x_B = R x_A
    wrong = turned_image(image_a, cam, cam, R.T)
    assert np.nanmedian(np.abs(wrong - want)[np.isfinite(wrong[..., 0])]) > 20 * step_px
    coarse = turned_image(image_a, cam, cam, R, step=3)
    np.testing.assert_array_equal(coarse[::3, ::3], out[::3, ::3])
    np.testing.assert_array_equal(coarse[1::3, 2::3], out[:-1:3, :-2:3])


def test_the_margin_and_its_jackknife_error_over_blocks_of_b(room):
    """:meth:`RotationAgreement.margin`: the difference of the two agreements, and its standard error
    by the jackknife over the blocks of B's sampled rays, each block left out by masking its pixels
    in image B (an independent route: a new judge per block); :meth:`RotationAgreement.agreement`:
    one rotation's agreement and its standard error the same way."""
    from catadioptric.photometric import BLOCKS, RotationAgreement

    cam, img = room
    R = _rot([0.3, -0.2, 1.0], 35)
    img_b, seen = _turned(cam, img, R)
    mask_b = (seen * 255).astype(np.uint8)
    judge = RotationAgreement(img, img_b, cam, cam, masks=(None, mask_b))
    rival = R @ _rot([0, 0, 1], 180)
    m, se = judge.margin(R, rival)
    a = judge(np.stack([R, rival]))
    assert m == pytest.approx(a[0] - a[1], abs=1e-12)
    assert set(np.unique(judge.blocks)) <= set(range(BLOCKS[0] * BLOCKS[1])) and len(np.unique(judge.blocks)) > 8
    theta, single = [], []
    for b in np.unique(judge.blocks):
        mask = mask_b.copy()
        uv = judge.uv_b[judge.blocks == b].astype(int)
        mask[uv[:, 1], uv[:, 0]] = 0
        ab = rotation_agreement(img, img_b, cam, cam, [R, rival], masks=(None, mask))
        theta.append(ab[0] - ab[1])
        single.append(ab[1])
    theta, single = np.array(theta), np.array(single)
    k = len(theta)
    assert se == pytest.approx(np.sqrt((k - 1) / k * np.sum((theta - theta.mean()) ** 2)), rel=1e-9)
    a_r, se_r = judge.agreement(rival)
    assert a_r == pytest.approx(a[1], abs=1e-12)
    assert se_r == pytest.approx(np.sqrt((k - 1) / k * np.sum((single - single.mean()) ** 2)), rel=1e-9)
    # B made by the turn itself: the right rotation leads by far more than its own error
    assert m > 0.5 and m > 5 * se, (m, se)
    # nothing of B seen in A under one of them: nothing measured
    none = np.zeros(img.shape[:2], np.uint8)
    blind = RotationAgreement(img, img_b, cam, cam, masks=(none, mask_b))
    assert np.isnan(blind.margin(R, rival)).all() and np.isnan(blind.agreement(R)).all()
