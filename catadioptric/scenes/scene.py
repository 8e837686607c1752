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
from typing import Optional

import numpy as np

from .._checks import CatadioptricError

__all__ = ["Scene", "SceneObject"]


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

    Optional, filled by the generators of :mod:`catadioptric.scenes`:
    ``segment_radius (L,)`` the radius of each segment's tube (metres; the axis of
    the tube is the segment) and ``segment_host (L,)`` the label of the mesh the
    segment is an edge of or is drawn on (0: none).
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
    segment_radius: Optional[np.ndarray] = None
    segment_host: Optional[np.ndarray] = None

    @property
    def labels(self) -> np.ndarray:
        return np.array([o.label for o in self.objects], dtype=np.int64)

    @property
    def triangle_count(self) -> int:
        """Triangles of all meshes."""
        return int(sum(len(o.faces) for o in self.objects))

    def object(self, label: int) -> SceneObject:
        """The object of ``label``."""
        for o in self.objects:
            if o.label == label:
                return o
        raise CatadioptricError(f"label: expected one of the scene's labels, got {label!r}")

    def segment_directions(self) -> np.ndarray:
        """Unit directions ``(L, 3)`` of the segments (from their first to their second end point)."""
        d = self.segments[:, 1] - self.segments[:, 0]
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def summary(self) -> dict:
        """Counts for logs and manifests: objects per kind, segments, families, triangles, bounds."""
        kinds: dict[str, int] = {}
        for o in self.objects:
            kinds[o.kind] = kinds.get(o.kind, 0) + 1
        boxes = [(o.vertices.min(axis=0), o.vertices.max(axis=0)) for o in self.objects if len(o.vertices)]
        lo = np.min([b[0] for b in boxes], axis=0) if boxes else np.full(3, np.nan)
        hi = np.max([b[1] for b in boxes], axis=0) if boxes else np.full(3, np.nan)
        return {
            "name": self.name,
            "seed": int(self.seed),
            "objects": len(self.objects),
            "objects_by_kind": kinds,
            "segments": int(len(self.segments)),
            "families": int(len(self.families)),
            "segments_per_family": np.bincount(self.segment_family, minlength=len(self.families)).tolist(),
            "triangles": self.triangle_count,
            "bounds": [lo.tolist(), hi.tolist()],
        }

    def validate(self, tol: float = 1e-9) -> "Scene":
        """Check the scene's invariants; raise :class:`CatadioptricError` naming the first broken one.

        Shapes and dtypes; labels unique and positive; faces index their vertices;
        families unit; each segment non-degenerate and parallel to its family (within
        ``tol`` radians); each non-zero segment label names an object of kind ``line``.
        Returns the scene.
        """
        labels = self.labels
        if np.any(labels <= 0):
            i = int(np.argmax(labels <= 0))
            raise CatadioptricError(f"objects[{i}].label: expected a positive integer (0 is the background), "
                                    f"got {int(labels[i])}")
        uniq, counts = np.unique(labels, return_counts=True)
        if np.any(counts > 1):
            raise CatadioptricError(f"objects: expected unique labels, label {int(uniq[counts > 1][0])} is used "
                                    f"{int(counts[counts > 1][0])} times")
        for i, o in enumerate(self.objects):
            v, f = np.asarray(o.vertices), np.asarray(o.faces)
            if v.ndim != 2 or v.shape[1] != 3 or v.dtype != np.float64 or not np.all(np.isfinite(v)):
                raise CatadioptricError(f"objects[{i}].vertices: expected finite float64 (V, 3), got "
                                        f"{v.dtype} {v.shape}")
            if f.ndim != 2 or f.shape[1] != 3 or not np.issubdtype(f.dtype, np.integer):
                raise CatadioptricError(f"objects[{i}].faces: expected integers (F, 3), got {f.dtype} {f.shape}")
            if len(f) and (f.min() < 0 or f.max() >= len(v)):
                raise CatadioptricError(f"objects[{i}].faces: indices must lie in [0, {len(v)}), got "
                                        f"[{int(f.min())}, {int(f.max())}]")
        L = len(self.segments)
        s = np.asarray(self.segments)
        if s.shape != (L, 2, 3):
            raise CatadioptricError(f"segments: expected an array of shape (L, 2, 3), got {s.shape}")
        for name in ("segment_family", "segment_label"):
            a = np.asarray(getattr(self, name))
            if a.shape != (L,) or not np.issubdtype(a.dtype, np.integer):
                raise CatadioptricError(f"{name}: expected integers of shape ({L},), got {a.dtype} {a.shape}")
        F = np.asarray(self.families)
        if F.ndim != 2 or F.shape[1] != 3:
            raise CatadioptricError(f"families: expected an array of shape (F, 3), got {F.shape}")
        if len(F) and np.max(np.abs(np.linalg.norm(F, axis=1) - 1)) > 1e-12:
            raise CatadioptricError("families: expected unit directions")
        if L == 0:
            return self
        fam = np.asarray(self.segment_family)
        if fam.min() < 0 or fam.max() >= len(F):
            raise CatadioptricError(f"segment_family: expected family ids in [0, {len(F)}), got "
                                    f"[{int(fam.min())}, {int(fam.max())}]")
        d = s[:, 1] - s[:, 0]
        length = np.linalg.norm(d, axis=1)
        if np.any(length == 0):
            raise CatadioptricError(f"segments[{int(np.argmax(length == 0))}]: a segment has zero length")
        sin = np.linalg.norm(np.cross(d / length[:, None], F[fam]), axis=1)
        if np.any(sin > tol):
            i = int(np.argmax(sin))
            raise CatadioptricError(f"segments[{i}]: not parallel to its family {int(fam[i])} "
                                    f"(angle {float(np.arcsin(min(sin[i], 1.0))):.3g} rad)")
        seg_labels = np.asarray(self.segment_label)
        drawn = seg_labels[seg_labels != 0]
        kind_of = {o.label: o.kind for o in self.objects}
        for lab in drawn:
            if kind_of.get(int(lab)) != "line":
                raise CatadioptricError(f"segment_label: label {int(lab)} is not the label of a line tube")
        if len(np.unique(drawn)) != len(drawn):
            raise CatadioptricError("segment_label: two segments share a tube label")
        for name in ("segment_radius", "segment_host"):
            a = getattr(self, name)
            if a is not None and np.shape(a) != (L,):
                raise CatadioptricError(f"{name}: expected shape ({L},), got {np.shape(a)}")
        return self
