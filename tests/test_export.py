"""Exports against the tools' own formulas: OpenCV omnidir (read back with cv2.FileStorage and
projected with cv2.omnidir.projectPoints), Kalibr's omni + radtan and COLMAP's EUCM (their
projection formulas written here from the tools' documentation), for a central rig exactly and
for a non-central one through its best central approximation."""
import json

import cv2
import numpy as np
import pytest
import yaml

from catadioptric.centrality import angular_error_map
from catadioptric.cli import main
from catadioptric.export import (FLIP_Y, central_model, colmap_camera_line, colmap_parameters, export_rig,
                                 kalibr_camchain, kalibr_parameters, opencv_yaml)
from catadioptric.rigs import preset
from catadioptric.unified import fit_unified

W, H = 160, 120


@pytest.fixture(scope="module")
def central():
    cam = preset("hyperboloid_central", width=W, height=H)
    return cam, central_model(cam, rig="hyperboloid_central")


@pytest.fixture(scope="module")
def noncentral():
    cam = preset("hyperboloid_9pct", width=W, height=H)
    return cam, central_model(cam, rig="hyperboloid_9pct")


def _points(cam, n=3000, seed=0):
    """Points the rig sees: along exact rays of random pixels, 0.5 to 30 m from the mirror."""
    rng = np.random.default_rng(seed)
    uv = rng.uniform([-0.5, -0.5], [W - 0.5, H - 0.5], (n, 2))
    r = cam.backproject(uv)
    ok = r.valid
    return uv[ok], r.origins[ok] + rng.uniform(0.5, 30.0, (ok.sum(), 1)) * r.directions[ok]


def _exact_pixels(cam, X):
    pr = cam.project(X)
    return pr.uv[:, 0], pr.valid[:, 0]


# ------------------------------------------------------------------ OpenCV
def _read_opencv(path):
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    out = {k: fs.getNode(k).mat() for k in ("camera_matrix", "distortion_coefficients", "xi", "rvec", "tvec")}
    out["size"] = (int(fs.getNode("image_width").real()), int(fs.getNode("image_height").real()))
    fs.release()
    return out


def test_opencv_yaml_is_read_by_filestorage_into_omnidir_exactly(central, tmp_path):
    cam, m = central
    assert m.exact and m.fit is None and m.angular_error_deg["max"] < 1e-9
    path = tmp_path / "cam.yaml"
    path.write_text(opencv_yaml(m))
    p = _read_opencv(path)
    assert p["size"] == (W, H) and p["xi"].shape == (1, 1) and not p["distortion_coefficients"].any()
    uv, X = _points(cam)
    img, _ = cv2.omnidir.projectPoints(X.reshape(-1, 1, 3), p["rvec"], p["tvec"], p["camera_matrix"], p["xi"][0, 0],
                                       p["distortion_coefficients"])
    exact, ok = _exact_pixels(cam, X)
    assert ok.all()
    assert np.max(np.linalg.norm(img.reshape(-1, 2) - exact, axis=-1)) < 1e-9
    assert np.max(np.linalg.norm(exact - uv, axis=-1)) < 1e-6


def test_opencv_yaml_of_a_noncentral_rig_states_how_far_it_is(noncentral, tmp_path):
    cam, m = noncentral
    assert not m.exact
    text = opencv_yaml(m)
    # the figures are the centrality report's for the pure (omnidir) approximation, same samples
    fit = fit_unified(cam, step=4, tilt=False)
    err = angular_error_map(cam, fit.camera, 4)[0]
    assert m.angular_error_deg["max"] == pytest.approx(np.nanmax(err), rel=1e-6)
    assert m.angular_error_deg["max"] > 5.0  # about 14 degrees at 640x480 (docs/unified.md)
    assert f"per-pixel angular error max {m.angular_error_deg['max']:.4g} deg" in text
    path = tmp_path / "cam.yaml"
    path.write_text(text)
    p = _read_opencv(path)
    uv, X = _points(cam)
    img, _ = cv2.omnidir.projectPoints(X.reshape(-1, 1, 3), p["rvec"], p["tvec"], p["camera_matrix"], p["xi"][0, 0],
                                       p["distortion_coefficients"])
    model = m.camera.project(X)
    assert np.max(np.linalg.norm(img.reshape(-1, 2)[model.valid] - model.uv[model.valid], axis=-1)) < 1e-9


# ------------------------------------------------------------------ Kalibr
def _kalibr_omni_radtan(Xc, intrinsics, dist):
    """Kalibr's omni camera (aslam_cv OmniProjection, Mei's model) with radtan distortion, from
    Kalibr's documentation of the camchain: intrinsics [xi, fu, fv, pu, pv];
    m = (x, y) / (z + xi |X|); radtan [k1, k2, r1, r2] on m; pixel = (fu m_x + pu, fv m_y + pv)."""
    xi, fu, fv, pu, pv = intrinsics
    k1, k2, r1, r2 = dist
    d = np.linalg.norm(Xc, axis=-1)
    rz = 1.0 / (Xc[:, 2] + xi * d)
    mx, my = Xc[:, 0] * rz, Xc[:, 1] * rz
    r2_ = mx * mx + my * my
    rad = k1 * r2_ + k2 * r2_ * r2_
    dx = mx * rad + 2 * r1 * mx * my + r2 * (r2_ + 2 * mx * mx)
    dy = my * rad + r1 * (r2_ + 2 * my * my) + 2 * r2 * mx * my
    return np.stack([fu * (mx + dx) + pu, fv * (my + dy) + pv], -1)


def _camchain(text):
    block = yaml.safe_load(text)["cam0"]
    assert block["camera_model"] == "omni" and block["distortion_model"] == "radtan"
    return block


@pytest.mark.parametrize("which", ["central", "noncentral"])
def test_kalibr_camchain_against_kalibrs_formula(which, central, noncentral):
    cam, m = central if which == "central" else noncentral
    text = kalibr_camchain(m)
    b = _camchain(text)
    k = kalibr_parameters(m)
    xi, fu, fv, pu, pv = b["intrinsics"]
    assert fu > 0 and fv > 0 and b["resolution"] == [W, H]
    # the frame of the export: x_cam = R (x_M - viewpoint), R = diag(1, -1, 1) R_sphere (a reflection)
    R = np.array(k["R_cam_from_mirror"])
    assert np.linalg.det(R) == pytest.approx(-1.0)
    np.testing.assert_array_equal(R, FLIP_Y @ m.camera.R_sphere_from_mirror)
    uv, X = _points(cam)
    Xc = (X - np.array(k["viewpoint_M"])) @ R.T
    kal = _kalibr_omni_radtan(Xc, b["intrinsics"], b["distortion_coeffs"])
    model = m.camera.project(X)
    shift = np.linalg.norm(kal[model.valid] - model.uv[model.valid], axis=-1)
    # Kalibr has no skew: the only difference from the model is the dropped skew, as stated
    assert np.max(shift) <= k["skew_dropped_px"]["max_px"] + 1e-9
    if which == "central":
        exact, ok = _exact_pixels(cam, X)
        assert k["skew"] == 0.0 and np.max(np.linalg.norm(kal - exact, axis=-1)) < 1e-9
        assert "central, exported exactly" in text
    else:
        assert k["skew"] != 0.0 and 0 < np.max(shift)
        assert f"moves pixels by at most {k['skew_dropped_px']['max_px']:.3g} px" in text


# ------------------------------------------------------------------ COLMAP
def _colmap_eucm(Xc, params):
    """COLMAP's EUCM camera (cameras.txt parameters fx, fy, cx, cy, alpha, beta; COLMAP's
    sensor/models.h): rho = sqrt(beta (x^2 + y^2) + z^2), d = alpha rho + (1 - alpha) z,
    pixel = (fx x / d + cx, fy y / d + cy); no image for z <= 0. COLMAP's pixel centres are at +0.5."""
    fx, fy, cx, cy, alpha, beta = params
    x, y, z = Xc[:, 0], Xc[:, 1], Xc[:, 2]
    rho = np.sqrt(beta * (x * x + y * y) + z * z)
    d = alpha * rho + (1 - alpha) * z
    uv = np.stack([fx * x / d + cx, fy * y / d + cy], -1)
    return uv, z > np.finfo(float).eps


@pytest.mark.parametrize("which", ["central", "noncentral"])
def test_colmap_line_against_colmaps_formula(which, central, noncentral):
    cam, m = central if which == "central" else noncentral
    text = colmap_camera_line(m, camera_id=3)
    line = [ln for ln in text.splitlines() if not ln.startswith("#")]
    assert len(line) == 1
    f = line[0].split()
    assert f[:4] == ["3", "EUCM", str(W), str(H)] and len(f) == 10
    params = [float(x) for x in f[4:]]
    assert params[0] > 0 and params[1] > 0 and params[5] == 1.0 and 0 <= params[4] <= 1
    c = colmap_parameters(m)
    R, t = np.array(c["R_cam_from_mirror"]), np.array(c["viewpoint_M"])
    uv, X = _points(cam)
    col, seen = _colmap_eucm((X - t) @ R.T, params)
    col = col - 0.5  # back to this project's (OpenCV's) pixel centres
    model = m.camera.project(X)
    both = seen & model.valid
    assert both.sum() > 100
    shift = np.linalg.norm(col[both] - model.uv[both], axis=-1)
    assert np.max(shift) <= c["skew_dropped_px"]["max_px"] + 1e-9
    if which == "central":
        exact, _ = _exact_pixels(cam, X)
        assert np.max(np.linalg.norm(col[seen] - exact[seen], axis=-1)) < 1e-9
    # the field of view COLMAP loses, as stated: the rig's pixels whose ray has z <= 0 in COLMAP's frame
    r = m.camera.backproject(m.pixels)
    zc = (r.directions @ R.T)[:, 2]
    assert c["lost_pixels"] == int(np.sum(~(zc > 0))) and c["pixels"] == len(m.pixels)
    assert 0 < c["lost_pixels"] < c["pixels"]
    assert f"{c['lost_pixels']} of {c['pixels']} sampled pixels of the rig" in text
    # and COLMAP indeed drops the points seen through those pixels
    assert not np.any(seen[model.valid & ~(((X - t) @ R.T)[:, 2] > np.finfo(float).eps)])


# ------------------------------------------------------------------ JSON and the command
def test_json_and_the_command(tmp_path, capsys):
    out = tmp_path / "c.json"
    assert main(["export", "--rig", "hyperboloid_central", "--format", "json", "--out", str(out), "--width", str(W),
                 "--height", str(H)]) == 0
    d = json.loads(out.read_text())
    assert d["exact"] and d["opencv"]["D"] == [0.0, 0.0, 0.0, 0.0] and d["colmap"]["model"] == "EUCM"
    assert "central, exported exactly" in capsys.readouterr().err
    assert main(["export", "--rig", "hyperboloid_central", "--format", "opencv-yaml", "--width", str(W),
                 "--height", str(H)]) == 0
    assert capsys.readouterr().out.startswith("%YAML:1.0\n---\n")
    assert main(["export", "--rig", "hyperboloid_central", "--format", "kalibr", "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err.strip() == f"catadioptric: error: --out: expected a file path, got {str(tmp_path)!r}"
    with pytest.raises(ValueError, match=r"format: expected one of \['opencv', 'kalibr', 'colmap', 'json'\], got 'x'"):
        export_rig(preset("hyperboloid_central", width=W, height=H), "x")
