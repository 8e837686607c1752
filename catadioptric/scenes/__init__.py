"""Seeded generators of urban scenes and chessboards whose 3-D lines are known exactly.

``build_scene(spec_or_path, seed=None)`` turns a scene spec (a TOML/JSON file, the name of a
packaged spec such as ``"urban_street"``, or its dict) into a :class:`Scene`; ``views(spec)``
gives the rig poses the spec lists and ``scene_rig(spec)`` the rig it names. The
spec format is documented in ``docs/formats.md`` ("Scene specs"). Generators are
pure functions of (spec, seed): the same seed gives identical arrays.

The meshes are built with trimesh (extra ``render``), imported when a scene is built.
"""
from __future__ import annotations

from .._checks import CatadioptricError
from .scene import Scene, SceneObject
from .spec import GENERATORS, SPEC_DIR, as_spec, load_spec, read_scene_spec, scene_rig, spec_names, spec_path, views

__all__ = ["Scene", "SceneObject", "GENERATORS", "SPEC_DIR", "build_scene", "load_spec", "read_scene_spec",
           "views", "scene_rig", "spec_path", "spec_names"]


def build_scene(spec_or_path, seed: int | None = None) -> Scene:
    """The :class:`Scene` of a spec (a file path, the name of a packaged spec, or a spec dict).

    ``seed`` overrides the spec's ``seed``. The result is checked with
    :meth:`Scene.validate`; ``scene.spec`` holds the normalised spec.
    """
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
