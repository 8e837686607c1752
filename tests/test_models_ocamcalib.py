"""OCamCalib's polynomial model (``ScaramuzzaCamera``) and its ``calib_results.txt`` reader and
writer, on pyomniunwarp's example (``tests/data/ocamcalib``, MIT licence): the reader with and
without pyomniunwarp's ROI and crop blocks, the crop offset, ``cam2world`` / ``world2cam``
against the OCamCalib C code's formulas written here independently (with its (row, column)
pixel order), the write / read round trip, the ROI, and how far the tool's ``invpol`` is from the
inverse of its ``ss``.

Tolerances: the C code's formulas agree with the model's to float64 rounding (the same
operations; the crop offset adds one rounding of the centre column, half an ulp of ~1000 px).
The invpol / ss mismatch is held to OCamCalib's own tolerance for its fit of ``invpol``
(``findinvpoly`` raises the degree until the fit's error is below 0.01 px) plus the rounding of
the coefficients as the file prints them (bounded in the test from the printed digits)."""
from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from catadioptric._checks import CatadioptricError
from catadioptric.formats import calibration_format, load_camera
from catadioptric.formats.ocamcalib import ocamcalib_text, read_ocamcalib
from catadioptric.models import MODELS, ScaramuzzaCamera, model_from_dict

DATA = Path(__file__).parent / "data" / "ocamcalib"
EPS = np.finfo(float).eps
#: float64 rounding of pixel coordinates below 2048 px through a few dozen operations
ROUND_PX = 2048 * EPS * 64
#: float64 rounding of unit directions computed from such pixels
ROUND_DIR = 1e-13
#: OCamCalib's stop criterion for its fit of invpol (findinvpoly: error below 0.01 px)
OCAMCALIB_FIT_PX = 0.01

# the example file's numbers, as printed
SS = [-2.665880e+02, 0.000000e+00, 1.220001e-03, -5.781730e-07, 2.003631e-09]
INVPOL = [443.183827, 308.133563, 28.505708, 27.497972, 26.856912, 9.619478, 1.117213, 2.966127, 3.206510,
          2.026977, 0.948490, 0.200601]
XC, YC = 545.872616, 674.318875
C, D, E = 0.999998, 0.000003, 0.000026
HEIGHT, WIDTH = 1080, 1300
LEFT, RIGHT = 300, 320
RMAX, RMIN = 600.0, 235.0


# ------------------------------------------------------------------ the C code's formulas
def c_cam2world(point2D, pol=SS, xc=XC, yc=YC, c=C, d=D, e=E):
    """OCamCalib's ocam_functions.c cam2world, one point (row, column) -> (x, y, z)."""
    invdet = 1 / (c - d * e)
    xp = invdet * ((point2D[0] - xc) - d * (point2D[1] - yc))
    yp = invdet * (-e * (point2D[0] - xc) + c * (point2D[1] - yc))
    r = math.sqrt(xp * xp + yp * yp)
    zp = pol[0]
    r_i = 1.0
    for i in range(1, len(pol)):
        r_i *= r
        zp += r_i * pol[i]
    invnorm = 1 / math.sqrt(xp * xp + yp * yp + zp * zp)
    return [invnorm * xp, invnorm * yp, invnorm * zp]


def c_world2cam(point3D, invpol=INVPOL, xc=XC, yc=YC, c=C, d=D, e=E):
    """OCamCalib's ocam_functions.c world2cam, one point (x, y, z) -> (row, column)."""
    norm = math.sqrt(point3D[0] * point3D[0] + point3D[1] * point3D[1])
    if norm == 0:
        return [xc, yc]
    theta = math.atan(point3D[2] / norm)
    invnorm = 1 / norm
    rho = invpol[0]
    t_i = 1.0
    for i in range(1, len(invpol)):
        t_i *= theta
        rho += t_i * invpol[i]
    x = point3D[0] * invnorm * rho
    y = point3D[1] * invnorm * rho
    return [x * c + y * d + xc, x * e + y + yc]


# ------------------------------------------------------------------ fixtures
@pytest.fixture(scope="module")
def full():
    """The file as committed (with pyomniunwarp's ROI and crop blocks)."""
    return read_ocamcalib(DATA / "calib_results.txt")


@pytest.fixture()
def plain_path(tmp_path):
    """A copy without pyomniunwarp's two blocks: what OCamCalib itself writes."""
    text = (DATA / "calib_results.txt").read_text()
    cut = text.index("#ROI max min radius")
    p = tmp_path / "calib_results.txt"
    p.write_text(text[:cut])
    return p


def _samples(n, seed, height=HEIGHT, width=WIDTH):
    rng = np.random.default_rng(seed)
    return rng.uniform([-0.5, -0.5], [height - 0.5, width - 0.5], (n, 2))  # (row, column)


# ------------------------------------------------------------------ reader
def test_reader_without_pyomniunwarps_blocks(plain_path):
    assert calibration_format(plain_path) == "ocamcalib"
    cam = load_camera(plain_path)
    assert isinstance(cam, ScaramuzzaCamera) and MODELS["ocamcalib"] is ScaramuzzaCamera
    assert cam.size == (WIDTH, HEIGHT) and cam.roi is None and cam.crop == (0, 0)
    assert cam.ss == tuple(SS) and cam.invpol == tuple(INVPOL)
    assert (cam.xc, cam.yc, cam.c, cam.d, cam.e) == (XC, YC, C, D, E)


def test_reader_with_them_gives_the_full_photograph(full):
    assert full.crop == (LEFT, RIGHT)
    assert full.size == (WIDTH + LEFT + RIGHT, HEIGHT) == (1920, 1080)
    assert full.xc == XC and full.yc == YC + LEFT
    assert full.roi == (YC + LEFT, XC, RMIN, RMAX)
    img = cv2.imread(str(DATA / "example.jpg"))
    assert img.shape[:2] == (full.height, full.width)  # the photograph the camera is of


# ------------------------------------------------------------------ the C code's formulas
def test_lift_is_cam2world_in_row_column_order(plain_path, full):
    plain = read_ocamcalib(plain_path)
    rc = _samples(1500, 0)
    want = np.array([c_cam2world(p) for p in rc])
    uv = rc[:, ::-1]  # our pixels: (u, v) = (column, row)
    X, ok = plain.lift(uv)
    assert ok.all() and np.max(np.abs(X - want)) <= ROUND_DIR
    # the full photograph's camera: the same rays, columns shifted by the crop
    Xf, okf = full.lift(uv + [LEFT, 0])
    assert okf.all() and np.max(np.abs(Xf - want)) <= ROUND_DIR
    assert np.array_equal(full.cam2world(rc + [0, LEFT]), Xf)


def test_project_unit_is_world2cam_in_row_column_order(plain_path, full):
    plain = read_ocamcalib(plain_path)
    rng = np.random.default_rng(1)
    X = rng.normal(size=(1500, 3))
    X /= np.linalg.norm(X, axis=1, keepdims=True)
    X[:, 2] = -np.abs(X[:, 2])  # the half the camera sees (elevations below 0)
    X /= np.linalg.norm(X, axis=1, keepdims=True)
    want = np.array([c_world2cam(p) for p in X])  # (row, column)
    uv, ok = plain.project_unit(X)
    assert ok.all() and np.max(np.abs(uv - want[:, ::-1])) <= ROUND_PX
    uvf, okf = full.project_unit(X)
    assert okf.all() and np.max(np.abs(uvf - (want[:, ::-1] + [LEFT, 0]))) <= ROUND_PX
    # the C code puts the axis on the centre
    uv0, ok0 = plain.project_unit(np.array([[0.0, 0.0, -1.0]]))
    assert ok0.all() and np.array_equal(uv0, [[YC, XC]])


def test_directions_are_in_ocamcalibs_own_frame(full):
    u0, v0 = full.yc, full.xc
    X, ok = full.lift(np.array([[u0, v0], [u0, v0 + 300.0], [u0 + 300.0, v0]]))
    assert ok.all()
    np.testing.assert_allclose(X[0], [0.0, 0.0, -1.0], atol=ROUND_DIR)  # the camera looks along -z
    assert X[1, 0] > 0 and abs(X[1, 1]) < 1e-4  # down the rows: +x
    assert X[2, 1] > 0 and abs(X[2, 0]) < 1e-4  # along the columns: +y
    # what has no image: the direction opposite the centre, and elevations above the image's
    assert not full.project_unit(np.array([[0.0, 0.0, 1.0]]))[1].any()
    t = full.theta_max + 0.01
    assert not full.project_unit(np.array([[np.cos(t), 0.0, np.sin(t)]]))[1].any()


# ------------------------------------------------------------------ writer
def test_write_read_round_trip_is_exact(full, plain_path, tmp_path):
    for cam in (full, read_ocamcalib(plain_path)):
        p = tmp_path / "again.txt"
        p.write_text(ocamcalib_text(cam))
        again = load_camera(p)
        assert isinstance(again, ScaramuzzaCamera) and again.to_dict() == cam.to_dict()
        assert model_from_dict(cam.to_dict()).to_dict() == cam.to_dict()
    text = ocamcalib_text(full)
    assert "#left right cropped pixel\n\n300 320" in text and "\n1080 1300\n" in text
    assert "#ROI max min radius\n\n600.0 235.0" in text


# ------------------------------------------------------------------ ROI and the tool's mismatch
def test_the_roi_bounds_the_image_region(full):
    reg = full.region()
    uv = full.pixel_grid()
    u0, v0, rmin, rmax = full.roi
    r = np.hypot(uv[..., 0] - u0, uv[..., 1] - v0)
    assert not reg[(r < rmin) | (r > rmax)].any()
    assert reg.any()


def _rounding_bound_px(rmax):
    """What printing the coefficients to the file's digits can move a round trip, up to radius
    ``rmax``: invpol's 6 decimals (each off by at most 5e-7, times theta^k, |theta| <= pi/2) plus
    ss's 7 significant digits (each off by at most 5e-7 relative, times rho^k) carried into the
    elevation and through invpol's slope."""
    t = np.linspace(-np.pi / 2, np.pi / 2, 2001)
    b_inv = 5e-7 * sum(np.abs(t) ** k for k in range(len(INVPOL))).max()
    slope = np.abs(sum(k * a * t ** (k - 1) for k, a in enumerate(INVPOL) if k)).max()
    r = np.linspace(1.0, rmax, 2001)
    z = sum(a * r ** k for k, a in enumerate(SS))
    dz = 5e-7 * sum(abs(a) * r ** k for k, a in enumerate(SS))
    b_ss = (dz * r / (r * r + z * z) * slope).max()
    return float(b_inv + b_ss)


def test_invpol_is_the_inverse_of_ss_to_the_tools_tolerance_over_the_roi(full):
    uv = full.pixel_grid()
    u0, v0, rmin, rmax = full.roi
    r = np.hypot(uv[..., 0] - u0, uv[..., 1] - v0)
    inside = (r >= rmin) & (r <= rmax)
    X, ok = full.lift(uv[inside])
    back, okb = full.project_unit(X)
    assert ok.all() and okb.all()
    err = np.linalg.norm(back - uv[inside], axis=-1)
    bound = OCAMCALIB_FIT_PX + _rounding_bound_px(rmax)
    assert bound < 0.02  # the stated bound itself: "well under a pixel"
    assert err.max() <= bound
    # and not an exact inverse: the two polynomials are the tool's, fitted separately
    assert err.max() > 1e3 * ROUND_PX


# ------------------------------------------------------------------ errors
@pytest.mark.parametrize("cut,msg", [
    ("#polynomial coefficients for the inverse mapping", "the invpol block (world2cam polynomial): missing"),
    ("#polynomial coefficients for the DIRECT mapping", "the ss block (cam2world polynomial): missing"),
    ("#affine parameters", "the affine block (c, d, e): missing"),
    ("#image size", "the image size block (height and width): missing"),
    ("#center", "the center block (row and column): missing"),
])
def test_a_missing_block_is_named(tmp_path, cut, msg):
    text = (DATA / "calib_results.txt").read_text()
    blocks = text.split("\n\n#")
    kept = [b for b in blocks if not ("#" + b).startswith(cut) and not b.startswith(cut)]
    p = tmp_path / "calib_results.txt"
    p.write_text("\n\n#".join(kept))
    with pytest.raises(CatadioptricError) as ei:
        read_ocamcalib(p)
    got = str(ei.value)
    assert got == f"{p}: {msg}"


def test_malformed_blocks_are_named(tmp_path):
    text = (DATA / "calib_results.txt").read_text()
    p = tmp_path / "calib_results.txt"
    p.write_text(text.replace("\n12 443.183827", "\n13 443.183827"))
    with pytest.raises(CatadioptricError, match=r": the invpol block \(world2cam polynomial\): expected 13 "
                                                r"coefficients \(its first number\), got 12$"):
        read_ocamcalib(p)
    p.write_text(text.replace("1080 1300", "1080 13x0"))
    with pytest.raises(CatadioptricError, match=r": the image size block \(height and width\): expected numbers, "
                                                r"got '13x0'$"):
        read_ocamcalib(p)
    p.write_text(text.replace("-2.665880e+02", "2.665880e+02"))
    with pytest.raises(CatadioptricError, match=r"calib_results.txt: ss: expected a negative constant term"):
        read_ocamcalib(p)

