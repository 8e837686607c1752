"""catadioptric: exact geometry of catadioptric cameras (a pinhole looking at a quadric mirror).

``import catadioptric`` loads numpy and scipy only; rendering, scenes, plots and
experiments live in subpackages that load their heavy dependencies lazily. The
submodules below (``catadioptric.rigs``, ``.unified``, ``.export``, ...), ``catadioptric.Dataset``,
``load_camera`` and the main jobs' front doors (``detect_lines``, ``relative_pose``,
``relative_pose_from_labels``: :mod:`catadioptric.jobs`) are imported on first use.
"""
import importlib as _importlib

from ._checks import CatadioptricError
from .cameras import CatadioptricCamera, PinholeCamera, look_at_rotation
from .frames import RigPose
from .mirrors import QuadricMirror
from .projection import Projections, Rays, backproject, project

__all__ = [
    "CatadioptricError",
    "QuadricMirror",
    "PinholeCamera",
    "CatadioptricCamera",
    "look_at_rotation",
    "RigPose",
    "Rays",
    "Projections",
    "backproject",
    "project",
    "Dataset",
    "load_camera",
    "detect_lines",
    "relative_pose",
    "relative_pose_from_labels",
]

# imported on first attribute access, so that ``import catadioptric`` stays light
_SUBMODULES = ("rigs", "rigspec", "unified", "centrality", "vanishing", "lines", "curves", "linefit", "pose",
               "export", "dataset", "scenes", "render", "validate", "models", "formats", "detect", "twoview", "jobs")
_ATTRIBUTES = {"Dataset": "dataset", "load_camera": "formats", "detect_lines": "jobs", "relative_pose": "jobs",
               "relative_pose_from_labels": "jobs"}


def __getattr__(name):
    if name in _SUBMODULES:
        return _importlib.import_module(f".{name}", __name__)
    if name in _ATTRIBUTES:
        return getattr(_importlib.import_module(f".{_ATTRIBUTES[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_SUBMODULES) | set(_ATTRIBUTES))

__version__ = "0.1.0"
