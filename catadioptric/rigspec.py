"""Rig spec files: a catadioptric rig (quadric mirror + pinhole placed in the mirror frame M)
described in a small TOML or JSON file, read with the checked reader of spec tables
(:mod:`catadioptric.spectable`).

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

:class:`~catadioptric.spectable.SpecTable` (:mod:`catadioptric.spectable`) reads each table
of a spec, checks every value and refuses unknown keys; every error is a
:class:`CatadioptricError` whose message starts with the key's full path
(``rig.mirror.a: expected a positive number, got -0.03``).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ._checks import CatadioptricError
from ._data import data_names, data_path
from .cameras import CatadioptricCamera, PinholeCamera, look_at_rotation
from .mirrors import QuadricMirror
from .spectable import REQUIRED, SpecTable, read_spec_file, show

__all__ = [
    "RIG_DIR",
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
        raise CatadioptricError(f"path_or_name: expected a file path or a rig name, got {show(path_or_name)}")
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
