"""Scene spec files (TOML or JSON): reading, checking, defaults, views and the rig.

The format is documented in ``docs/formats.md`` ("Scene specs"); the named specs
(``urban_street``, ...) are package data (``catadioptric/data/scenes``, :data:`SPEC_DIR`). Every error is a :class:`CatadioptricError`
whose message starts with the key's path from the root ``scene``, e.g.
``scene.buildings.height_range: expected two increasing positive numbers, got [5, 2]``.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .._checks import CatadioptricError
from ..frames import RigPose
from .._data import data_names, data_path
from ..rigspec import read_rig_spec
from ..spectable import REQUIRED, SpecTable, read_spec_file

__all__ = ["GENERATORS", "SPEC_DIR", "spec_path", "spec_names", "read_scene_spec", "load_spec", "as_spec", "views", "scene_rig", "view_rotation",
           "sun_direction"]

GENERATORS = ("street", "chessboard")
FOOTPRINTS = ("rect", "L", "chamfer")
FACADES = ("street", "all", "none")

_BUILDING_PALETTE = [
    [0.72, 0.64, 0.55], [0.80, 0.76, 0.68], [0.62, 0.45, 0.38], [0.70, 0.70, 0.72],
    [0.85, 0.80, 0.62], [0.55, 0.58, 0.60], [0.76, 0.58, 0.45], [0.66, 0.70, 0.62],
]


# ---------------------------------------------------------------- shared tables
def _read_sun(t: SpecTable) -> None:
    t.number("azimuth_deg", 135.0, what="an azimuth in degrees")
    t.number("elevation_deg", 50.0, min=0.0, max=90.0, min_open=True,
             what="an elevation in (0, 90] degrees")


def _read_ground(t: SpecTable, size: float, color) -> None:
    t.number("size", size, positive=True)
    t.color("color", color)


def _read_lines(t: SpecTable, radius: float, flatten: float) -> None:
    t.number("radius", radius, positive=True)
    t.integer("sides", 6, min=3, max=64)
    t.number("clearance", 0.002, nonnegative=True)
    t.number("flatten", flatten, min=0.0, max=1.0, min_open=True)
    t.color("color", None)


def _read_view(t: SpecTable, i: int) -> None:
    t.string("name", f"view{i}")
    t.vector("position", REQUIRED)
    t.exclusive("R_world_from_mirror", "yaw_deg")
    t.exclusive("R_world_from_mirror", "pitch_deg")
    t.exclusive("R_world_from_mirror", "roll_deg")
    if t.has("R_world_from_mirror"):
        t.matrix("R_world_from_mirror")
    else:
        t.number("yaw_deg", 0.0, what="an angle in degrees")
        t.number("pitch_deg", 0.0, what="an angle in degrees")
        t.number("roll_deg", 0.0, what="an angle in degrees")


MAX_GENERATED_VIEWS = 1_000_000  # views of one [[view_paths]] or [[random_views]] table
MAX_TRIANGLES = 50_000_000  # a scene of more does not fit the renderers' memory on a common machine


def _read_view_path(t: SpecTable, i: int) -> None:
    t.string("name", f"path{i}")
    t.integer("count", REQUIRED, min=1, max=MAX_GENERATED_VIEWS)
    raw = t.raw("points")
    what = "a list of at least 2 points (3 numbers each)"
    if raw is None:
        raise t.error("points", f"missing; expected {what}")
    if not (isinstance(raw, (list, tuple)) and len(raw) >= 2):
        raise t.error("points", f"expected {what}, got {raw!r}")
    pts = np.array(t.matrix("points", REQUIRED, rows=len(raw), cols=3))
    if not np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)) > 0:
        raise t.error("points", f"expected a path of positive length, got {raw!r}")
    t.number("yaw_deg", 0.0, what="an angle in degrees")
    t.number("pitch_deg", 0.0, what="an angle in degrees")
    t.number("roll_deg", 0.0, what="an angle in degrees")
    t.boolean("yaw_follows_path", False)


def _read_random_views(t: SpecTable, i: int) -> None:
    t.string("name", f"random{i}")
    t.integer("count", REQUIRED, min=1, max=MAX_GENERATED_VIEWS)
    t.integer("seed", 0, min=0)
    lo = t.vector("position_min", REQUIRED)
    hi = t.vector("position_max", REQUIRED)
    if not all(a <= b for a, b in zip(lo, hi)):
        raise t.error("position_max", f"expected at least position_min = {lo!r} in every coordinate, got {hi!r}")
    for key, default in (("yaw_deg", [0.0, 360.0]), ("pitch_deg", [0.0, 0.0]), ("roll_deg", [0.0, 0.0])):
        r = t.numbers(key, default, length=2, what="an angle range [low, high] in degrees")
        if not r[0] <= r[1]:
            raise t.error(key, f"expected an angle range [low, high] in degrees with low <= high, got {r!r}")


def _read_rig(t: SpecTable) -> None:
    raw = t.raw("rig")
    if raw is None or isinstance(raw, str):
        t.string("rig", None)
    else:
        t.nested("rig", read_rig_spec)


# -------------------------------------------------------------------- street
def _read_street_tables(t: SpecTable) -> None:
    s = t.table("street")
    s.number("length", 120.0, positive=True)
    s.number("road_width", 8.0, positive=True)
    s.integer("lanes", 2, min=1, max=100)
    s.number("sidewalk_width", 3.0, positive=True)
    s.number("curb_height", 0.15, positive=True)
    s.range("block_length_range", [35.0, 50.0])
    s.number("cross_street_width", 8.0, positive=True)
    s.number("block_depth", 30.0, positive=True)
    s.string("sides", "both", choices=("both", "north", "south"))
    s.color("sidewalk_color", [0.62, 0.61, 0.58])

    b = t.table("buildings")
    b.range("width_range", [8.0, 18.0])
    b.range("depth_range", [8.0, 14.0])
    b.range("height_range", [6.0, 22.0])
    b.range("gap_range", [1.0, 4.0], nonnegative=True)
    b.range("setback_range", [0.0, 1.5], nonnegative=True)
    b.number("floor_height", 3.0, positive=True)
    b.weights("footprints", {"rect": 0.5, "L": 0.3, "chamfer": 0.2}, FOOTPRINTS)
    b.numbers("yaw_deg", [0.0], min=-45.0, max=45.0, what="a list of at least 1 angles in [-45, 45] degrees")
    b.numbers("yaw_weights", None, nonnegative=True)
    b.number("gable_fraction", 0.25, min=0.0, max=1.0)
    b.numbers("roof_pitch_deg", [30.0], min=0.0, max=75.0, min_open=True,
              what="a list of at least 1 pitches in (0, 75] degrees")
    b.string("floor_lines", "street", choices=FACADES)
    b.colors("palette", _BUILDING_PALETTE)
    b.color("roof_color", [0.45, 0.30, 0.26])

    w = t.table("windows")
    w.string("facades", "street", choices=FACADES)
    w.number("width", 1.2, positive=True)
    w.number("height", 1.5, positive=True)
    w.number("sill", 0.9, positive=True)
    w.number("spacing", 3.0, positive=True)
    w.number("margin", 1.0, nonnegative=True)
    w.number("depth", 0.04, positive=True)
    w.boolean("lines", True)
    w.color("color", [0.16, 0.21, 0.28])

    m = t.table("markings")
    m.color("color", [0.95, 0.95, 0.92])
    m.number("width", 0.15, positive=True)
    m.number("thickness", 0.01, positive=True)
    m.number("dash_length", 3.0, positive=True)
    m.number("dash_gap", 6.0, positive=True)
    m.boolean("edge_lines", True)
    m.number("edge_offset", 0.3, positive=True)
    m.boolean("zebra", True)
    m.number("zebra_stripe_width", 0.5, positive=True)
    m.number("zebra_gap", 0.5, positive=True)
    m.number("zebra_length", 3.0, positive=True)
    m.boolean("stop_lines", True)
    m.number("stop_line_width", 0.3, positive=True)


def _check_street(spec: dict) -> None:
    st, b, w, m = spec["street"], spec["buildings"], spec["windows"], spec["markings"]
    need = st["sidewalk_width"] + b["setback_range"][1] + b["depth_range"][1]
    if not st["block_depth"] > need:
        raise CatadioptricError(
            f"scene.street.block_depth: expected more than sidewalk_width + setback_range[1] + depth_range[1] "
            f"= {need!r} m (the deepest building must fit on its block), got {st['block_depth']!r}")
    if not w["sill"] + w["height"] < b["floor_height"]:
        raise CatadioptricError(
            f"scene.windows.height: expected sill + height below buildings.floor_height = {b['floor_height']!r}, "
            f"got {w['sill']!r} + {w['height']!r}")
    if b.get("yaw_weights") is not None:
        if len(b["yaw_weights"]) != len(b["yaw_deg"]) or not sum(b["yaw_weights"]) > 0:
            raise CatadioptricError(
                f"scene.buildings.yaw_weights: expected {len(b['yaw_deg'])} weights >= 0 (one per yaw_deg) "
                f"with a positive sum, got {b['yaw_weights']!r}")
    r = spec["lines"]["radius"]
    if w["facades"] != "none" and w["lines"] and not r < min(w["width"], w["height"]) / 4:
        raise CatadioptricError(
            f"scene.lines.radius: expected less than a quarter of the window size min(width, height) / 4 = "
            f"{min(w['width'], w['height']) / 4!r} (the window's edge tubes would merge), got {r!r}")
    if w["facades"] != "none":
        # panes side by side, centres spacing apart: they must not overlap or touch, nor their edge
        # tubes (lines.radius about each edge) merge between them
        tubes = 2 * r if w["lines"] else 0.0
        if not w["spacing"] > w["width"] + tubes:
            need = f"width = {w['width']!r}" + (f" + 2 lines.radius = {w['width'] + tubes!r}" if tubes else "")
            raise CatadioptricError(
                f"scene.windows.spacing: expected more than {need} (the distance between neighbouring windows' "
                f"centres; less overlaps their panes), got {w['spacing']!r}")
    half = st["road_width"] / 2
    if not m["edge_offset"] + m["width"] / 2 < half:
        raise CatadioptricError(
            f"scene.markings.edge_offset: expected edge_offset + width/2 below half the road width {half!r}, "
            f"got {m['edge_offset']!r}")
    if m["zebra"] and not m["zebra_stripe_width"] + 1.0 <= st["road_width"]:
        raise CatadioptricError(
            f"scene.markings.zebra_stripe_width: expected at most road_width - 1 = {st['road_width'] - 1.0!r}, "
            f"got {m['zebra_stripe_width']!r}")
    lim = half + st["sidewalk_width"]
    for where, v in _all_views(spec):
        x, y, z = v["position"]
        if not (abs(y) < lim and abs(x) <= st["length"] / 2 and z > 0):
            raise CatadioptricError(
                f"{where}.position: expected a point above the street (|x| <= {st['length'] / 2!r}, "
                f"|y| < road_width/2 + sidewalk_width = {lim!r}, z > 0), got {v['position']!r}")
        over_sidewalk = abs(y) >= half
        if over_sidewalk and not z > st["curb_height"]:
            raise CatadioptricError(
                f"{where}.position: a view over the sidewalk must be above the curb "
                f"(z > {st['curb_height']!r}), got {v['position']!r}")


# ---------------------------------------------------------------- chessboard
def _read_chessboard_tables(t: SpecTable) -> None:
    c = t.table("chessboard")
    c.integers("squares", [9, 6], length=2, min=1)
    c.number("square_size", 0.1, positive=True)
    c.number("border", 0.05, nonnegative=True)
    c.number("thickness", 0.01, positive=True)
    c.color("dark_color", [0.04, 0.04, 0.04])
    c.color("light_color", [0.93, 0.93, 0.90])
    c.string("lines", "all", choices=("all", "inner", "none"))
    for i, bt in enumerate(c.tables("boards", min_count=1)):
        bt.string("name", f"board{i}")
        bt.vector("center", REQUIRED)
        bt.number("yaw_deg", 0.0, what="an angle in degrees")
        bt.number("tilt_deg", 90.0, min=0.0, max=180.0, what="an angle in [0, 180] degrees")
        bt.number("spin_deg", 0.0, what="an angle in degrees")
        bt.integers("squares", None, length=2, min=1)
        bt.number("square_size", None, positive=True)
        bt.number("border", None, nonnegative=True)
        bt.number("thickness", None, positive=True)


def board_frame(board: dict) -> np.ndarray:
    """Columns ``u, v, n`` (in W) of a board: ``u`` along its first square count, ``v`` along its
    second, ``n`` its front normal. ``tilt_deg = 0`` lies face up; 90 stands upright facing the
    azimuth ``yaw_deg`` (from +x toward +y); ``spin_deg`` turns the board in its plane."""
    yaw, tilt, spin = (math.radians(board[k]) for k in ("yaw_deg", "tilt_deg", "spin_deg"))
    n = np.array([math.cos(yaw) * math.sin(tilt), math.sin(yaw) * math.sin(tilt), math.cos(tilt)])
    u0 = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
    v0 = np.cross(n, u0)
    u = math.cos(spin) * u0 + math.sin(spin) * v0
    v = np.cross(n, u)
    return np.stack([u, v, n], axis=1)


def board_size(spec: dict, board: dict) -> tuple[list[int], float, float, float]:
    """``squares, square_size, border, thickness`` of a board (its own values, else the chessboard's)."""
    c = spec["chessboard"]
    get = lambda k: board[k] if board.get(k) is not None else c[k]  # noqa: E731
    return get("squares"), get("square_size"), get("border"), get("thickness")


def _check_chessboard(spec: dict) -> None:
    names = [b["name"] for b in spec["chessboard"]["boards"]]
    for i, b in enumerate(spec["chessboard"]["boards"]):
        if names.index(b["name"]) != i:
            raise CatadioptricError(f"scene.chessboard.boards[{i}].name: duplicate board name {b['name']!r}")
        (nx, ny), s, border, thick = board_size(spec, b)
        R = board_frame(b)
        hw, hh = nx * s / 2 + border, ny * s / 2 + border
        corners = np.array([[x, y, z] for x in (-hw, hw) for y in (-hh, hh) for z in (-thick, 0.0)])
        low = float(np.min(corners @ R.T[:, 2] + b["center"][2]))
        if low < 0:
            raise CatadioptricError(
                f"scene.chessboard.boards[{i}].center: the board reaches below the ground (lowest point "
                f"z = {low:.4g} m); raise it or tilt it")
    boards = []
    for b in spec["chessboard"]["boards"]:
        (nx, ny), s, border, thick = board_size(spec, b)
        boards.append((b["name"], board_frame(b), np.asarray(b["center"], float), nx * s / 2 + border,
                       ny * s / 2 + border, thick))
    for where, v in _all_views(spec):
        if not v["position"][2] > 0:
            raise CatadioptricError(f"{where}.position: expected a point above the ground (z > 0), "
                                    f"got {v['position']!r}")
        for name, R, c, hw, hh, thick in boards:  # the board's slab: its face at n = 0, its back at -thickness
            u, w_, n = (np.asarray(v["position"], float) - c) @ R
            if abs(u) <= hw and abs(w_) <= hh and -thick <= n <= 0.0:
                raise CatadioptricError(
                    f"{where}.position: expected a point outside every chessboard, got {v['position']!r}, inside "
                    f"the board {name!r} (the mirror would see the board from within)")


# ---------------------------------------------------------------------- root
def read_scene_spec(data, path: str = "scene") -> dict:
    """Check a parsed scene spec and return it normalised: every default filled in, numbers as
    floats, plain Python values only (JSON-serialisable). Reading a normalised spec again gives
    the same dict."""
    t = SpecTable(data, path)
    t.string("name", "scene")
    t.string("description", None)
    t.string("source", None)
    gen = t.string("generator", REQUIRED, choices=GENERATORS)
    t.integer("seed", 0, min=0)
    t.integer("max_triangles", 60000, min=1, max=MAX_TRIANGLES)
    _read_rig(t)
    _read_sun(t.table("sun"))
    street = gen == "street"
    _read_ground(t.table("ground"), 400.0 if street else 60.0,
                 [0.30, 0.30, 0.32] if street else [0.42, 0.45, 0.38])
    _read_lines(t.table("lines"), 0.02 if street else 0.003, 1.0 if street else 0.5)
    view_tables = t.tables("views")
    for i, vt in enumerate(view_tables):
        _read_view(vt, i)
    for i, vt in enumerate(t.tables("view_paths")):
        _read_view_path(vt, i)
    for i, vt in enumerate(t.tables("random_views")):
        _read_random_views(vt, i)
    if street:
        _read_street_tables(t)
    else:
        _read_chessboard_tables(t)
    spec = t.done()
    for key in ("view_paths", "random_views"):  # absent when none (normalised specs stay as they were)
        if not spec.get(key):
            spec.pop(key, None)
    seen = set()
    for where, v in _all_views(spec):
        if v["name"] in seen:
            raise CatadioptricError(f"{where}.name: duplicate view name {v['name']!r}")
        seen.add(v["name"])
    for i, v in enumerate(spec.get("views", [])):
        if "R_world_from_mirror" in v:
            try:
                RigPose.from_mirror_in_world(np.array(v["R_world_from_mirror"]), v["position"])
            except CatadioptricError as exc:
                raise CatadioptricError(f"scene.views[{i}].{exc}") from None
    spec.setdefault("views", [])
    (_check_street if street else _check_chessboard)(spec)
    if isinstance(spec.get("rig"), str):
        _rig_of(spec)  # the name or file must resolve
    return spec


def load_spec(path) -> dict:
    """Read and check a scene spec file (``.toml`` or ``.json``); returns the normalised spec
    (see :func:`read_scene_spec`) with ``source`` set to the file's absolute path."""
    p = Path(path)
    data = read_spec_file(p)
    data["source"] = str(p.resolve())
    return read_scene_spec(data)


#: The folder of the packaged scene specs (``catadioptric/data/scenes``, read with importlib.resources).
SPEC_DIR = data_path("scenes")


def spec_names() -> list[str]:
    """The names :func:`spec_path` resolves (the packaged scene specs)."""
    return data_names("scenes")


def spec_path(name_or_path) -> Path:
    """A scene spec file: a path (a ``.toml``/``.json`` name, a path with a folder, or an existing
    file), or the name of a packaged spec (``urban_street`` -> ``catadioptric/data/scenes/urban_street.toml``)."""
    p = Path(name_or_path)
    s = str(name_or_path)
    if p.suffix in (".toml", ".json") or "/" in s or "\\" in s or p.is_file():
        if not p.exists() and p.stem in spec_names():
            raise CatadioptricError(f"spec: no file {s!r}; the packaged spec {p.stem!r} is given by its name "
                                    f"({p.stem}), or copy {str(SPEC_DIR / (p.stem + '.toml'))!r} to edit it")
        return p
    for suffix in (".toml", ".json"):
        q = SPEC_DIR / f"{s}{suffix}"
        if s and q.is_file():
            return q
    raise CatadioptricError(f"spec: expected a scene spec file or one of {spec_names()}, got {s!r}")


def as_spec(spec_or_path) -> dict:
    """A normalised spec from a path, the name of a packaged spec (:func:`spec_path`) or a (raw or normalised) spec dict."""
    if isinstance(spec_or_path, (str, Path)):
        return load_spec(spec_path(spec_or_path))
    if isinstance(spec_or_path, dict):
        return read_scene_spec(spec_or_path)
    raise CatadioptricError(f"spec: expected a path or a spec dict, got {type(spec_or_path).__name__}")


# --------------------------------------------------------------- views, rig, sun
def view_rotation(yaw_deg: float, pitch_deg: float = 0.0, roll_deg: float = 0.0) -> np.ndarray:
    """``R_world_from_mirror = Rz(yaw) @ Ry(pitch) @ Rx(roll)`` (angles in degrees): the columns are
    the mirror frame's axes in W. All zero: the mirror axis is the world's vertical."""
    a, b, c = (math.radians(x) for x in (yaw_deg, pitch_deg, roll_deg))
    Rz = np.array([[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])
    Ry = np.array([[math.cos(b), 0.0, math.sin(b)], [0.0, 1.0, 0.0], [-math.sin(b), 0.0, math.cos(b)]])
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(c), -math.sin(c)], [0.0, math.sin(c), math.cos(c)]])
    return Rz @ Ry @ Rx


def _path_views(t: dict, j: int) -> list[dict]:
    """The views of a ``[[view_paths]]`` table: ``count`` positions evenly spaced by arc length along
    the polyline ``points``, both ends included (one view: the first point)."""
    pts = np.array(t["points"], dtype=np.float64)
    seg = np.diff(pts, axis=0)
    cum = np.r_[0.0, np.cumsum(np.linalg.norm(seg, axis=1))]
    n = t["count"]
    s = cum[-1] * np.arange(n) / max(n - 1, 1)
    k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1)  # the segment holding s
    while np.any(cum[k + 1] == cum[k]):  # zero-length segments hold nothing
        k = np.where(cum[k + 1] == cum[k], np.maximum(k - 1, 0), k)
    f = np.clip((s - cum[k]) / np.where(cum[k + 1] > cum[k], cum[k + 1] - cum[k], 1.0), 0.0, 1.0)
    pos = pts[k] + f[:, None] * seg[k]
    pos[-1] = pts[-1] if n > 1 else pts[0]
    heading = np.degrees(np.arctan2(seg[k, 1], seg[k, 0])) if t["yaw_follows_path"] else np.zeros(n)
    w = len(str(n - 1))
    return [{"name": f"{t['name']}_{i:0{w}d}", "position": pos[i].tolist(), "yaw_deg": t["yaw_deg"] + float(heading[i]),
             "pitch_deg": t["pitch_deg"], "roll_deg": t["roll_deg"]} for i in range(n)]


def _random_views(t: dict, j: int) -> list[dict]:
    """The views of a ``[[random_views]]`` table: positions uniform in the box ``position_min`` ..
    ``position_max`` and angles uniform in their ranges, drawn from ``numpy.random.default_rng(seed)``
    (all positions, then all yaws, pitches and rolls)."""
    n = t["count"]
    rng = np.random.default_rng(t["seed"])
    pos = rng.uniform(t["position_min"], t["position_max"], (n, 3))
    ang = [rng.uniform(*t[k], n) for k in ("yaw_deg", "pitch_deg", "roll_deg")]
    w = len(str(n - 1))
    return [{"name": f"{t['name']}_{i:0{w}d}", "position": pos[i].tolist(), "yaw_deg": float(ang[0][i]),
             "pitch_deg": float(ang[1][i]), "roll_deg": float(ang[2][i])} for i in range(n)]


def _all_views(spec: dict) -> list[tuple[str, dict]]:
    """Every view of a normalised spec with the key path its errors name: the ``[[views]]`` in file
    order (``scene.views[i]``), then the views of each ``[[view_paths]]`` and ``[[random_views]]``
    table (``scene.view_paths[j].<view name>``)."""
    out = [(f"scene.views[{i}]", v) for i, v in enumerate(spec.get("views", []))]
    for key, make in (("view_paths", _path_views), ("random_views", _random_views)):
        for j, t in enumerate(spec.get(key, [])):
            out += [(f"scene.{key}[{j}].{v['name']}", v) for v in make(t, j)]
    return out


def views(spec_or_path) -> list[tuple[str, RigPose]]:
    """The views of a scene spec as ``(name, RigPose)``: the ``[[views]]`` in file order, then those
    of each ``[[view_paths]]`` and ``[[random_views]]`` table (docs/formats.md, "Scene specs").

    Each view places the rig's mirror frame M in W: its origin at ``position`` and its
    axes ``R_world_from_mirror`` (explicit, or from ``yaw_deg``/``pitch_deg``/``roll_deg``,
    see :func:`view_rotation`); the pose maps ``x_M = R x_W + t``.
    """
    spec = as_spec(spec_or_path)
    out = []
    for _, v in _all_views(spec):
        if "R_world_from_mirror" in v:
            Rw = np.array(v["R_world_from_mirror"], dtype=np.float64)
        else:
            Rw = view_rotation(v["yaw_deg"], v["pitch_deg"], v["roll_deg"])
        out.append((v["name"], RigPose.from_mirror_in_world(Rw, np.array(v["position"], dtype=np.float64))))
    return out


def scene_rig(spec_or_path, *, width: int | None = None, height: int | None = None):
    """The :class:`~catadioptric.CatadioptricCamera` the spec's ``rig`` names (a rig name, a rig spec
    file relative to the scene spec's folder, or an inline rig table)."""
    return _rig_of(as_spec(spec_or_path), width, height)


def _rig_of(spec: dict, width=None, height=None):
    from ..rigspec import load_rig, rig_from_spec

    rig = spec.get("rig")
    if rig is None:
        raise CatadioptricError("scene.rig: missing; this scene spec names no rig")
    if isinstance(rig, dict):
        return rig_from_spec(rig, width=width, height=height, path="scene.rig")
    base = Path(spec["source"]).parent if spec.get("source") else None
    try:
        return load_rig(rig, width=width, height=height, base_dir=base)
    except CatadioptricError as exc:
        raise CatadioptricError(f"scene.rig: {exc}") from None


def sun_direction(spec: dict) -> np.ndarray:
    """Unit direction toward the sun: azimuth from +x toward +y, elevation above the ground."""
    az, el = math.radians(spec["sun"]["azimuth_deg"]), math.radians(spec["sun"]["elevation_deg"])
    return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
