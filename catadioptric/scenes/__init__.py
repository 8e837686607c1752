"""Seeded generators of urban scenes and chessboards whose 3-D lines are known exactly.

``build_scene(spec_or_path, seed=None)`` turns a scene spec (TOML/JSON file in the
top-level ``scenes/`` folder, or its dict) into a :class:`Scene`; ``views(spec)``
gives the rig poses the spec lists and ``scene_rig(spec)`` the rig it names. The
spec format is documented in ``docs/formats.md`` ("Scene specs"). Generators are
pure functions of (spec, seed): the same seed gives identical arrays.

The meshes are built with trimesh (extra ``render``), imported when a scene is built.
"""
from __future__ import annotations

from pathlib import Path

from .._checks import CatadioptricError
from .scene import Scene, SceneObject
from .spec import GENERATORS, as_spec, load_spec, read_scene_spec, scene_rig, views

__all__ = ["Scene", "SceneObject", "GENERATORS", "SPEC_DIR", "build_scene", "load_spec", "read_scene_spec",
           "views", "scene_rig", "spec_path"]

#: The folder of the scene spec files of a source checkout (``scenes/``).
SPEC_DIR = Path(__file__).resolve().parents[2] / "scenes"


def spec_path(name_or_path) -> Path:
    """A scene spec file: a path, or a name of ``scenes/<name>.toml``."""
    p = Path(name_or_path)
    if p.suffix in (".toml", ".json") or p.is_file():
        return p
    q = SPEC_DIR / f"{name_or_path}.toml"
    if q.is_file():
        return q
    names = sorted(f.stem for f in SPEC_DIR.glob("*.toml")) if SPEC_DIR.is_dir() else []
    raise CatadioptricError(f"spec: expected a scene spec file or one of {names}, got {str(name_or_path)!r}")


def build_scene(spec_or_path, seed: int | None = None) -> Scene:
    """The :class:`Scene` of a spec (a file path, a name in ``scenes/``, or a spec dict).

    ``seed`` overrides the spec's ``seed``. The result is checked with
    :meth:`Scene.validate`; ``scene.spec`` holds the normalised spec.
    """
    if isinstance(spec_or_path, (str, Path)):
        spec = load_spec(spec_path(spec_or_path))
    else:
        spec = as_spec(spec_or_path)
    if seed is None:
        seed = spec["seed"]
    if not (isinstance(seed, int) and not isinstance(seed, bool) and seed >= 0):
        raise CatadioptricError(f"seed: expected an integer >= 0, got {seed!r}")
    if spec["generator"] == "street":
        from .street import build_street as generate
    else:
        from .chessboard import build_chessboard as generate
    return generate(spec, seed).validate()
