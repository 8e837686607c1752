"""Rig spec files: the files of render/rigs reproduce the presets exactly; errors name the key."""
import json
import tomllib

import numpy as np
import pytest

import catadioptric as cd
from catadioptric.rigs import preset, preset_names
from catadioptric.rigspec import RIG_DIR, load_rig, load_rig_spec, read_rig_spec, rig_from_spec, rig_names

PAPER_RIGS = ("sphere", "ellipsoid", "hyperboloid", "hyperboloid_central")


def assert_same_rig(a, b):
    assert a.mirror == b.mirror  # A, B, C, z_min, z_max exactly
    np.testing.assert_array_equal(a.pinhole.K, b.pinhole.K)
    assert (a.pinhole.width, a.pinhole.height) == (b.pinhole.width, b.pinhole.height)
    np.testing.assert_array_equal(a.center, b.center)
    np.testing.assert_array_equal(a.R_cam_from_mirror, b.R_cam_from_mirror)


@pytest.mark.parametrize("name", preset_names())
def test_rig_files_reproduce_the_presets_exactly(name):
    path = RIG_DIR / f"{name}.toml"
    assert path.is_file(), f"render/rigs/{name}.toml is missing"
    assert_same_rig(load_rig(path), preset(name))
    assert_same_rig(load_rig(name), preset(name))
    assert_same_rig(load_rig(name, width=320, height=240), preset(name, width=320, height=240))
    assert load_rig_spec(name)["name"] == name


def test_paper_configurations():
    kinds = {n: load_rig(n).mirror.kind for n in PAPER_RIGS}
    assert kinds == {"sphere": "sphere", "ellipsoid": "ellipsoid", "hyperboloid": "hyperboloid",
                     "hyperboloid_central": "hyperboloid"}
    assert [load_rig(n).is_central for n in PAPER_RIGS] == [False, False, False, True]
    np.testing.assert_allclose(load_rig("hyperboloid_central").viewpoint, [0, 0, 0.05], atol=1e-15)
    assert set(preset_names()) <= set(rig_names())


def _spec(name="hyperboloid"):
    return tomllib.loads((RIG_DIR / f"{name}.toml").read_text())


def test_json_equals_toml(tmp_path):
    p = tmp_path / "rig.json"
    p.write_text(json.dumps(_spec("ellipsoid")))
    assert_same_rig(load_rig(p), preset("ellipsoid"))
    assert load_rig_spec(p) == load_rig_spec("ellipsoid")


def test_normalised_spec_reads_back_to_itself():
    s = load_rig_spec("hyperboloid_9pct")
    assert read_rig_spec(json.loads(json.dumps(s))) == s
    assert s["camera"]["offset"] == [0.009, 0.0, 0.0] and s["camera"]["width"] == 640


def test_explicit_K_center_and_rotation_give_the_same_rig():
    ref = preset("hyperboloid")
    spec = {"mirror": {"kind": "quadric", "A": ref.mirror.A, "B": ref.mirror.B, "C": ref.mirror.C,
                       "z_min": ref.mirror.z_min, "z_max": ref.mirror.z_max},
            "camera": {"width": 640, "height": 480, "K": ref.pinhole.K.tolist(), "center": ref.center.tolist(),
                       "R_cam_from_mirror": ref.R_cam_from_mirror.tolist()}}
    assert_same_rig(rig_from_spec(read_rig_spec(spec)), ref)
    # a K rescaled with the image covers the same rays as the field of view re-derived at that size
    small = rig_from_spec(read_rig_spec(spec), width=320, height=240)
    np.testing.assert_allclose(small.pinhole.K, preset("hyperboloid", width=320, height=240).pinhole.K, rtol=1e-14)


def test_focus_and_other_mirror_kinds():
    spec = _spec()
    spec["camera"]["focus"] = "upper"
    spec["camera"]["offset"] = [0.0, 0.0, -0.2]
    cam = rig_from_spec(read_rig_spec(spec))
    np.testing.assert_allclose(cam.center, [0.0, 0.0, 0.05 - 0.2], atol=1e-15)
    para = {"mirror": {"kind": "paraboloid", "focal_length": 0.015, "z_min": 0.0, "z_max": 0.02},
            "camera": {"fov_x_deg": 20.0, "focus": "only", "offset": [0.0, 0.0, -0.3]}}
    np.testing.assert_allclose(rig_from_spec(read_rig_spec(para)).center, [0.0, 0.0, 0.015 - 0.3], atol=1e-15)
    cyl = {"mirror": {"kind": "cylinder", "radius": 0.02, "z_min": 0.0, "z_max": 0.05},
           "camera": {"fov_x_deg": 60.0, "center": [0.0, 0.0, -0.1]}}
    assert rig_from_spec(read_rig_spec(cyl)).mirror.kind == "cylinder"


def _err(mutate, match, name="hyperboloid"):
    spec = _spec(name)
    mutate(spec)
    with pytest.raises(cd.CatadioptricError, match=match):
        read_rig_spec(spec)


def test_rig_spec_errors_name_the_key():
    _err(lambda s: s["mirror"].update(a=-0.03), r"^rig\.mirror\.a: expected a positive number, got -0\.03$")
    _err(lambda s: s["mirror"].update(kind="torus"),
         r"^rig\.mirror\.kind: expected one of 'sphere', 'ellipsoid', 'hyperboloid', 'paraboloid', 'cone', "
         r"'cylinder', 'quadric', got 'torus'$")
    _err(lambda s: s["mirror"].update(radius=0.05), r"^rig\.mirror\.radius: unknown key; expected one of kind, a, c")
    _err(lambda s: s.pop("mirror"), r"^rig\.mirror: missing; expected a table$")
    _err(lambda s: s.update(mirror=3), r"^rig\.mirror: expected a table, got 3$")
    _err(lambda s: s["camera"].update(K=np.eye(3).tolist()), r"^rig\.camera: give one of fov_x_deg, K, not several")
    _err(lambda s: s["camera"].update(fov_x_deg=190.0),
         r"^rig\.camera\.fov_x_deg: expected a horizontal field of view in \(0, 180\) degrees, got 190\.0$")
    _err(lambda s: s["camera"].update(width=0), r"^rig\.camera\.width: expected an integer >= 1, got 0$")
    _err(lambda s: s["camera"].update(width=640.0), r"^rig\.camera\.width: expected an integer >= 1, got 640\.0$")
    _err(lambda s: s["camera"].update(focus="only"),
         r"^rig\.camera\.focus: a hyperboloid mirror has two foci: expected 'lower' or 'upper', got 'only'$")
    _err(lambda s: s["camera"].update(look_at=[1, 2]), r"^rig\.camera\.look_at: expected a list of 3 numbers, got \[1, 2\]$")
    _err(lambda s: s["camera"].update(center=[0, 0, 0]), r"^rig\.camera: give one of center, focus, not several")
    _err(lambda s: s["camera"].update(K=[[1, 2], [3, 4]]) or s["camera"].pop("fov_x_deg"),
         r"^rig\.camera\.K: expected a 3x3 matrix")
    _err(lambda s: s["camera"].update(K=[[500.0, 0, 320], [0, 500, 240], [0, 0, 2]]) or s["camera"].pop("fov_x_deg"),
         r"^rig\.camera: K: expected an upper-triangular intrinsic matrix with K\[2,2\] = 1")
    _err(lambda s: s["mirror"].update(z_min=0.2, z_max=0.1),
         r"^rig\.mirror: z_min, z_max: expected z_min < z_max, got z_min=0\.2 >= z_max=0\.1$")
    _err(lambda s: s["camera"].update(R_cam_from_mirror=np.eye(3).tolist()),
         r"^rig\.camera: give one of look_at, R_cam_from_mirror, not several")
    _err(lambda s: s["camera"].update(look_at=[0.004, 0.003, 0.25]),
         r"^rig\.camera: target: expected a point other than the centre", "sphere")
    _err(lambda s: s.update(name=7), r"^rig\.name: expected a string, got 7$")
    _err(lambda s: s["mirror"].update(kind="cone", half_angle_deg=35.0) or [s["mirror"].pop(k) for k in ("a", "c")],
         r"^rig\.camera\.focus: a cone mirror has no focus on its axis; give center instead$")
    # a camera centre on the mirror surface
    _err(lambda s: s["camera"].update(focus="lower", offset=[0.0, 0.0, 0.09]),
         r"^rig\.camera: center: the camera centre \[0\.0, 0\.0, 0\.04.*\] lies on the mirror surface")


def test_load_rig_errors(tmp_path):
    with pytest.raises(cd.CatadioptricError, match=r"^path_or_name: expected a rig spec file or one of \['cone', "):
        load_rig("hyperboloid_10pct")
    with pytest.raises(cd.CatadioptricError, match=r"^path_or_name: no rig spec file at"):
        load_rig(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[mirror\nkind = 'sphere'\n")
    with pytest.raises(cd.CatadioptricError, match=r"bad\.toml' is not a valid TOML file"):
        load_rig(bad)
    with pytest.raises(cd.CatadioptricError, match=r"^width: expected a positive integer number of pixels, got -5$"):
        load_rig("sphere", width=-5)
