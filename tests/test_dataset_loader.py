"""catadioptric.Dataset: lazy per-view reading of a rendered dataset, done.json checks with clear
errors, and the optional outputs (ray and depth maps, 16-bit beauty, scene mesh)."""
import json
import os
import shutil

import cv2
import numpy as np
import pytest

import catadioptric as cd
from catadioptric.cli import main
from catadioptric.render.common import decode_labels_png
from catadioptric.rigspec import load_rig_spec
from catadioptric.scenes import build_scene


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("ds") / "tiny")
    assert main(["render", "tiny_street", "--out", out, "--resolution", "tiny", "--quality", "draft", "--rays",
                 "--beauty16", "--hdr", "--mesh", "--no-progress"]) == 0
    return out


@pytest.fixture
def copy(rendered, tmp_path):
    dst = str(tmp_path / "copy")
    shutil.copytree(rendered, dst)
    return dst


def test_lazy_views_by_position_and_name(rendered):
    ds = cd.Dataset(rendered)
    assert len(ds) == 2 and ds.names == ["A", "B"] and [v.name for v in ds] == ["A", "B"]
    v = ds["B"]
    assert v.name == ds[1].name == ds[-1].name == "B"
    assert repr(v) == "DatasetView('B', loaded ['folder', 'name'])"  # nothing read yet
    labels = v["labels"]
    assert repr(v) == "DatasetView('B', loaded ['folder', 'labels', 'name'])"
    png = cv2.imread(os.path.join(rendered, "B", "labels.png"), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(labels, decode_labels_png(png))
    assert labels.dtype == np.int32 and labels.shape == (120, 160)
    assert set(v) >= {"beauty", "labels", "curves", "vanishing_points", "camera", "pose", "depth", "beauty16"}
    with pytest.raises(KeyError, match=r"view: expected one of \['A', 'B'\], got 'C'"):
        ds["C"]
    with pytest.raises(IndexError):
        ds[2]


def test_view_contents_match_the_files(rendered):
    ds = cd.Dataset(rendered)
    v = dict(ds[0])  # reads everything
    gt = json.load(open(os.path.join(rendered, "A", "groundtruth.json")))
    assert v["groundtruth"] == gt and v["lines"] == gt["lines"] and v["families"] == gt["families"]
    assert v["camera"].to_dict() == cd.CatadioptricCamera.from_dict(gt["camera"]).to_dict()
    np.testing.assert_array_equal(v["pose"].R, np.array(gt["pose"]["R"]))
    bgr = cv2.imread(os.path.join(rendered, "A", "beauty.png"), cv2.IMREAD_COLOR)
    np.testing.assert_array_equal(v["beauty"], bgr[..., ::-1])
    with np.load(os.path.join(rendered, "A", "groundtruth.npz")) as z:
        off = z["line_curve_offsets"]
        assert len(v["curves"]) == len(off) - 1
        c = v["curves"][1]
        np.testing.assert_array_equal(c["uv"], z["line_uv"][off[1]:off[2]])
        assert c["segment"] == int(z["line_curve_segment"][1])
        np.testing.assert_array_equal(v["vanishing_points"]["uv"], z["vp_uv"])
        np.testing.assert_array_equal(v["label_ambiguous"], z["label_ambiguous"])
    # the 16-bit beauty is the same picture with 256 times the levels, both from the kept linear image
    b16 = v["beauty16"].astype(float) / 257.0
    assert v["beauty16"].dtype == np.uint16 and np.max(np.abs(b16 - v["beauty"])) <= 0.5 + 1e-9
    from catadioptric.render.common import linear_to_srgb8
    from catadioptric.render.extras import linear_to_srgb16

    hdr = v["beauty_hdr"]
    assert hdr.dtype == np.float32 and hdr.shape == (120, 160, 3) and hdr.max() > 0
    np.testing.assert_array_equal(linear_to_srgb8(hdr.astype(np.float64)), v["beauty"])
    np.testing.assert_array_equal(linear_to_srgb16(hdr.astype(np.float64)), v["beauty16"])


def test_ray_and_depth_maps(rendered):
    ds = cd.Dataset(rendered)
    v = ds[0]
    cam, pose = v["camera"], v["pose"]
    o, d, depth = v["ray_origins"], v["ray_directions"], v["depth"]
    assert o.shape == (120, 160, 3) and d.shape == (120, 160, 3) and depth.shape == (120, 160)
    rays = cam.backproject(cam.pinhole.pixel_grid())
    ok = rays.valid
    np.testing.assert_allclose(o[ok], rays.origins[ok], atol=1e-12)
    np.testing.assert_allclose(d[ok], rays.directions[ok], atol=1e-12)
    labels = v["labels"]
    assert np.all(np.isnan(depth[labels < 0])) and np.all(np.isinf(depth[labels == 0]))
    # the point at the depth lies on a triangle of the object the label image names
    scene = build_scene("tiny_street")
    objs = {o_.label: o_ for o_ in scene.objects}
    rows, cols = np.nonzero(labels > 0)
    pick = np.random.default_rng(0).choice(len(rows), 200, replace=False)
    for r, c in zip(rows[pick], cols[pick]):
        X_M = o[r, c] + depth[r, c] * d[r, c]
        X = pose.R.T @ (X_M - pose.t)
        ob = objs[int(labels[r, c])]
        tri = ob.vertices[ob.faces]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        dist = np.abs(np.sum((X - tri[:, 0]) * n, -1))
        assert dist.min() < 1e-8 * max(1.0, float(depth[r, c]))


def test_scene_mesh_and_manifest_rig_spec(rendered):
    import trimesh

    ds = cd.Dataset(rendered)
    assert ds.mesh_path == os.path.join(rendered, "scene.ply")
    m = trimesh.load(ds.mesh_path, process=False)
    raw = m.metadata["_ply_raw"]["face"]["data"]
    scene = build_scene("tiny_street")
    want = np.concatenate([np.full(len(o.faces), o.label) for o in scene.objects])
    np.testing.assert_array_equal(raw["label"], want)
    assert len(m.faces) == sum(len(o.faces) for o in scene.objects)
    np.testing.assert_allclose(m.vertices, np.concatenate([o.vertices for o in scene.objects]), atol=1e-4)
    # the scene's own rig is recorded with its normalised spec (docs/formats.md, manifest.json)
    assert ds.manifest["rig"]["name"] == "hyperboloid"
    assert ds.manifest["rig"]["spec"] == load_rig_spec("hyperboloid")


def test_unfinished_altered_and_missing(copy, tmp_path):
    with pytest.raises(ValueError, match=r"path: expected a dataset folder with manifest.json, got .* \(no manifest"):
        cd.Dataset(str(tmp_path))
    with pytest.raises(ValueError, match=r"path: expected a dataset folder .* which is not a folder"):
        cd.Dataset(str(tmp_path / "nope"))
    os.unlink(os.path.join(copy, "A", "done.json"))
    v = cd.Dataset(copy)["A"]
    with pytest.raises(ValueError, match=r"dataset: view 'A' of .* is unfinished \(no done.json: the render stopped "
                                         r"before this view was complete\); rerun the `catadioptric render` command"):
        v["labels"]
    p = os.path.join(copy, "B", "labels.png")
    with open(p, "r+b") as f:
        f.seek(60)
        f.write(b"\x00\x01")
    with pytest.raises(ValueError, match=r"dataset: view 'B' of .*: labels.png differs from the file the render "
                                         r"wrote \(SHA-256 mismatch: altered or corrupted\)"):
        cd.Dataset(copy)["B"]["beauty"]
    # verify=False skips the checksums, not the completion marker
    assert cd.Dataset(copy, verify=False)["B"]["beauty"].shape == (120, 160, 3)


@pytest.mark.parametrize("fname, key", [("groundtruth.npz", "curves"), ("rays.npz", "depth"),
                                        ("beauty_hdr.npz", "beauty_hdr")])
def test_truncated_archive_read_without_verify_names_the_file(copy, fname, key):
    """verify=False skips the checksums: an archive cut short is then an error naming its file, not
    a raw zipfile.BadZipFile (issue 39)."""
    p = os.path.join(copy, "A", fname)
    with open(p, "r+b") as f:
        f.truncate(os.path.getsize(p) // 2)
    with pytest.raises(cd.CatadioptricError, match=rf"dataset: view 'A': {fname} is not a readable \.npz archive "
                                                   r"\(BadZipFile: .*truncated or corrupted\); rerun the "):
        cd.Dataset(copy, verify=False)["A"][key]


def test_manifest_that_is_a_folder(tmp_path):
    (tmp_path / "manifest.json").mkdir()
    with pytest.raises(cd.CatadioptricError, match=r"path: expected a dataset folder with a manifest.json file, got "
                                                   r".*, whose manifest.json is a folder"):
        cd.Dataset(str(tmp_path))
