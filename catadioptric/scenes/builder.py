"""Assembling a :class:`~catadioptric.scenes.scene.Scene`: labels, families of parallel lines and line tubes.

Labels are handed out in creation order, 1, 2, 3, ... (0 is the background).
A family is a direction up to sign, stored with a canonical sign (see
:func:`canonical_direction`); a segment is stored as ``start`` and
``start + length * s`` with ``s = +-`` its family's direction, so that every
segment is parallel to its family to rounding. Each segment gets its own tube
mesh, built for all segments at once when the scene is finished.
"""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError
from .meshes import tube_depth, tubes
from .scene import Scene, SceneObject

__all__ = ["canonical_direction", "SceneBuilder", "FAMILY_TOL"]

#: Directions whose unit vectors differ by less than this (up to sign) are one family.
FAMILY_TOL = 1e-9
_SIGN_TOL = 1e-12


def canonical_direction(direction) -> np.ndarray:
    """The unit vector of ``direction`` with the canonical sign of a family: the first of
    the components z, y, x whose magnitude exceeds 1e-12 is positive (up, then +y, then +x)."""
    d = np.asarray(direction, dtype=np.float64)
    n = np.linalg.norm(d)
    if not np.isfinite(n) or n == 0:
        raise CatadioptricError(f"direction: expected a non-zero finite vector, got {d.tolist()}")
    d = d / n
    for i in (2, 1, 0):
        if abs(d[i]) > _SIGN_TOL:
            return (d if d[i] > 0 else -d) + 0.0  # + 0.0: no negative zeros
    raise AssertionError("unreachable: a unit vector has a component above 1e-12")


def _count_text(n) -> str:
    return str(int(n)) if n < 1e15 else f"{float(n):.3g}"


class SceneBuilder:
    """Collects labelled meshes and labelled line segments, then builds a :class:`Scene`.

    ``sides`` is the number of sides of every line tube and ``clearance`` the gap
    (metres) left between a tube and the surface it is drawn on. ``max_triangles`` (the
    spec's ``scene.max_triangles``): adding past it raises at once, so that a generator never
    builds (or loops over) more than that before the error.
    """

    def __init__(self, *, sides: int = 6, clearance: float = 0.002, max_triangles: int | None = None):
        self.sides = int(sides)
        self.clearance = float(clearance)
        self.max_triangles = max_triangles
        self._triangles = 0
        self._depth = tube_depth(self.sides)
        self._objects: list[SceneObject] = []
        self._families: list[np.ndarray] = []
        self._family_cache: dict[bytes, int] = {}
        self._seg: dict[str, list] = {k: [] for k in
                                      ("start", "end", "family", "label", "radius", "flatten", "normal",
                                       "name", "color", "host")}
        self._next = 1

    # ------------------------------------------------------------------ labels
    def _label(self) -> int:
        label = self._next
        self._next += 1
        return label

    def add_mesh(self, name: str, vertices, faces, color, kind: str) -> int:
        """Add one labelled mesh; returns its label."""
        v = np.ascontiguousarray(vertices, dtype=np.float64)
        f = np.ascontiguousarray(faces, dtype=np.int64)
        self._count(len(f))
        label = self._label()
        self._objects.append(SceneObject(name, label, v, f, tuple(float(c) for c in color), kind))
        return label

    # ---------------------------------------------------------------- families
    def family(self, direction) -> int:
        """The id of the family of ``direction`` (a new family when none is parallel to it)."""
        d = np.asarray(direction, dtype=np.float64)
        key = d.tobytes()
        fid = self._family_cache.get(key)
        if fid is not None:
            return fid
        c = canonical_direction(d)
        fid = -1
        if self._families:
            F = np.asarray(self._families)
            dist = np.linalg.norm(F - c, axis=1)
            j = int(np.argmin(dist))
            if dist[j] < FAMILY_TOL:
                fid = j
        if fid < 0:
            self._families.append(c)
            fid = len(self._families) - 1
        self._family_cache[key] = fid
        return fid

    def family_direction(self, fid: int) -> np.ndarray:
        return self._families[fid].copy()

    # ---------------------------------------------------------------- segments
    def add_segment(self, name: str, start, direction, length: float, *, radius: float, color,
                    normal=None, on_surface: bool = False, flatten: float = 1.0, host: int = 0) -> int:
        """Add a labelled segment from ``start`` along ``direction`` over ``length``; returns its label.

        ``normal`` orients the tube's cross-section (a vertex points along it). With
        ``on_surface`` the segment is drawn on a surface whose outward normal is
        ``normal``: the segment (the tube's axis) is lifted off the surface so that
        the tube clears it by ``clearance``. Otherwise the segment is the tube's axis
        as given (an edge of a solid: the tube straddles the edge). ``host`` is the
        label of the mesh the segment belongs to (0: none).
        """
        length = float(length)
        if not length > 0:
            raise CatadioptricError(f"length: expected a positive segment length, got {length!r}")
        self._count(self.tube_triangles)
        d = np.asarray(direction, dtype=np.float64)
        fid = self.family(d)
        f = self._families[fid]
        s = f if float(np.dot(f, d)) >= 0 else -f
        p0 = np.asarray(start, dtype=np.float64).copy()
        n = np.zeros(3) if normal is None else np.asarray(normal, dtype=np.float64)
        if on_surface:
            if normal is None:
                raise CatadioptricError("normal: a segment drawn on a surface needs the surface's normal")
            nn = n - np.dot(n, s) * s
            nn = nn / np.linalg.norm(nn)
            p0 = p0 + nn * (radius * flatten * self._depth + self.clearance)
            n = nn
        label = self._label()
        seg = self._seg
        seg["start"].append(p0)
        seg["end"].append(p0 + length * s)
        seg["family"].append(fid)
        seg["label"].append(label)
        seg["radius"].append(float(radius))
        seg["flatten"].append(float(flatten))
        seg["normal"].append(n)
        seg["name"].append(name)
        seg["color"].append(tuple(float(c) for c in color))
        seg["host"].append(int(host))
        return label

    @property
    def tube_triangles(self) -> int:
        """Triangles of one line tube."""
        return 4 * self.sides - 4

    @property
    def triangle_count(self) -> int:
        """Triangles so far, the tubes still to be built included."""
        return self._triangles

    def check(self, n, what: str = "") -> None:
        """A ``scene.max_triangles`` error if ``n`` more triangles (a batch about to be made: call this
        before making it) would exceed ``max_triangles``."""
        total = self._triangles + n
        if self.max_triangles is not None and total > self.max_triangles:
            raise CatadioptricError(
                f"scene.max_triangles: the scene would have at least {_count_text(total)} triangles{what}, more than "
                f"max_triangles = {self.max_triangles}; make the scene smaller or raise the limit")

    def _count(self, n: int) -> None:
        self.check(n)
        self._triangles += int(n)

    # ------------------------------------------------------------------- build
    def build(self, *, name: str, seed: int, sun, spec: dict) -> Scene:
        """The finished scene: tubes built, objects sorted by label."""
        seg = self._seg
        L = len(seg["label"])
        objects = list(self._objects)
        if L:
            starts = np.asarray(seg["start"])
            ends = np.asarray(seg["end"])
            verts, faces = tubes(starts, ends, np.asarray(seg["radius"]), np.asarray(seg["normal"]),
                                 sides=self.sides, flatten=np.asarray(seg["flatten"]))
            for i in range(L):
                faces_i = faces.copy()
                objects.append(SceneObject(seg["name"][i], seg["label"][i], verts[i], faces_i, seg["color"][i],
                                           "line"))
            segments = np.stack([starts, ends], axis=1)
        else:
            segments = np.zeros((0, 2, 3))
        objects.sort(key=lambda o: o.label)
        families = np.asarray(self._families, dtype=np.float64).reshape(-1, 3)
        scene = Scene(
            objects=objects,
            segments=segments,
            segment_family=np.asarray(seg["family"], dtype=np.int64),
            families=families,
            segment_label=np.asarray(seg["label"], dtype=np.int64),
            name=name,
            seed=int(seed),
            sun=np.asarray(sun, dtype=np.float64),
            spec=spec,
            segment_radius=np.asarray(seg["radius"], dtype=np.float64),
            segment_host=np.asarray(seg["host"], dtype=np.int64),
        )
        return scene
