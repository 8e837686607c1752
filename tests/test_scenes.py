"""Scene generators and scene specs: determinism, segments on their tubes and hosts, families,
labels, closed meshes, views, and the errors of bad specs."""
import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest

import catadioptric as cd
from catadioptric.rigs import preset
from catadioptric.scenes import SPEC_DIR, build_scene, load_spec, read_scene_spec, scene_rig, views
from catadioptric.scenes.builder import canonical_direction
from catadioptric.scenes.spec import as_spec, board_frame, board_size

trimesh = pytest.importorskip("trimesh")

SCENES = SPEC_DIR  # the packaged scene specs (catadioptric/data/scenes)
TINY = SCENES / "tiny_street.toml"


@pytest.fixture(scope="module")
def tiny():
    return build_scene(TINY)


@pytest.fixture(scope="module")
def urban():
    return build_scene(SCENES / "urban_street.toml")


@pytest.fixture(scope="module")
def boards():
    return build_scene(SCENES / "chessboard.toml")


def _raw(path=TINY):
    import tomllib

    return tomllib.loads(Path(path).read_text())


# ------------------------------------------------------------------ helpers
def point_triangle_distance(p, tri):
    """Distances ``(P, T)`` from points ``(P, 3)`` to triangles ``(T, 3, 3)`` (brute force)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    rel = p[:, None, :] - a[None]
    h = np.sum(rel * n[None], axis=-1)
    q = p[:, None, :] - h[..., None] * n[None]  # projection on the plane

    def inside(q):
        s = []
        for u, v in ((a, b), (b, c), (c, a)):
            s.append(np.sum(np.cross(v - u, q - u[None]) * n[None], axis=-1))
        s = np.stack(s)
        return np.all(s >= -1e-12, axis=0) | np.all(s <= 1e-12, axis=0)

    def seg_dist(u, v):
        e = v - u
        t = np.clip(np.sum((p[:, None, :] - u[None]) * e[None], -1) / np.sum(e * e, -1)[None], 0, 1)
        return np.linalg.norm(p[:, None, :] - (u[None] + t[..., None] * e[None]), axis=-1)

    edge = np.minimum(np.minimum(seg_dist(a, b), seg_dist(b, c)), seg_dist(c, a))
    return np.where(inside(q), np.abs(h), edge)


def mesh_distance(points, obj):
    tri = obj.vertices[obj.faces]
    return point_triangle_distance(points, tri).min(axis=1)


def _same_scene(s1, s2):
    assert [o.name for o in s1.objects] == [o.name for o in s2.objects]
    for a, b in zip(s1.objects, s2.objects):
        assert a.label == b.label and a.kind == b.kind and a.color == b.color
        np.testing.assert_array_equal(a.vertices, b.vertices)
        np.testing.assert_array_equal(a.faces, b.faces)
    for k in ("segments", "segment_family", "families", "segment_label", "segment_radius", "segment_host", "sun"):
        np.testing.assert_array_equal(getattr(s1, k), getattr(s2, k))


# -------------------------------------------------------------- determinism
def test_same_seed_same_arrays(tiny):
    again = build_scene(TINY)
    _same_scene(tiny, again)
    assert again.seed == 3 and again.name == "tiny_street"


def test_other_seed_other_scene(tiny):
    other = build_scene(TINY, seed=4)
    assert other.seed == 4 and other.spec["seed"] == 3  # the override does not rewrite the spec
    assert len(other.segments) != len(tiny.segments) or not np.array_equal(other.segments, tiny.segments)
    _same_scene(other, build_scene(TINY, seed=4))


def test_spec_dict_and_path_give_the_same_scene(tiny):
    _same_scene(tiny, build_scene(load_spec(TINY)))
    _same_scene(tiny, build_scene("tiny_street"))


def test_normalised_spec_reads_back_to_itself_and_is_json():
    for name in ("tiny_street", "urban_street", "chessboard"):
        spec = load_spec(SCENES / f"{name}.toml")
        assert read_scene_spec(copy.deepcopy(spec)) == spec
        assert json.loads(json.dumps(spec)) == spec


# ------------------------------------------------------- segments and tubes
@pytest.mark.parametrize("name", ["tiny", "boards"])
def test_segments_are_the_axes_of_their_tubes(name, request):
    scene = request.getfixturevalue(name)
    by_label = {o.label: o for o in scene.objects}
    for (a, b), lab, r in zip(scene.segments, scene.segment_label, scene.segment_radius):
        tube = by_label[int(lab)]
        assert tube.kind == "line"
        n = len(tube.vertices) // 2
        np.testing.assert_allclose(tube.vertices[:n].mean(axis=0), a, atol=1e-12)  # cap centres = end points
        np.testing.assert_allclose(tube.vertices[n:].mean(axis=0), b, atol=1e-12)
        d = (b - a) / np.linalg.norm(b - a)
        rel = tube.vertices - a
        along = rel @ d
        np.testing.assert_allclose(along[:n], 0.0, atol=1e-12)
        np.testing.assert_allclose(along[n:], np.linalg.norm(b - a), atol=1e-12)
        across = np.linalg.norm(rel - along[:, None] * d, axis=1)
        assert np.all(across <= r * (1 + 1e-12)) and np.max(across) >= r * math.cos(math.pi / n) - 1e-12


@pytest.mark.parametrize("name", ["tiny", "boards"])
def test_segments_lie_on_their_host_meshes(name, request):
    scene = request.getfixturevalue(name)
    lines = scene.spec["lines"]
    by_label = {o.label: o for o in scene.objects}
    t = np.linspace(0.0, 1.0, 5)
    for (a, b), host, r in zip(scene.segments, scene.segment_host, scene.segment_radius):
        assert host > 0 and by_label[int(host)].kind != "line"
        pts = a + t[:, None] * (b - a)
        dist = mesh_distance(pts, by_label[int(host)])
        # on an edge of the host (distance 0) or drawn on one of its faces, lifted by at most r + clearance
        assert np.all(dist <= r + lines["clearance"] + 1e-9), dist


def test_segments_drawn_on_faces_clear_them(boards):
    """Grid lines of a board: in front of the board's plane by r * flatten + clearance, inside its squares."""
    spec = boards.spec
    lift = spec["lines"]["radius"] * spec["lines"]["flatten"] + spec["lines"]["clearance"]
    names = {o.label: o.name for o in boards.objects}
    for board in spec["chessboard"]["boards"]:
        R = board_frame(board)
        idx = [i for i, lab in enumerate(boards.segment_label) if names[int(lab)].startswith(board["name"] + ":")]
        assert len(idx) == (9 + 1) + (6 + 1)
        local = (boards.segments[idx] - np.array(board["center"])) @ R
        np.testing.assert_allclose(local[..., 2], lift, atol=1e-12)
        half = np.array([9, 6]) * spec["chessboard"]["square_size"] / 2
        assert np.all(np.abs(local[..., :2]) <= half + 1e-12)
        # the lines along v sit on the square boundaries, one square apart
        xs = np.sort(local[[k for k, i in enumerate(idx) if names[int(boards.segment_label[i])].split(":")[1][0] == "v"], 0, 0])
        np.testing.assert_allclose(np.diff(xs), spec["chessboard"]["square_size"], atol=1e-12)


# ----------------------------------------------------------------- families
@pytest.mark.parametrize("name", ["tiny", "urban", "boards"])
def test_families_unit_canonical_distinct_and_parallel(name, request):
    scene = request.getfixturevalue(name)
    F = scene.families
    np.testing.assert_allclose(np.linalg.norm(F, axis=1), 1.0, atol=1e-15)
    for f in F:
        np.testing.assert_array_equal(canonical_direction(f), f)
    cross = np.linalg.norm(np.cross(F[:, None], F[None]), axis=-1) + np.eye(len(F))
    assert cross.min() > 1e-6  # no two families are parallel
    d = scene.segment_directions()
    assert np.max(np.linalg.norm(np.cross(d, F[scene.segment_family]), axis=1)) < 1e-12
    assert set(scene.segment_family.tolist()) == set(range(len(F)))  # every family is used


def test_canonical_sign():
    np.testing.assert_array_equal(canonical_direction([0, 0, -2.0]), [0, 0, 1.0])
    np.testing.assert_array_equal(canonical_direction([3.0, -4.0, 0]), [-0.6, 0.8, 0.0])
    np.testing.assert_array_equal(canonical_direction([-1.0, 0, 0]), [1.0, 0.0, 0.0])
    with pytest.raises(cd.CatadioptricError, match=r"direction: expected a non-zero finite vector"):
        canonical_direction([0, 0, 0])


def test_street_has_the_expected_families(urban):
    F = urban.families
    for axis in np.eye(3):
        assert np.any(np.all(np.abs(F - axis) < 1e-12, axis=1))  # along the street, across, vertical
    slopes = np.abs(F[:, 2])
    assert np.any((slopes > 0.1) & (slopes < 0.99))  # rakes of gable roofs
    yawed = np.radians(12.0)
    assert np.any(np.linalg.norm(F - [math.cos(yawed), math.sin(yawed), 0.0], axis=1) < 1e-9)


# --------------------------------------------------------- labels and meshes
@pytest.mark.parametrize("name", ["tiny", "urban", "boards"])
def test_labels_unique_positive_and_tied_to_segments(name, request):
    scene = request.getfixturevalue(name)
    labels = scene.labels
    np.testing.assert_array_equal(labels, np.arange(1, len(labels) + 1))
    line_labels = sorted(o.label for o in scene.objects if o.kind == "line")
    assert sorted(scene.segment_label.tolist()) == line_labels  # one tube per segment, one segment per tube
    assert scene.triangle_count <= scene.spec["max_triangles"]
    ground = [o for o in scene.objects if o.kind == "ground"]
    assert len(ground) == 1 and len(ground[0].faces) == 2
    assert scene.validate() is scene


def test_solids_are_closed_and_outward(tiny, boards):
    for scene in (tiny, boards):
        for o in scene.objects:
            if o.kind == "ground" or o.name.endswith((":dark", ":light")):
                continue
            m = trimesh.Trimesh(o.vertices, o.faces)  # merges the duplicated vertices of each face
            assert m.is_watertight and m.is_winding_consistent and m.volume > 0, o.name


def test_street_content(urban):
    objs = urban.objects
    buildings = [o for o in objs if o.kind == "building" and ":" not in o.name]
    assert len(buildings) >= 8
    n_vertices = {len(o.vertices) for o in buildings}
    assert n_vertices - {8}, "expected some non-rectangular footprints (more than 8 vertices)"
    assert any(o.name.endswith(":roof") for o in objs if o.kind == "building")
    names = [o.name for o in objs if o.kind == "line"]
    for part in ("zebra", "lane", "stop", "edge", ":corner", ":window", ":floor", ":rake", ":curb"):
        assert any(part in n for n in names), part
    assert any(o.kind == "window" for o in objs)
    heights = [o.vertices[:, 2].max() for o in buildings]
    lo, hi = urban.spec["buildings"]["height_range"]
    curb = urban.spec["street"]["curb_height"]
    assert min(heights) >= curb + lo - 1e-9 and max(heights) <= curb + hi + 1e-9
    # no building reaches the sidewalk or the road
    edge = urban.spec["street"]["road_width"] / 2 + urban.spec["street"]["sidewalk_width"]
    assert min(np.abs(o.vertices[:, 1]).min() for o in buildings) >= edge - 1e-9


def test_markings_lie_on_the_road(urban):
    """Painted lines: flat tubes exactly ``width`` wide and ``thickness`` thick, resting on the road."""
    by_label = {o.label: o for o in urban.objects}
    m = urban.spec["markings"]
    half = urban.spec["street"]["road_width"] / 2
    count = 0
    for seg, lab in zip(urban.segments, urban.segment_label):
        tube = by_label[int(lab)]
        if not tube.name.startswith(("zebra", "lane", "stop", "edge")):
            continue
        count += 1
        width = m["stop_line_width"] if tube.name.startswith("stop") else (
            m["zebra_stripe_width"] if tube.name.startswith("zebra") else m["width"])
        z = tube.vertices[:, 2]
        np.testing.assert_allclose([z.min(), z.max()], [urban.spec["lines"]["clearance"],
                                                        urban.spec["lines"]["clearance"] + m["thickness"]], atol=1e-12)
        d = (seg[1] - seg[0]) / np.linalg.norm(seg[1] - seg[0])
        side = np.cross([0.0, 0.0, 1.0], d)
        w = (tube.vertices - seg[0]) @ side
        np.testing.assert_allclose([w.min(), w.max()], [-width / 2, width / 2], atol=1e-12)
        assert np.all(np.abs(seg[:, 1]) <= half)
    assert count > 30


def test_scene_validate_catches_broken_scenes(tiny):
    broken = copy.copy(tiny)
    broken.segments = tiny.segments.copy()
    d = tiny.segment_directions()[3]
    broken.segments[3, 1] += 0.01 * np.cross(d, [0.6, 0.0, 0.8] if abs(d[1]) > 0.5 else [0.0, 1.0, 0.0])
    with pytest.raises(cd.CatadioptricError, match=r"segments\[3\]: not parallel to its family"):
        broken.validate()
    broken = copy.copy(tiny)
    broken.objects = tiny.objects + [tiny.objects[0]]
    with pytest.raises(cd.CatadioptricError, match=r"objects: expected unique labels, label 1 is used 2 times"):
        broken.validate()


# ------------------------------------------------------------- views and rig
def test_views_place_the_mirror_frame():
    vs = views("urban_street")
    assert [n for n, _ in vs] == ["A", "B"]
    (_, a), (_, b) = vs
    np.testing.assert_allclose(a.origin_in_world, [-3.0, -1.8, 2.0], atol=1e-12)
    np.testing.assert_allclose(a.R, np.eye(3), atol=1e-15)  # mirror axis = world vertical
    np.testing.assert_allclose(b.to_mirror([4.0, 0.4, 2.0]), 0.0, atol=1e-12)
    # yaw 15 then pitch 2 degrees: the mirror's x axis in W
    x_M_in_W = b.directions_to_world([1.0, 0.0, 0.0])
    c, s = math.cos(math.radians(2.0)), math.sin(math.radians(2.0))
    np.testing.assert_allclose(x_M_in_W, [c * math.cos(math.radians(15)), c * math.sin(math.radians(15)), -s],
                               atol=1e-12)


def test_scene_rig_is_the_preset():
    cam = scene_rig(SCENES / "urban_street.toml")
    ref = preset("hyperboloid")
    assert cam.mirror == ref.mirror
    np.testing.assert_array_equal(cam.center, ref.center)
    assert scene_rig(SCENES / "chessboard.toml", width=320, height=240).pinhole.width == 320


def test_inline_rig_table():
    raw = _raw()
    raw["rig"] = {"mirror": {"kind": "sphere", "radius": 0.05, "z_min": 0.015, "z_max": 0.05},
                  "camera": {"fov_x_deg": 26.0, "center": [0.004, 0.003, 0.25], "look_at": [0.0, 0.0, 0.03]}}
    cam = scene_rig(raw)
    ref = preset("sphere")
    assert cam.mirror == ref.mirror
    np.testing.assert_array_equal(cam.R_cam_from_mirror, ref.R_cam_from_mirror)
    raw["rig"]["mirror"]["radius"] = -1.0
    with pytest.raises(cd.CatadioptricError, match=r"^scene\.rig\.mirror\.radius: expected a positive number, got -1\.0"):
        read_scene_spec(raw)


# ----------------------------------------------------------- spec errors
def _err(mutate, match, path=TINY):
    raw = _raw(path)
    mutate(raw)
    with pytest.raises(cd.CatadioptricError, match=match):
        build_scene(raw)


def test_spec_errors_name_the_key():
    _err(lambda r: r["buildings"].update(height_range=[5, 2]),
         r"^scene\.buildings\.height_range: expected two increasing positive numbers, got \[5, 2\]$")
    _err(lambda r: r["buildings"].update(heigth_range=[5, 8]),
         r"^scene\.buildings\.heigth_range: unknown key; expected one of width_range, depth_range, height_range")
    _err(lambda r: r.update(colour=1), r"^scene\.colour: unknown key")
    _err(lambda r: r["street"].update(lanes=2.5), r"^scene\.street\.lanes: expected an integer in \[1, 100\], got 2\.5$")
    _err(lambda r: r["street"].update(lanes=0), r"^scene\.street\.lanes: expected an integer in \[1, 100\], got 0$")
    _err(lambda r: r["street"].update(road_width=-8.0),
         r"^scene\.street\.road_width: expected a positive number, got -8\.0$")
    _err(lambda r: r["street"].update(length="long"), r"^scene\.street\.length: expected a positive number, got 'long'$")
    _err(lambda r: r["windows"].update(lines="yes"), r"^scene\.windows\.lines: expected true or false, got 'yes'$")
    _err(lambda r: r["windows"].update(facades="some"),
         r"^scene\.windows\.facades: expected one of 'street', 'all', 'none', got 'some'$")
    _err(lambda r: r["buildings"].update(footprints={"rect": 1.0, "round": 1.0}),
         r"^scene\.buildings\.footprints\.round: unknown key; expected one of rect, L, chamfer$")
    _err(lambda r: r["buildings"].update(footprints={"rect": 0.0}),
         r"^scene\.buildings\.footprints: expected a table of weights >= 0 over rect, L, chamfer")
    _err(lambda r: r.setdefault("ground", {}).update(color=[1.2, 0, 0]),
         r"^scene\.ground\.color: expected an RGB colour: three numbers in \[0, 1\], got \[1\.2, 0, 0\]$")
    _err(lambda r: r.update(generator="forest"),
         r"^scene\.generator: expected one of 'street', 'chessboard', got 'forest'$")
    _err(lambda r: r.pop("generator"), r"^scene\.generator: missing; expected one of 'street', 'chessboard'$")
    _err(lambda r: r.update(seed=-1), r"^scene\.seed: expected an integer >= 0, got -1$")
    _err(lambda r: r["lines"].update(sides=2), r"^scene\.lines\.sides: expected an integer in \[3, 64\], got 2$")
    _err(lambda r: r.update(views={"name": "A"}), r"^scene\.views: expected an array of tables \(\[\[views\]\]\), got a table$")


def test_spec_cross_checks():
    _err(lambda r: r["views"][1].update(position=[3.0, 9.0, 1.8]),
         r"^scene\.views\[1\]\.position: expected a point above the street \(\|x\| <= 15\.0, \|y\| < road_width/2 "
         r"\+ sidewalk_width = 7\.0, z > 0\), got \[3\.0, 9\.0, 1\.8\]$")
    _err(lambda r: r["views"][1].pop("position"), r"^scene\.views\[1\]\.position: missing; expected a list of 3 numbers$")
    _err(lambda r: r["views"][1].update(name="A"), r"^scene\.views\[1\]\.name: duplicate view name 'A'$")
    _err(lambda r: r["views"][0].update(R_world_from_mirror=[[1, 0, 0], [0, 1, 0], [0, 0, -1]]),
         r"^scene\.views\[0\]\.R_world_from_mirror: expected a rotation matrix")
    _err(lambda r: r["views"][0].update(R_world_from_mirror=np.eye(3).tolist(), yaw_deg=3.0),
         r"^scene\.views\[0\]: give one of R_world_from_mirror, yaw_deg, not several")
    _err(lambda r: r["windows"].update(height=2.5),
         r"^scene\.windows\.height: expected sill \+ height below buildings\.floor_height = 3\.0, got 0\.9 \+ 2\.5$")
    _err(lambda r: r["street"].update(block_depth=10.0),
         r"^scene\.street\.block_depth: expected more than sidewalk_width \+ setback_range\[1\] \+ depth_range\[1\]")
    _err(lambda r: r["buildings"].update(yaw_weights=[1.0]),
         r"^scene\.buildings\.yaw_weights: expected 2 weights >= 0 \(one per yaw_deg\)")
    _err(lambda r: r["lines"].update(radius=0.5), r"^scene\.lines\.radius: expected less than a quarter of the window size")
    _err(lambda r: r.update(max_triangles=500),
         r"^scene\.max_triangles: the scene would have at least \d+ triangles, more than max_triangles = 500")
    _err(lambda r: r.update(rig="no_such_rig"), r"^scene\.rig: path_or_name: expected a rig spec file or one of \[")


def test_chessboard_spec_errors():
    cb = SCENES / "chessboard.toml"
    _err(lambda r: r["chessboard"].update(squares=[0, 5]),
         r"^scene\.chessboard\.squares: expected a list of 2 integers >= 1, got \[0, 5\]$", cb)
    _err(lambda r: r["chessboard"]["boards"][3].update(center=[0.9, -0.9, 0.0]),
         r"^scene\.chessboard\.boards\[3\]\.center: the board reaches below the ground \(lowest point z = -0\.01 m\)",
         cb)
    _err(lambda r: r["chessboard"]["boards"][1].update(tilt_deg=200.0),
         r"^scene\.chessboard\.boards\[1\]\.tilt_deg: expected an angle in \[0, 180\] degrees, got 200\.0$", cb)
    _err(lambda r: r["chessboard"].update(boards=[]),
         r"^scene\.chessboard\.boards: expected an array of tables \(\[\[boards\]\]\) with at least 1, got \[\]$", cb)
    _err(lambda r: r["chessboard"].pop("boards"), r"^scene\.chessboard\.boards: missing", cb)


def test_sizes_are_bounded_before_anything_is_built(monkeypatch):
    """Scenes that never finished: a street of 1e308 m looped for ever (x + 38 == x), 1e6 m ran for
    minutes; a 3000 x 3000 chessboard took 11 s and 3 GB before the triangle check. Refused at once,
    from counts known before any mesh is made."""
    import catadioptric.scenes.builder as builder

    made = []
    monkeypatch.setattr(builder.SceneBuilder, "add_mesh", lambda self, *a, **k: made.append(a[0]))
    for length in (1e308, 1e6):
        _err(lambda r: r["street"].update(length=length),
             r"^scene\.street\.length: a street of .* m has at least .* blocks .* more than max_triangles = 20000")
    cb = SCENES / "chessboard.toml"
    _err(lambda r: r["chessboard"].update(squares=[3000, 3000], square_size=1e-4),
         r"^scene\.max_triangles: the scene would have at least \d{8} triangles \(4 boards\), more than "
         r"max_triangles = 20000", cb)
    assert made == []
    _err(lambda r: r.update(max_triangles=10**12),
         r"^scene\.max_triangles: expected an integer in \[1, 50000000\], got 1000000000000$")


def test_generators_stop_at_the_limit_as_they_go():
    """Windows are counted before they are made, every mesh and tube as it is added: a street whose
    blocks are few but whose facades hold millions of windows stops at the limit."""
    _err(lambda r: (r["street"].update(block_length_range=[1e6, 2e6], length=3e6),
                    r["buildings"].update(width_range=[5e5, 8e5])),
         r"^scene\.max_triangles: the scene would have at least \d+ triangles( \(.* windows on .*\))?, more than")


def test_load_spec_errors(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("name = \n")
    with pytest.raises(cd.CatadioptricError, match=r"is not a valid TOML file"):
        load_spec(bad)
    with pytest.raises(cd.CatadioptricError, match=r"path: cannot read spec file"):
        load_spec(tmp_path / "missing.toml")
    with pytest.raises(cd.CatadioptricError, match=r"spec: expected a scene spec file or one of \[.*'tiny_street'"):
        build_scene("no_such_scene")
    with pytest.raises(cd.CatadioptricError, match=r"seed: expected an integer >= 0, got -3"):
        build_scene(TINY, seed=-3)
    j = tmp_path / "tiny.json"
    j.write_text(json.dumps(_raw()))
    spec = load_spec(j)
    assert spec["source"] == str(j.resolve()) and spec["buildings"]["yaw_deg"] == [0.0, 10.0]


def test_overlapping_windows_and_a_view_inside_a_board_are_refused():
    """Issue 39: windows closer than their width (overlapping panes, labels off the tracer) and a
    view inside a chessboard (the board seen through the mirror from within) are spec errors
    naming the key."""
    _err(lambda r: r["windows"].update(spacing=1.0),
         r"^scene\.windows\.spacing: expected more than width = 1\.2 \+ 2 lines\.radius = 1\.3 \(the distance "
         r"between neighbouring windows' centres; less overlaps their panes\), got 1\.0$")
    _err(lambda r: r["windows"].update(spacing=1.2, lines=False), r"^scene\.windows\.spacing: expected more than "
         r"width = 1\.2 \(the distance")
    raw = _raw(TINY)
    raw["windows"].update(spacing=1.0, facades="none")  # no windows: no panes to overlap
    build_scene(raw)
    cb = SCENES / "chessboard.toml"
    raw = _raw(cb)
    b = raw["chessboard"]["boards"][0]
    spec = as_spec(raw)
    board = spec["chessboard"]["boards"][0]
    inside = (np.asarray(board["center"]) - 0.5 * board_size(spec, board)[3] * board_frame(board)[:, 2]).tolist()
    _err(lambda r: r["views"][0].update(position=inside),
         rf"^scene\.views\[0\]\.position: expected a point outside every chessboard, got \[.*\], inside the board "
         rf"{b.get('name', 'board0')!r} \(the mirror would see the board from within\)$", cb)
