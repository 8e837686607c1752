"""Our float64 label tracer: the ground truth every renderer is checked against.

Pixel-centre rays are reflected on the exact quadric by :func:`catadioptric.projection.backproject`
(float64) and intersected with the scene's triangles in float64 by a bounding-volume
hierarchy:

* build (numpy): triangles longer than 1/128 of the scene's extent are first bisected along
  their longest edge (the surface is unchanged; a ground plane of two triangles would
  otherwise give boxes every ray enters), then a balanced median-split tree in complete-binary
  layout (node ``i`` of level ``l`` covers the triangles ``[floor(i N / 2^l),
  floor((i + 1) N / 2^l))`` of a permutation that is re-sorted, level by level, along each
  node's longest centroid extent);
* traversal (compiled with numba, :mod:`catadioptric.render.tracer_kernels`): each ray goes
  depth first, nearer child box first, and skips the boxes farther than its best hit so far;
* triangles: Moeller-Trumbore in float64 (``p = d x e2``, ``det = e1 . p``, ``s = o - v0``,
  ``q = s x e1``, ``u = (s . p) / det``, ``v = (d . q) / det``, ``t = (e2 . q) / det``, each
  product summed x, y, z in that order; barycentric slack 1e-12). The nearest hit wins;
  among hits at exactly the same distance, the lowest triangle index of the hierarchy's
  order (so the answer does not depend on the order boxes are visited in).

Labels (docs/formats.md, "Datasets"): ``0`` nothing hit (sky), ``-1`` the pixel does not
see the mirror, ``-2`` the reflected ray meets the mirror again; otherwise the label of
the first object hit.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError, as_float_array
from .._extras import require

__all__ = ["TriangleBVH", "scene_bvh", "trace_labels", "trace_rays", "pixel_rays", "scene_digest",
           "LABEL_SKY", "LABEL_NO_MIRROR", "LABEL_MIRROR_AGAIN"]

LABEL_SKY = 0
LABEL_NO_MIRROR = -1
LABEL_MIRROR_AGAIN = -2

LEAF = 4            # triangles per leaf (at most)
SPLIT_FRACTION = 128  # triangles longer than 1/128 of the scene's extent are split for the hierarchy


@dataclass
class Hits:
    """First hits of rays: ``t (N,)`` (inf where none), ``triangle (N,)`` (-1 where none)."""

    t: np.ndarray
    triangle: np.ndarray


def _kernels():
    """The compiled traversal (numba, the ``render`` extra; compiled once per machine and cached)."""
    require("numba", "the float64 label tracer")
    from . import tracer_kernels

    return tracer_kernels


class TriangleBVH:
    """Float64 bounding-volume hierarchy over triangles ``vertices[faces]``."""

    def __init__(self, vertices, faces, triangle_labels=None):
        v = as_float_array(vertices, "vertices", 3)
        f = np.asarray(faces)
        if f.ndim != 2 or f.shape[1] != 3 or not np.issubdtype(f.dtype, np.integer):
            raise CatadioptricError(f"faces: expected an integer array of shape (F, 3), got {f.dtype} {f.shape}")
        if len(f) and (f.min() < 0 or f.max() >= len(v)):
            raise CatadioptricError(f"faces: expected vertex indices in [0, {len(v)}), got range "
                                    f"[{int(f.min())}, {int(f.max())}]")
        tri = v[f]  # (N, 3, 3)
        labels = (np.zeros(len(tri), np.int64) if triangle_labels is None
                  else np.asarray(triangle_labels, dtype=np.int64))
        if labels.shape != (len(tri),):
            raise CatadioptricError(f"triangle_labels: expected shape ({len(tri)},), got {labels.shape}")
        self.n_input = len(tri)
        # long triangles (a ground plane, long thin tubes) make boxes that every ray enters: bisect
        # their longest edge until the boxes are small against the scene (the surface is unchanged)
        source = np.arange(len(tri))
        if len(tri):
            ext = float(np.max(tri.reshape(-1, 3).max(0) - tri.reshape(-1, 3).min(0)))
            tri, source = _split_long(tri, source, max(ext / SPLIT_FRACTION, 1e-300))
        self.n = len(tri)
        self.source = source
        self.labels = labels[source]
        if self.n == 0:
            self.depth = 0
            return
        cen = tri.mean(axis=1)
        depth = 0  # smallest depth whose leaves hold at most LEAF triangles (none empty)
        while -(-self.n >> depth) > LEAF and (2 << depth) <= self.n:
            depth += 1
        perm = np.arange(self.n)
        for level in range(depth):
            bounds = (np.arange((1 << level) + 1) * self.n) >> level
            node = np.searchsorted(bounds, np.arange(self.n), side="right") - 1
            c = cen[perm]
            ext = np.maximum.reduceat(c, bounds[:-1], axis=0) - np.minimum.reduceat(c, bounds[:-1], axis=0)
            axis = np.argmax(ext, axis=1)[node]
            key = c[np.arange(self.n), axis]
            perm = perm[np.lexsort((key, node))]
        self.depth = depth
        self.perm = perm
        t = tri[perm]
        self.v0 = np.ascontiguousarray(t[:, 0])
        self.e1 = np.ascontiguousarray(t[:, 1] - t[:, 0])
        self.e2 = np.ascontiguousarray(t[:, 2] - t[:, 0])
        self.tri_labels = np.ascontiguousarray(self.labels[perm])
        nleaf = 1 << depth
        self.leaf_bounds = (np.arange(nleaf + 1) * self.n) >> depth
        lo = np.minimum.reduceat(t.min(axis=1), self.leaf_bounds[:-1], axis=0)
        hi = np.maximum.reduceat(t.max(axis=1), self.leaf_bounds[:-1], axis=0)
        pad = 1e-9 * (np.abs(lo) + np.abs(hi) + (hi - lo)) + 1e-12
        lo, hi = lo - pad, hi + pad
        # boxes of the complete tree in heap order (node k's children 2k + 1, 2k + 2): rows
        # lo_x, lo_y, lo_z, hi_x, hi_y, hi_z, the leaves last
        levels = [np.concatenate([lo, hi], axis=1)]
        for _ in range(depth):
            lo = np.minimum(lo[0::2], lo[1::2])
            hi = np.maximum(hi[0::2], hi[1::2])
            levels.append(np.concatenate([lo, hi], axis=1))
        self.nodes = np.ascontiguousarray(np.concatenate(levels[::-1]))

    # ------------------------------------------------------------------ queries
    def intersect(self, origins, directions, t_min=0.0, t_max=None, exclude_labels=None) -> Hits:
        """First hit with ``t_min < t < t_max`` of each ray ``origins + t directions`` (float64).

        ``t_min``, ``t_max``: numbers or one per ray (default: 0 and no limit; a narrow window
        prunes the traversal).
        ``exclude_labels (N,)``: triangles of that label are ignored for that ray (-1: none)."""
        # writeable C-contiguous copies: one compiled signature serves every call
        o = np.array(as_float_array(origins, "origins", 3).reshape(-1, 3), order="C")
        d = np.array(as_float_array(directions, "directions", 3).reshape(-1, 3), order="C")
        if o.shape != d.shape:
            raise CatadioptricError(f"origins, directions: expected the same shape, got {o.shape} and {d.shape}")
        n = len(o)
        t = np.full(n, np.inf)
        tri = np.full(n, -1, dtype=np.int64)
        ex = None if exclude_labels is None else np.asarray(exclude_labels, dtype=np.int64).reshape(-1)
        if ex is not None and ex.shape != (n,):
            raise CatadioptricError(f"exclude_labels: expected shape ({n},), got {ex.shape}")
        tmax = np.array(np.broadcast_to(np.inf if t_max is None else np.asarray(t_max, dtype=np.float64), (n,)),
                        dtype=np.float64)
        tmin = np.array(np.broadcast_to(np.asarray(t_min, dtype=np.float64), (n,)), dtype=np.float64)
        if self.n == 0 or n == 0:
            return Hits(t, tri)
        kernels = _kernels()
        use_ex = ex is not None
        ex = np.array(ex, dtype=np.int64) if use_ex else np.zeros(1, dtype=np.int64)
        kernels.intersect_rays(o, d, tmin, tmax, ex, use_ex, self.nodes, self.leaf_bounds, self.depth, self.v0,
                               self.e1, self.e2, self.tri_labels, t, tri)
        return Hits(t, tri)

    def labels_of(self, hits: Hits) -> np.ndarray:
        """Labels of the triangles hit (``LABEL_SKY`` where nothing)."""
        out = np.full(hits.triangle.shape, LABEL_SKY, dtype=np.int64)
        ok = hits.triangle >= 0
        out[ok] = self.tri_labels[hits.triangle[ok]]
        return out

    def original_index(self, triangle: np.ndarray) -> np.ndarray:
        """Index in the input ``faces`` of triangles returned by :meth:`intersect` (-1 stays -1)."""
        out = np.full(np.shape(triangle), -1, dtype=np.int64)
        ok = triangle >= 0
        out[ok] = self.source[self.perm[triangle[ok]]]
        return out


def _split_long(tri, source, max_edge, max_rounds=12):
    """Bisect the longest edge of every triangle longer than ``max_edge`` (repeatedly); returns the
    pieces and the index of the input triangle each comes from. Orientation is kept."""
    for _ in range(max_rounds):
        e = np.stack([np.linalg.norm(tri[:, (k + 1) % 3] - tri[:, k], axis=1) for k in range(3)], axis=1)
        k = np.argmax(e, axis=1)
        long = e[np.arange(len(tri)), k] > max_edge
        if not np.any(long):
            break
        t, kk = tri[long], k[long]
        i = np.arange(len(t))
        a, b, c = t[i, kk], t[i, (kk + 1) % 3], t[i, (kk + 2) % 3]  # longest edge a -> b, opposite c
        m = 0.5 * (a + b)
        first = np.stack([a, m, c], axis=1)
        second = np.stack([m, b, c], axis=1)
        tri = np.concatenate([tri[~long], first, second])
        source = np.concatenate([source[~long], source[long], source[long]])
    return tri, source


# ---------------------------------------------------------------------- scenes
def scene_digest(scene) -> str:
    """A content hash of a Scene's geometry, labels and lines (stable across processes)."""
    h = hashlib.sha256()
    for obj in scene.objects:
        h.update(f"{obj.name}|{int(obj.label)}|{obj.kind}|{tuple(float(c) for c in obj.color)}".encode())
        h.update(np.ascontiguousarray(obj.vertices, dtype=np.float64).tobytes())
        h.update(np.ascontiguousarray(obj.faces, dtype=np.int64).tobytes())
    for a in (scene.segments, scene.segment_family, scene.families, scene.segment_label, scene.sun):
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    h.update(f"{scene.name}|{scene.seed}".encode())
    return h.hexdigest()


_BVH_CACHE: dict = {}


def scene_bvh(scene) -> TriangleBVH:
    """The BVH of all the scene's triangles in W, labelled by object (cached per scene content)."""
    key = getattr(scene, "_catadioptric_digest", None) or scene_digest(scene)
    bvh = _BVH_CACHE.get(key)
    if bvh is None:
        verts, faces, labels = [], [], []
        base = 0
        for i, obj in enumerate(scene.objects):
            v = as_float_array(obj.vertices, f"scene.objects[{i}].vertices", 3)
            f = np.asarray(obj.faces, dtype=np.int64)
            if f.ndim != 2 or f.shape[1] != 3:
                raise CatadioptricError(f"scene.objects[{i}].faces: expected shape (F, 3), got {f.shape}")
            if len(f) and (f.min() < 0 or f.max() >= len(v)):
                raise CatadioptricError(f"scene.objects[{i}].faces: expected vertex indices in [0, {len(v)}), "
                                        f"got range [{int(f.min())}, {int(f.max())}] (object {obj.name!r})")
            if int(obj.label) <= 0:
                raise CatadioptricError(f"scene.objects[{i}].label: expected a positive label (0 is the sky), "
                                        f"got {obj.label!r} (object {obj.name!r})")
            verts.append(v)
            faces.append(f + base)
            labels.append(np.full(len(f), int(obj.label), dtype=np.int64))
            base += len(v)
        if verts:
            bvh = TriangleBVH(np.concatenate(verts), np.concatenate(faces), np.concatenate(labels))
        else:
            bvh = TriangleBVH(np.zeros((0, 3)), np.zeros((0, 3), np.int64))
        if len(_BVH_CACHE) >= 4:
            _BVH_CACHE.pop(next(iter(_BVH_CACHE)))
        _BVH_CACHE[key] = bvh
    return bvh


@dataclass
class TracedRays:
    """Pixel-centre rays of a view traced in float64: the labels plus the geometry behind them."""

    labels: np.ndarray        # (H, W) int32
    origins_W: np.ndarray     # (H, W, 3) reflection points in W (NaN where the pixel misses the mirror)
    directions_W: np.ndarray  # (H, W, 3) unit reflected directions in W
    t: np.ndarray             # (H, W) distance to the first hit (inf: none)
    ambiguous: np.ndarray     # (H, W) a surface of another label lies within TIE_REL * t of the first hit


# relative depth below which two surfaces of different labels tie (float32's resolution): a
# renderer may report either label there, e.g. where coplanar faces of two objects overlap
TIE_REL = 1e-6


_PIXEL_RAYS: dict = {}


def pixel_rays(cam):
    """The reflected rays (:meth:`CatadioptricCamera.backproject`, frame M) of every pixel centre of
    ``cam``, as read-only arrays. They depend on the rig alone, so they are computed once per rig
    and kept (the last two rigs): every view of a dataset, and the renderer's label pass, share them."""
    key = hashlib.sha256(json.dumps(cam.to_dict(), sort_keys=True).encode()).hexdigest()
    rays = _PIXEL_RAYS.get(key)
    if rays is None:
        rays = cam.backproject(cam.pinhole.pixel_grid())
        for a in (rays.origins, rays.directions, rays.valid, rays.hit):
            a.setflags(write=False)
        if len(_PIXEL_RAYS) >= 2:
            _PIXEL_RAYS.pop(next(iter(_PIXEL_RAYS)))
        _PIXEL_RAYS[key] = rays
    return rays


def trace_rays(scene, cam, pose, uv=None, *, ties: bool = True) -> TracedRays:
    """Trace pixel rays (default: every pixel centre) of the rig ``cam`` placed by ``pose``
    (``x_M = R x_W + t``) through the mirror into ``scene`` (in W), in float64.

    ``ties``: also find the pixels whose first hit is ambiguous (a second query excluding
    the first hit's label; about doubles the time)."""
    if uv is None:
        rays = pixel_rays(cam)
    else:
        rays = cam.backproject(as_float_array(uv, "uv", 2))
    shape = rays.valid.shape
    labels = np.full(shape, LABEL_NO_MIRROR, dtype=np.int32)
    labels[rays.hit & ~rays.valid] = LABEL_MIRROR_AGAIN
    o_W = np.where(rays.hit[..., None], (rays.origins - pose.t) @ pose.R, np.nan)
    d_W = np.where(rays.hit[..., None], rays.directions @ pose.R, np.nan)
    t = np.full(shape, np.inf)
    amb = np.zeros(shape, bool)
    ok = rays.valid
    if np.any(ok):
        bvh = scene_bvh(scene)
        hits = bvh.intersect(o_W[ok], d_W[ok])
        lab = bvh.labels_of(hits)
        labels[ok] = lab.astype(np.int32)
        t[ok] = hits.t
        if ties:
            sel = np.flatnonzero(lab > 0)
            # only a window around the first hit matters (other labels are not nearer than it)
            h2 = bvh.intersect(o_W[ok][sel], d_W[ok][sel], t_min=hits.t[sel] * (1 - 2 * TIE_REL),
                               t_max=hits.t[sel] * (1 + 2 * TIE_REL), exclude_labels=lab[sel])
            a = np.zeros(len(lab), bool)
            a[sel] = h2.t <= hits.t[sel] * (1 + TIE_REL)
            amb[ok] = a
    return TracedRays(labels, o_W, d_W, t, amb)


def trace_labels(scene, cam, pose) -> np.ndarray:
    """The exact label image ``(H, W)`` int32 of a view (see the module docstring for the values)."""
    return trace_rays(scene, cam, pose, ties=False).labels
