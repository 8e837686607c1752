"""The Scene: what every generator produces and every renderer and tracer consumes.

A scene is data: labelled triangle meshes plus the exact 3-D line segments the
ground truth is about. Coordinates are in the world frame W (metres, z up,
right-handed); a rig is placed in W by a :class:`catadioptric.frames.RigPose`.

Labels: 0 is reserved for "no object" (sky / background / the mirror's outside).
Every mesh carries one label; every line segment is drawn as a thin tube mesh of
its own label, so that the label image tells which pixel sees which line.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class SceneObject:
    """One labelled mesh: ``vertices (V, 3)`` float64, ``faces (F, 3)`` int, an RGB colour in [0, 1]."""

    name: str
    label: int
    vertices: np.ndarray
    faces: np.ndarray
    color: tuple[float, float, float]
    kind: str = "solid"  # solid | ground | road | marking | building | window | line | chessboard


@dataclass
class Scene:
    """Meshes plus labelled line segments grouped in families of parallel lines.

    ``segments (L, 2, 3)``: the end points of each segment in W; ``segment_family (L,)``:
    the family index of each segment; ``families (F, 3)``: the unit direction of each
    family; ``segment_label (L,)``: the label of the tube mesh that draws the segment
    (0 when the segment is not drawn). ``sun`` is a unit direction toward the sun.
    """

    objects: list[SceneObject]
    segments: np.ndarray
    segment_family: np.ndarray
    families: np.ndarray
    segment_label: np.ndarray
    name: str = "scene"
    seed: int = 0
    sun: np.ndarray = field(default_factory=lambda: np.array([0.4, -0.3, 0.866]))
    spec: dict = field(default_factory=dict)

    @property
    def labels(self) -> np.ndarray:
        return np.array([o.label for o in self.objects], dtype=np.int64)
