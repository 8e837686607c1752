"""Mesh primitives of the scene generators: boxes, extruded polygons, quads and batched line tubes.

Every function returns ``vertices (V, 3)`` float64 and ``faces (F, 3)`` int64 with
outward (counter-clockwise seen from outside) winding; closed solids are
watertight. Boxes and extrusions are built with trimesh (imported on first use);
the tubes that draw labelled line segments are built for all segments at once
with numpy.
"""
from __future__ import annotations

import numpy as np

__all__ = [
    "oriented_box",
    "extrude_polygon",
    "extrude_profile",
    "quads",
    "tubes",
    "tube_faces",
    "tube_depth",
    "tube_half_width",
    "merge",
    "frame_from_normal",
]


def _trimesh():
    try:
        import trimesh  # noqa: F401
        import trimesh.creation
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError("catadioptric.scenes needs trimesh, shapely and mapbox-earcut: "
                          "pip install 'catadioptric[render]'") from exc
    return trimesh


def _right_handed(axes: np.ndarray) -> bool:
    return float(np.linalg.det(axes)) > 0


def oriented_box(origin, axes, sizes):
    """The box ``origin + s0 a0 + s1 a1 + s2 a2`` with ``0 <= s_i <= sizes[i]``.

    ``axes (3, 3)`` holds the unit edge directions as columns (orthonormal,
    either handedness); ``sizes (3,)`` the edge lengths.
    """
    tm = _trimesh()
    axes = np.asarray(axes, dtype=np.float64)
    sizes = np.asarray(sizes, dtype=np.float64)
    origin = np.asarray(origin, dtype=np.float64)
    if not _right_handed(axes):
        axes = axes * np.array([1.0, 1.0, -1.0])
        origin = origin + axes[:, 2] * -sizes[2]  # the same box, described from its other corner
    T = np.eye(4)
    T[:3, :3] = axes
    T[:3, 3] = origin + axes @ (0.5 * sizes)
    m = tm.creation.box(extents=sizes, transform=T)
    return np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64)


def extrude_polygon(polygon_xy, z0: float, z1: float):
    """The prism over a simple polygon ``(P, 2)`` of the plane z = 0 between heights ``z0 < z1``."""
    tm = _trimesh()
    from shapely.geometry import Polygon

    poly = Polygon(np.asarray(polygon_xy, dtype=np.float64))
    if not poly.exterior.is_ccw:
        poly = Polygon(list(poly.exterior.coords)[::-1])
    m = tm.creation.extrude_polygon(poly, height=float(z1 - z0))
    v = np.asarray(m.vertices, dtype=np.float64).copy()
    v[:, 2] += z0
    f = np.asarray(m.faces, dtype=np.int64)
    if m.volume < 0:  # keep the winding outward whatever trimesh's convention
        f = f[:, ::-1].copy()
    return v, f


def extrude_profile(profile, origin, u, v, w, length: float):
    """A prism: the polygon ``profile (P, 2)`` drawn in the plane ``origin + p u + q v``
    and swept along ``w`` over ``length``. ``u, v, w`` are orthonormal (either handedness)."""
    verts, faces = extrude_polygon(profile, 0.0, length)
    axes = np.stack([np.asarray(u, float), np.asarray(v, float), np.asarray(w, float)], axis=1)
    out = np.asarray(origin, dtype=np.float64) + verts @ axes.T
    if not _right_handed(axes):
        faces = faces[:, ::-1].copy()
    return out, faces


def quads(corners):
    """Flat quads ``(Q, 4, 3)`` (corners in order around each quad) as ``2 Q`` triangles.

    The front side is the one from which the corners run counter-clockwise.
    """
    c = np.asarray(corners, dtype=np.float64).reshape(-1, 4, 3)
    q = c.shape[0]
    verts = c.reshape(-1, 3)
    base = 4 * np.arange(q, dtype=np.int64)[:, None]
    faces = np.concatenate([base + np.array([0, 1, 2]), base + np.array([0, 2, 3])], axis=1).reshape(-1, 3)
    return verts, faces


def merge(meshes):
    """Concatenate ``[(vertices, faces), ...]`` into one mesh."""
    vs, fs, n = [], [], 0
    for v, f in meshes:
        vs.append(np.asarray(v, dtype=np.float64))
        fs.append(np.asarray(f, dtype=np.int64) + n)
        n += len(v)
    if not vs:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    return np.concatenate(vs), np.concatenate(fs)


def frame_from_normal(directions, normals):
    """Unit ``e1`` (the part of ``normals`` across ``directions``) and ``e2 = d x e1`` for
    unit ``directions (L, 3)``. Where a normal is missing (zero) or parallel to its
    direction, a fixed perpendicular is used."""
    d = np.asarray(directions, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    e1 = n - np.sum(n * d, axis=-1, keepdims=True) * d
    norm = np.linalg.norm(e1, axis=-1, keepdims=True)
    bad = norm[..., 0] < 1e-9
    if np.any(bad):
        ref = np.where(np.abs(d[bad, 2:3]) < 0.9, np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
        alt = ref - np.sum(ref * d[bad], axis=-1, keepdims=True) * d[bad]
        e1[bad] = alt
        norm[bad] = np.linalg.norm(alt, axis=-1, keepdims=True)
    e1 = e1 / norm
    e2 = np.cross(d, e1)
    return e1, e2


def _angles(sides: int) -> np.ndarray:
    return 2.0 * np.pi * np.arange(sides) / sides


def tube_depth(sides: int) -> float:
    """How far (in radii) the polygonal cross-section reaches along ``-e1``: the tube of
    radius r flattened by ``flatten`` reaches ``r * flatten * tube_depth(sides)`` below its axis."""
    return float(np.max(-np.cos(_angles(sides))))


def tube_half_width(sides: int) -> float:
    """How far (in radii) the cross-section reaches along ``+-e2``, across the normal: a tube of
    ``sides`` sides is ``2 r tube_half_width(sides)`` wide (1 when ``sides`` is a multiple of 4)."""
    return float(np.max(np.sin(_angles(sides))))


def tube_faces(sides: int) -> np.ndarray:
    """The ``4 sides - 4`` triangles of a closed tube: the ``sides`` vertices of the start
    cap come first (counter-clockwise seen from the end), then those of the end cap."""
    n = int(sides)
    k = np.arange(n)
    k1 = (k + 1) % n
    side = np.concatenate([np.stack([k, k1, n + k1], 1), np.stack([k, n + k1, n + k], 1)])
    j = np.arange(1, n - 1)
    start_cap = np.stack([np.zeros_like(j), j + 1, j], 1)   # normal -d
    end_cap = np.stack([np.full_like(j, n), n + j, n + j + 1], 1)  # normal +d
    return np.concatenate([side, start_cap, end_cap]).astype(np.int64)


def tubes(starts, ends, radii, normals, *, sides: int = 6, flatten=1.0):
    """Closed polygonal tubes around the segments ``starts -> ends`` (``(L, 3)`` each).

    The cross-section is a regular ``sides``-gon inscribed in the circle of radius
    ``radii (L,)``, squeezed by ``flatten (L,)`` along ``e1`` (the part of
    ``normals (L, 3)`` across the segment) and with a vertex on ``+e1``; its caps
    lie in the planes through the end points. Returns ``vertices (L, 2 sides, 3)``
    and the shared ``faces (4 sides - 4, 3)`` (see :func:`tube_faces`).
    """
    a = np.asarray(starts, dtype=np.float64).reshape(-1, 3)
    b = np.asarray(ends, dtype=np.float64).reshape(-1, 3)
    L = a.shape[0]
    r = np.broadcast_to(np.asarray(radii, dtype=np.float64), (L,))
    fl = np.broadcast_to(np.asarray(flatten, dtype=np.float64), (L,))
    d = b - a
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    e1, e2 = frame_from_normal(d, np.broadcast_to(np.asarray(normals, dtype=np.float64), (L, 3)))
    th = _angles(sides)
    # offsets (L, n, 3) of the cross-section vertices from the axis
    off = (r * fl)[:, None, None] * np.cos(th)[None, :, None] * e1[:, None, :] + \
        r[:, None, None] * np.sin(th)[None, :, None] * e2[:, None, :]
    verts = np.concatenate([a[:, None, :] + off, b[:, None, :] + off], axis=1)
    return verts, tube_faces(sides)
