"""Rig spec files: a catadioptric rig (quadric mirror + pinhole placed in the mirror frame M)
described in a small TOML or JSON file, and the checked reader of spec tables.

A rig spec has two tables (the format is documented in ``docs/formats.md``, "Rig specs")::

    name = "hyperboloid"                    # optional: name, description, source
    [mirror]
    kind = "hyperboloid"                    # sphere | ellipsoid | hyperboloid | paraboloid | cone | cylinder | quadric
    a = 0.03
    c = 0.04
    z_min = 0.04
    z_max = 0.075
    [camera]
    width = 640
    height = 480
    fov_x_deg = 70.0                        # or K = [[fx, s, cx], [0, fy, cy], [0, 0, 1]]
    focus = "lower"                         # or center = [x, y, z] (metres, frame M)
    offset = [0.004, 0.0, -0.006]           # added to the focus
    look_at = [0.0, 0.0, 0.06]              # or R_cam_from_mirror = [[...], [...], [...]]

:func:`load_rig` accepts a file path or a name: the rig spec file ``<name>.toml`` (or ``.json``)
of the package data (``catadioptric/data/rigs``, :data:`RIG_DIR`), else the preset
``catadioptric.rigs.preset(name)``; the packaged files reproduce those presets exactly
(``tests/test_rigspec.py``).

:class:`SpecTable` reads one table of a parsed spec file, checks every value and
refuses unknown keys; every error is a :class:`CatadioptricError` whose message
starts with the key's full path (``rig.mirror.a: expected a positive number, got -0.03``).
The scene specs (``catadioptric.scenes``) use it too.
"""
from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ._checks import CatadioptricError
from ._data import data_names, data_path
from .cameras import CatadioptricCamera, PinholeCamera, look_at_rotation
from .mirrors import QuadricMirror

__all__ = [
    "REQUIRED",
    "RIG_DIR",
    "SpecTable",
    "read_spec_file",
    "read_rig_spec",
    "rig_from_spec",
    "load_rig_spec",
    "load_rig",
    "find_rig_file",
    "rig_names",
]

#: The folder of the packaged rig spec files (``catadioptric/data/rigs``, read with importlib.resources).
RIG_DIR = data_path("rigs")

MIRROR_KINDS = ("sphere", "ellipsoid", "hyperboloid", "paraboloid", "cone", "cylinder", "quadric")


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


#: Default marker of a key that must be present.
REQUIRED = _Required()


def _show(value, limit: int = 80) -> str:
    """A short description of a parsed value for an error message."""
    if isinstance(value, Mapping):
        return "a table"
    if isinstance(value, list) and value and all(isinstance(v, Mapping) for v in value):
        return "an array of tables"
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _interval_text(lo, hi, lo_open, hi_open) -> str:
    if lo == 0 and lo_open and hi is None:
        return "a positive number"
    if lo == 0 and not lo_open and hi is None:
        return "a number >= 0"
    if lo is not None and hi is None:
        return f"a number {'>' if lo_open else '>='} {lo!r}"
    if lo is None and hi is not None:
        return f"a number {'<' if hi_open else '<='} {hi!r}"
    if lo is not None and hi is not None:
        return f"a number in {'(' if lo_open else '['}{lo!r}, {hi!r}{')' if hi_open else ']'}"
    return "a number"


def _in_interval(x: float, lo, hi, lo_open, hi_open) -> bool:
    if lo is not None and (x <= lo if lo_open else x < lo):
        return False
    if hi is not None and (x >= hi if hi_open else x > hi):
        return False
    return True


class SpecTable:
    """Checked access to one table of a parsed TOML/JSON spec.

    Each accessor reads one key, checks its type and value, records the
    (normalised) value for :meth:`done` and returns it. A key absent from the
    file takes its ``default``; ``default=REQUIRED`` makes it mandatory and
    ``default=None`` makes it optional (absent keys then stay absent from the
    normalised table). :meth:`done` refuses keys no accessor asked for and
    returns the normalised table (plain Python values, sub-tables included),
    which reads back to itself.
    """

    def __init__(self, data, path: str):
        if not isinstance(data, Mapping):
            raise CatadioptricError(f"{path}: expected a table, got {_show(data)}")
        self._data = dict(data)
        self.path = path
        self._out: dict = {}
        self._known: list[str] = []

    # ------------------------------------------------------------------ helpers
    def key_path(self, key: str) -> str:
        """The full path of ``key`` in this table (``scene.buildings.height_range``)."""
        return f"{self.path}.{key}" if self.path else key

    def error(self, key: str, message: str) -> CatadioptricError:
        """A :class:`CatadioptricError` about ``key`` (message after the key's path)."""
        return CatadioptricError(f"{self.key_path(key)}: {message}")

    def has(self, key: str) -> bool:
        """True when the file gives ``key``."""
        return key in self._data

    def raw(self, key: str, default=None):
        """The value of ``key`` as parsed, unchecked (for dispatch on its type)."""
        return self._data.get(key, default)

    def _fetch(self, key: str, default, what: str):
        if key not in self._known:
            self._known.append(key)
        if key in self._data:
            return self._data[key], True
        if default is REQUIRED:
            raise self.error(key, f"missing; expected {what}")
        return default, False

    def _fail(self, key: str, what: str, value):
        raise self.error(key, f"expected {what}, got {_show(value)}")

    def _store(self, key, value):
        if value is not None:
            self._out[key] = value
        return value

    def exclusive(self, *keys: str) -> None:
        """Refuse a table that gives more than one of ``keys``."""
        given = [k for k in keys if k in self._data]
        if len(given) > 1:
            raise CatadioptricError(
                f"{self.path}: give one of {', '.join(keys)}, not several (got {', '.join(given)})")

    # ---------------------------------------------------------------- scalars
    def number(self, key: str, default=REQUIRED, *, min=None, max=None, min_open=False, max_open=False,
               positive=False, nonnegative=False, what: str | None = None) -> float | None:
        """A real number (TOML integer or float), optionally bounded."""
        if positive:
            min, min_open = 0.0, True
        if nonnegative:
            min, min_open = 0.0, False
        what = what or _interval_text(min, max, min_open, max_open)
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        if not _is_number(v) or not math.isfinite(v) or not _in_interval(float(v), min, max, min_open, max_open):
            self._fail(key, what, v)
        return self._store(key, float(v))

    def integer(self, key: str, default=REQUIRED, *, min=None, max=None) -> int | None:
        """An integer (TOML integer, not a float), optionally bounded."""
        if min is not None and max is None:
            what = f"an integer >= {min}"
        elif min is not None:
            what = f"an integer in [{min}, {max}]"
        else:
            what = "an integer"
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        if not isinstance(v, int) or isinstance(v, bool) or not _in_interval(v, min, max, False, False):
            self._fail(key, what, v)
        return self._store(key, int(v))

    def boolean(self, key: str, default=REQUIRED) -> bool | None:
        v, given = self._fetch(key, default, "true or false")
        if v is None:
            return None
        if not isinstance(v, bool):
            self._fail(key, "true or false", v)
        return self._store(key, v)

    def string(self, key: str, default=REQUIRED, *, choices=None) -> str | None:
        what = "a string" if choices is None else "one of " + ", ".join(repr(c) for c in choices)
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        if not isinstance(v, str) or (choices is not None and v not in choices):
            self._fail(key, what, v)
        return self._store(key, v)

    # ------------------------------------------------------------------ lists
    def strings(self, key: str, default=REQUIRED, *, choices=None) -> list[str] | None:
        """A non-empty list of strings (each among ``choices`` when given)."""
        what = "a non-empty list of strings" + ("" if choices is None else " among " + ", ".join(map(repr, choices)))
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        ok = isinstance(v, (list, tuple)) and len(v) >= 1 and all(isinstance(x, str) for x in v)
        ok = ok and (choices is None or all(x in choices for x in v))
        if not ok:
            self._fail(key, what, v)
        return self._store(key, list(v))

    def numbers(self, key: str, default=REQUIRED, *, length=None, min_length=1, min=None, max=None,
                min_open=False, max_open=False, positive=False, nonnegative=False,
                what: str | None = None) -> list[float] | None:
        """A list of real numbers (``length`` of them, or at least ``min_length``)."""
        if positive:
            min, min_open = 0.0, True
        if nonnegative:
            min, min_open = 0.0, False
        if what is None:
            each = _interval_text(min, max, min_open, max_open)
            each = "numbers" if each == "a number" else each.replace("a number", "numbers", 1).replace(
                "a positive number", "positive numbers")
            count = f"{length}" if length is not None else f"at least {min_length}"
            what = f"a list of {count} {each}"
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        ok = isinstance(v, (list, tuple)) and all(_is_number(x) and math.isfinite(x) for x in v)
        ok = ok and (len(v) == length if length is not None else len(v) >= min_length)
        ok = ok and all(_in_interval(float(x), min, max, min_open, max_open) for x in v)
        if not ok:
            self._fail(key, what, v)
        return self._store(key, [float(x) for x in v])

    def integers(self, key: str, default=REQUIRED, *, length: int, min=None) -> list[int] | None:
        """A list of ``length`` integers (each ``>= min`` when given)."""
        what = f"a list of {length} integers" + (f" >= {min}" if min is not None else "")
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        ok = isinstance(v, (list, tuple)) and len(v) == length
        ok = ok and all(isinstance(x, int) and not isinstance(x, bool) and (min is None or x >= min) for x in v)
        if not ok:
            self._fail(key, what, v)
        return self._store(key, [int(x) for x in v])

    def vector(self, key: str, default=REQUIRED, n: int = 3) -> list[float] | None:
        """``n`` real numbers (a point or a direction)."""
        return self.numbers(key, default, length=n, what=f"a list of {n} numbers")

    def range(self, key: str, default=REQUIRED, *, nonnegative: bool = False) -> list[float] | None:
        """``[low, high]`` with ``0 < low <= high`` (``0 <= low`` when ``nonnegative``)."""
        what = "two increasing non-negative numbers" if nonnegative else "two increasing positive numbers"
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        ok = isinstance(v, (list, tuple)) and len(v) == 2 and all(_is_number(x) and math.isfinite(x) for x in v)
        if ok:
            lo, hi = float(v[0]), float(v[1])
            ok = (lo >= 0 if nonnegative else lo > 0) and lo <= hi
        if not ok:
            self._fail(key, what, v)
        return self._store(key, [float(v[0]), float(v[1])])

    def color(self, key: str, default=REQUIRED) -> list[float] | None:
        """An RGB colour: three numbers in [0, 1]."""
        return self.numbers(key, default, length=3, min=0.0, max=1.0, what="an RGB colour: three numbers in [0, 1]")

    def colors(self, key: str, default=REQUIRED) -> list[list[float]] | None:
        """A non-empty list of RGB colours."""
        what = "a non-empty list of RGB colours (three numbers in [0, 1] each)"
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        ok = isinstance(v, (list, tuple)) and len(v) >= 1
        ok = ok and all(isinstance(c, (list, tuple)) and len(c) == 3 and
                        all(_is_number(x) and 0 <= x <= 1 for x in c) for c in v)
        if not ok:
            self._fail(key, what, v)
        return self._store(key, [[float(x) for x in c] for c in v])

    def matrix(self, key: str, default=REQUIRED, rows: int = 3, cols: int = 3) -> list[list[float]] | None:
        """A ``rows`` x ``cols`` matrix as a list of rows."""
        what = f"a {rows}x{cols} matrix (a list of {rows} rows of {cols} numbers)"
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        ok = isinstance(v, (list, tuple)) and len(v) == rows
        ok = ok and all(isinstance(r, (list, tuple)) and len(r) == cols and
                        all(_is_number(x) and math.isfinite(x) for x in r) for r in v)
        if not ok:
            self._fail(key, what, v)
        return self._store(key, [[float(x) for x in r] for r in v])

    def weights(self, key: str, default, names) -> dict[str, float]:
        """A table ``{name: weight}`` over some of ``names``: weights >= 0, at least one positive."""
        what = f"a table of weights >= 0 over {', '.join(names)} with at least one positive weight"
        v, given = self._fetch(key, default, what)
        if not isinstance(v, Mapping):
            self._fail(key, what, v)
        for name, w in v.items():
            if name not in names:
                raise self.error(f"{key}.{name}", f"unknown key; expected one of {', '.join(names)}")
            if not _is_number(w) or not math.isfinite(w) or w < 0:
                raise self.error(f"{key}.{name}", f"expected a weight >= 0, got {_show(w)}")
        if not any(w > 0 for w in v.values()):
            self._fail(key, what, dict(v))
        return self._store(key, {name: float(v[name]) for name in names if name in v})

    # ----------------------------------------------------------------- tables
    def table(self, key: str, required: bool = False) -> "SpecTable":
        """The sub-table ``key`` (empty when absent and not ``required``)."""
        v, given = self._fetch(key, REQUIRED if required else {}, "a table")
        sub = SpecTable(v, self.key_path(key))
        self._out[key] = sub
        return sub

    def tables(self, key: str, *, min_count: int = 0) -> list["SpecTable"]:
        """The array of tables ``key`` (TOML ``[[key]]``), at least ``min_count`` of them."""
        what = f"an array of tables ([[{key}]])" + (f" with at least {min_count}" if min_count else "")
        v, given = self._fetch(key, REQUIRED if min_count else [], what)
        if not isinstance(v, (list, tuple)) or len(v) < min_count:
            self._fail(key, what, v)
        subs = [SpecTable(item, f"{self.key_path(key)}[{i}]") for i, item in enumerate(v)]
        self._out[key] = subs
        return subs

    def nested(self, key: str, reader, default=None):
        """Read the sub-table ``key`` with ``reader(value, path) -> normalised dict`` (another
        spec's reader, e.g. :func:`read_rig_spec` for a rig inlined in a scene spec)."""
        v, given = self._fetch(key, default, "a table")
        if v is None:
            return None
        return self._store(key, reader(v, self.key_path(key)))

    def done(self) -> dict:
        """Refuse unknown keys; return the normalised table (sub-tables resolved)."""
        unknown = [k for k in self._data if k not in self._known]
        if unknown:
            raise self.error(unknown[0], f"unknown key; expected one of {', '.join(self._known)}")
        out = {}
        for k, v in self._out.items():
            if isinstance(v, SpecTable):
                out[k] = v.done()
            elif isinstance(v, list) and v and isinstance(v[0], SpecTable):
                out[k] = [s.done() for s in v]
            else:
                out[k] = v
        return out


# ------------------------------------------------------------------ spec files
def read_spec_file(path) -> dict:
    """Parse a ``.toml`` or ``.json`` spec file; syntax errors name the file."""
    p = Path(path)
    try:
        text = p.read_bytes()
    except OSError as exc:
        raise CatadioptricError(f"path: cannot read spec file {str(p)!r} ({exc.strerror})") from None
    try:
        if p.suffix.lower() == ".json":
            data = json.loads(text.decode("utf-8"))
        else:
            data = tomllib.loads(text.decode("utf-8"))
    except (tomllib.TOMLDecodeError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise CatadioptricError(f"path: {str(p)!r} is not a valid {p.suffix.lstrip('.').upper() or 'TOML'} file: {exc}") from None
    if not isinstance(data, dict):
        raise CatadioptricError(f"path: {str(p)!r} must hold a table at its top level, got {_show(data)}")
    return data


# ------------------------------------------------------------------- rig specs
def _read_mirror(m: SpecTable) -> None:
    kind = m.string("kind", REQUIRED, choices=MIRROR_KINDS)
    if kind == "sphere":
        m.number("radius", positive=True)
        m.number("center_z", 0.0)
    elif kind in ("ellipsoid", "hyperboloid"):
        m.number("a", positive=True)
        m.number("c", positive=True)
        m.number("center_z", 0.0)
    elif kind == "paraboloid":
        m.number("focal_length", positive=True)
        m.number("vertex_z", 0.0)
        m.integer("opening", 1, min=-1, max=1)
        if m.raw("opening", 1) == 0:
            raise m.error("opening", "expected +1 (opens to +z) or -1, got 0")
    elif kind == "cone":
        m.number("half_angle_deg", min=0.0, max=90.0, min_open=True, max_open=True)
    elif kind == "cylinder":
        m.number("radius", positive=True)
    else:  # quadric
        m.number("A")
        m.number("B")
        m.number("C")
    m.number("z_min")
    m.number("z_max")


def _read_camera(c: SpecTable) -> None:
    c.integer("width", 640, min=1)
    c.integer("height", 480, min=1)
    c.exclusive("fov_x_deg", "K")
    if c.has("K"):
        c.matrix("K")
    else:
        c.number("fov_x_deg", min=0.0, max=180.0, min_open=True, max_open=True,
                 what="a horizontal field of view in (0, 180) degrees")
    c.exclusive("center", "focus")
    if c.has("focus"):
        c.string("focus", choices=("lower", "upper", "only"))
        c.vector("offset", None)
    else:
        c.vector("center", REQUIRED)
        if c.has("offset"):
            raise c.error("offset", "only allowed with focus (an offset from a focus of the mirror)")
    c.exclusive("look_at", "R_cam_from_mirror")
    c.exclusive("up", "R_cam_from_mirror")
    if c.has("R_cam_from_mirror"):
        c.matrix("R_cam_from_mirror")
    else:
        c.vector("look_at", None)
        c.vector("up", None)


def read_rig_spec(data, path: str = "rig") -> dict:
    """Check a parsed rig spec and return it normalised (defaults filled in).

    The geometry is checked too (a mirror patch that holds no point, a camera
    centre on the mirror, a K that is not an intrinsic matrix...): every error
    is a :class:`CatadioptricError` whose message starts with the key's path.
    """
    t = SpecTable(data, path)
    t.string("name", None)
    t.string("description", None)
    t.string("source", None)
    _read_mirror(t.table("mirror", required=True))
    _read_camera(t.table("camera", required=True))
    spec = t.done()
    rig_from_spec(spec, path=path)  # geometric checks
    return spec


def _mirror_from_spec(m: dict) -> QuadricMirror:
    kind = m["kind"]
    lo, hi = m["z_min"], m["z_max"]
    if kind == "sphere":
        return QuadricMirror.sphere(m["radius"], z_min=lo, z_max=hi, center_z=m["center_z"])
    if kind == "ellipsoid":
        return QuadricMirror.ellipsoid(m["a"], m["c"], z_min=lo, z_max=hi, center_z=m["center_z"])
    if kind == "hyperboloid":
        return QuadricMirror.hyperboloid(m["a"], m["c"], z_min=lo, z_max=hi, center_z=m["center_z"])
    if kind == "paraboloid":
        return QuadricMirror.paraboloid(m["focal_length"], z_min=lo, z_max=hi, vertex_z=m["vertex_z"],
                                        opening=m["opening"])
    if kind == "cone":
        return QuadricMirror.cone(np.radians(m["half_angle_deg"]), z_min=lo, z_max=hi)
    if kind == "cylinder":
        return QuadricMirror.cylinder(m["radius"], z_min=lo, z_max=hi)
    return QuadricMirror(m["A"], m["B"], m["C"], lo, hi)


def _pinhole_from_spec(c: dict, width, height) -> PinholeCamera:
    W, H = c["width"], c["height"]
    W2 = W if width is None else width
    H2 = H if height is None else height
    if "fov_x_deg" in c:
        return PinholeCamera.from_fov(W2, H2, c["fov_x_deg"])
    K = np.array(c["K"], dtype=float)
    if (W2, H2) != (W, H):
        # rescale the image: the pixel-edge rectangle [-0.5, W-0.5] maps onto [-0.5, W2-0.5]
        sx, sy = W2 / W, H2 / H
        K = K.copy()
        K[0, 0] *= sx
        K[0, 1] *= sx
        K[0, 2] = (K[0, 2] + 0.5) * sx - 0.5
        K[1, 1] *= sy
        K[1, 2] = (K[1, 2] + 0.5) * sy - 0.5
    return PinholeCamera(K, W2, H2)


def _camera_center(c: dict, mirror: QuadricMirror, path: str) -> np.ndarray:
    if "center" in c:
        return np.array(c["center"], dtype=float)
    which = c["focus"]
    foci = mirror.foci
    kind = mirror.kind
    if len(foci) == 0:
        raise CatadioptricError(f"{path}.camera.focus: a {kind} mirror has no focus on its axis; give center instead")
    if len(foci) == 1 and which != "only":
        raise CatadioptricError(f"{path}.camera.focus: a {kind} mirror has one focus: expected 'only', got {which!r}")
    if len(foci) == 2 and which == "only":
        raise CatadioptricError(
            f"{path}.camera.focus: a {kind} mirror has two foci: expected 'lower' or 'upper', got 'only'")
    f = foci[1] if which == "upper" else foci[0]
    offset = c.get("offset")
    return f if offset is None else f + np.asarray(offset, dtype=float)


def rig_from_spec(spec: dict, *, width: int | None = None, height: int | None = None,
                  path: str = "rig") -> CatadioptricCamera:
    """Build the :class:`CatadioptricCamera` of a normalised rig spec (see :func:`read_rig_spec`).

    ``width``/``height`` replace the image size: with ``fov_x_deg`` the field of
    view is kept, with ``K`` the intrinsics are rescaled with the image.
    """
    for name, v in (("width", width), ("height", height)):
        if v is not None and not (isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v > 0):
            raise CatadioptricError(f"{name}: expected a positive integer number of pixels, got {v!r}")
    try:
        mirror = _mirror_from_spec(spec["mirror"])
    except CatadioptricError as exc:
        raise CatadioptricError(f"{path}.mirror: {exc}") from None
    c = spec["camera"]
    try:
        pinhole = _pinhole_from_spec(c, width, height)
    except CatadioptricError as exc:
        raise CatadioptricError(f"{path}.camera: {exc}") from None
    center = _camera_center(c, mirror, path)
    try:
        if "R_cam_from_mirror" in c:
            return CatadioptricCamera(mirror, pinhole, center, np.array(c["R_cam_from_mirror"], dtype=float))
        if "look_at" not in c and "up" not in c:
            return CatadioptricCamera.looking_at_mirror(mirror, pinhole, center)
        target = c.get("look_at")
        target = np.array([0.0, 0.0, 0.5 * (mirror.z_min + mirror.z_max)]) if target is None else np.array(target)
        up = (0.0, 1.0, 0.0) if c.get("up") is None else tuple(c["up"])
        if np.linalg.norm(up) == 0:
            raise CatadioptricError(f"up: expected a non-zero direction, got {list(up)}")
        return CatadioptricCamera(mirror, pinhole, center, look_at_rotation(center, target, up))
    except CatadioptricError as exc:
        raise CatadioptricError(f"{path}.camera: {exc}") from None


# ------------------------------------------------------------------ resolution
def rig_names() -> list[str]:
    """Names :func:`load_rig` resolves: the packaged rig spec files and the presets of ``catadioptric.rigs``."""
    from .rigs import preset_names

    return sorted(set(preset_names()) | set(data_names("rigs")))


def find_rig_file(name: str) -> Path | None:
    """The packaged spec file of rig ``name`` (:data:`RIG_DIR`; ``.toml`` first, then ``.json``), or None."""
    for suffix in (".toml", ".json"):
        p = RIG_DIR / f"{name}{suffix}"
        if p.is_file():
            return p
    return None


def _looks_like_path(s: str) -> bool:
    return s.endswith((".toml", ".json")) or "/" in s or "\\" in s


def load_rig_spec(path_or_name, *, base_dir=None) -> dict:
    """The normalised rig spec of a file (a path, relative to ``base_dir`` when given and the
    file exists there) or of a rig name (see :func:`load_rig`). A preset without a file
    gives ``{"preset": name}``."""
    if isinstance(path_or_name, Path) or (isinstance(path_or_name, str) and _looks_like_path(path_or_name)):
        p = Path(path_or_name)
        if base_dir is not None and not p.is_absolute() and (Path(base_dir) / p).is_file():
            p = Path(base_dir) / p
        if not p.is_file():
            raise CatadioptricError(f"path_or_name: no rig spec file at {str(p)!r}")
        return read_rig_spec(read_spec_file(p), path="rig")
    if not isinstance(path_or_name, str):
        raise CatadioptricError(f"path_or_name: expected a file path or a rig name, got {_show(path_or_name)}")
    p = find_rig_file(path_or_name)
    if p is not None:
        return read_rig_spec(read_spec_file(p), path="rig")
    from .rigs import PRESETS

    if path_or_name in PRESETS:
        return {"preset": path_or_name}
    raise CatadioptricError(f"path_or_name: expected a rig spec file or one of {rig_names()}, got {path_or_name!r}")


def load_rig(path_or_name, *, width: int | None = None, height: int | None = None,
             base_dir=None) -> CatadioptricCamera:
    """The :class:`CatadioptricCamera` of a rig spec file (TOML or JSON) or of a rig name.

    A name (no path separator, no ``.toml``/``.json`` suffix) resolves to
    the packaged ``<name>.toml`` (:data:`RIG_DIR`), else to the preset
    ``catadioptric.rigs.preset(name)`` (the files reproduce the presets exactly).
    ``width``/``height`` replace the image size (see :func:`rig_from_spec`).
    """
    spec = load_rig_spec(path_or_name, base_dir=base_dir)
    if "preset" in spec:
        from .rigs import preset

        return preset(spec["preset"], width=640 if width is None else width, height=480 if height is None else height)
    return rig_from_spec(spec, width=width, height=height)
