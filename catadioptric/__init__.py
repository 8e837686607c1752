"""catadioptric: exact geometry of catadioptric cameras (a pinhole looking at a quadric mirror).

``import catadioptric`` loads numpy and scipy only; rendering, scenes, plots and
experiments live in subpackages that load their heavy dependencies lazily.
"""
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
]

__version__ = "0.1.0"
