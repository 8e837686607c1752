"""Our float64 label tracer: the ground truth every renderer is checked against.

Pixel-centre rays are reflected on the exact quadric by :func:`catadioptric.projection.backproject`
(float64) and intersected with the scene's triangles in float64 by a bounding-volume
hierarchy traversed breadth-first over whole batches of rays with numpy:

* build: triangles longer than 1/128 of the scene's extent are first bisected along their
  longest edge (the surface is unchanged; a ground plane of two triangles would otherwise
  give boxes every ray enters), then a balanced median-split tree in complete-binary
  layout (node ``i`` of level ``l`` covers the triangles ``[floor(i N / 2^l),
  floor((i + 1) N / 2^l))`` of a permutation that is re-sorted, level by level, along each
  node's longest centroid extent);
* traversal: (ray, node) pairs go down ``SUBTREE`` levels together (one slab test per pair
  and level), then each ray visits its subtrees nearest box first, in rounds, and skips
  the boxes farther than its best hit so far, down to the leaves;
* triangles: Moeller-Trumbore in float64.

Labels (docs/formats.md, "Datasets"): ``0`` nothing hit (sky), ``-1`` the pixel does not
see the mirror, ``-2`` the reflected ray meets the mirror again; otherwise the label of
the first object hit.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError, as_float_array

__all__ = ["TriangleBVH", "scene_bvh", "trace_labels", "trace_rays", "scene_digest",
           "LABEL_SKY", "LABEL_NO_MIRROR", "LABEL_MIRROR_AGAIN"]

LABEL_SKY = 0
LABEL_NO_MIRROR = -1
LABEL_MIRROR_AGAIN = -2

LEAF = 4            # triangles per leaf (at most)
RAY_CHUNK = 1 << 15  # rays traversed together (bounds the memory of the pair lists)
SUBTREE = 4          # levels descended breadth-first before the pairs are visited nearest box first
SPLIT_FRACTION = 128  # triangles longer than 1/128 of the scene's extent are split for the hierarchy
_BARY_TOL = 1e-12    # barycentric slack: a ray through a shared edge hits one of its triangles


@dataclass
class Hits:
    """First hits of rays: ``t (N,)`` (inf where none), ``triangle (N,)`` (-1 where none)."""

    t: np.ndarray
    triangle: np.ndarray


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
        self.v0 = t[:, 0].copy()
        self.e1 = t[:, 1] - t[:, 0]
        self.e2 = t[:, 2] - t[:, 0]
        self.tri_labels = self.labels[perm]
        nleaf = 1 << depth
        self.leaf_bounds = (np.arange(nleaf + 1) * self.n) >> depth
        lo = np.minimum.reduceat(t.min(axis=1), self.leaf_bounds[:-1], axis=0)
        hi = np.maximum.reduceat(t.max(axis=1), self.leaf_bounds[:-1], axis=0)
        pad = 1e-9 * (np.abs(lo) + np.abs(hi) + (hi - lo)) + 1e-12
        lo, hi = lo - pad, hi + pad
        # boxes per level as (6, nodes) rows lo_x, lo_y, lo_z, hi_x, hi_y, hi_z (one gather per level)
        self.boxes = [None] * (depth + 1)
        self.boxes[depth] = np.concatenate([lo.T, hi.T])
        for level in range(depth - 1, -1, -1):
            lo = np.minimum(lo[0::2], lo[1::2])
            hi = np.maximum(hi[0::2], hi[1::2])
            self.boxes[level] = np.concatenate([lo.T, hi.T])
        self.leaf_size = int(np.max(np.diff(self.leaf_bounds)))

    # ------------------------------------------------------------------ queries
    def intersect(self, origins, directions, t_min=0.0, t_max=None, exclude_labels=None) -> Hits:
        """First hit with ``t_min < t < t_max`` of each ray ``origins + t directions`` (float64).

        ``t_min``, ``t_max``: numbers or one per ray (default: 0 and no limit; a narrow window
        prunes the traversal).
        ``exclude_labels (N,)``: triangles of that label are ignored for that ray (-1: none)."""
        o = as_float_array(origins, "origins", 3).reshape(-1, 3)
        d = as_float_array(directions, "directions", 3).reshape(-1, 3)
        if o.shape != d.shape:
            raise CatadioptricError(f"origins, directions: expected the same shape, got {o.shape} and {d.shape}")
        t = np.full(len(o), np.inf)
        tri = np.full(len(o), -1, dtype=np.int64)
        ex = None if exclude_labels is None else np.asarray(exclude_labels, dtype=np.int64).reshape(-1)
        if ex is not None and ex.shape != (len(o),):
            raise CatadioptricError(f"exclude_labels: expected shape ({len(o)},), got {ex.shape}")
        tmax = np.broadcast_to(np.inf if t_max is None else np.asarray(t_max, dtype=np.float64), (len(o),))
        tmin = np.broadcast_to(np.asarray(t_min, dtype=np.float64), (len(o),))
        if self.n == 0:
            return Hits(t, tri)
        for s in range(0, len(o), RAY_CHUNK):
            tt, ii = self._intersect_chunk(o[s:s + RAY_CHUNK], d[s:s + RAY_CHUNK], tmin[s:s + RAY_CHUNK],
                                           tmax[s:s + RAY_CHUNK],
                                           None if ex is None else ex[s:s + RAY_CHUNK])
            t[s:s + RAY_CHUNK] = tt
            tri[s:s + RAY_CHUNK] = ii
        return Hits(t, tri)

    def _slab(self, level, nodes, o, inv, tmin, tmax):
        """Entry distance of rays ``o, inv`` (3, P) into boxes ``nodes`` of ``level`` and whether they enter."""
        bx = self.boxes[level][:, nodes]
        near = np.array(tmin, dtype=np.float64)
        far = np.array(tmax, dtype=np.float64)
        with np.errstate(invalid="ignore"):
            for k in range(3):
                t0 = (bx[k] - o[k]) * inv[k]
                t1 = (bx[k + 3] - o[k]) * inv[k]
                # NaN (0 * inf) where the origin lies on a slab plane of a parallel ray: fmax/fmin ignore it
                np.fmax(near, np.minimum(t0, t1), out=near)
                np.fmin(far, np.maximum(t0, t1), out=far)
        return near, near <= far

    def _descend(self, rays, nodes, level, steps, oT, inv, t_min, best_t):
        """Breadth-first from ``level`` down ``steps`` levels: the (ray, node) pairs whose boxes the
        rays enter before their current best hit, with the entry distances."""
        near, ok = self._slab(level, nodes, oT[:, rays], inv[:, rays], t_min[rays], best_t[rays])
        rays, nodes, near = rays[ok], nodes[ok], near[ok]
        if steps:
            return self._descend_children(rays, nodes, level, steps, oT, inv, t_min, best_t)
        return rays, nodes, near

    def _ordered(self, rays, nodes, near, level, ctx):
        """Visit the subtrees (ray, node at ``level``) nearest box first, in rounds of growing width:
        a ray stops descending into boxes farther than its best hit so far."""
        o, d, oT, inv, t_min, best_t, best_i, ex = ctx
        order = np.lexsort((near, rays))
        rays, nodes, near = rays[order], nodes[order], near[order]
        rank = np.arange(len(rays)) - np.searchsorted(rays, rays, side="left")
        max_rank = int(rank.max(initial=-1))
        lo_rank, width = 0, 1
        while lo_rank <= max_rank:
            sel = (rank >= lo_rank) & (rank < lo_rank + width)
            r, nd, nr = rays[sel], nodes[sel], near[sel]
            keep = nr <= best_t[r]
            r, nd = r[keep], nd[keep]
            if len(r):
                if level == self.depth:
                    self._test_leaves(r, nd, o, d, t_min, best_t, best_i, ex)
                else:
                    steps = min(SUBTREE, self.depth - level)
                    r2, n2, near2 = self._descend(r, nd, level, steps, oT, inv, t_min, best_t)
                    if len(r2):
                        self._ordered(r2, n2, near2, level + steps, ctx)
            lo_rank += width
            width *= 2

    def _descend_children(self, rays, nodes, level, steps, oT, inv, t_min, best_t):
        near = None
        for lv in range(level + 1, level + steps + 1):
            rays = np.repeat(rays, 2)
            nodes = np.repeat(nodes << 1, 2)
            nodes[1::2] += 1
            near, ok = self._slab(lv, nodes, oT[:, rays], inv[:, rays], t_min[rays], best_t[rays])
            rays, nodes, near = rays[ok], nodes[ok], near[ok]
        return rays, nodes, near

    def _intersect_chunk(self, o, d, t_min, tmax, ex):
        n = len(o)
        with np.errstate(divide="ignore"):
            inv = np.ascontiguousarray((1.0 / d).T)
        oT = np.ascontiguousarray(o.T)
        best_t = np.array(tmax, dtype=np.float64)  # hits must come before t_max
        best_i = np.full(n, -1, dtype=np.int64)
        top = min(SUBTREE, self.depth)
        rays, nodes, near = self._descend(np.arange(n), np.zeros(n, dtype=np.int64), 0, top, oT, inv, t_min,
                                          best_t)
        if len(rays):
            self._ordered(rays, nodes, near, top, (o, d, oT, inv, t_min, best_t, best_i, ex))
        return np.where(best_i >= 0, best_t, np.inf), best_i

    def _test_leaves(self, r, nd, o, d, t_min, best_t, best_i, ex=None):
        start = self.leaf_bounds[nd]
        count = self.leaf_bounds[nd + 1] - start
        k = np.arange(self.leaf_size)
        m = k[None, :] < count[:, None]
        rr = np.broadcast_to(r[:, None], m.shape)[m]
        ti = (start[:, None] + k[None, :])[m]
        t = _moller_trumbore(o[rr], d[rr], self.v0[ti], self.e1[ti], self.e2[ti], t_min[rr])
        hit = t < best_t[rr]
        if ex is not None:
            hit &= self.tri_labels[ti] != ex[rr]
        if not np.any(hit):
            return
        rr, ti, t = rr[hit], ti[hit], t[hit]
        order = np.lexsort((ti, t, rr))  # nearest per ray; ties go to the lower triangle index
        rr, ti, t = rr[order], ti[order], t[order]
        head = np.ones(len(rr), bool)
        head[1:] = rr[1:] != rr[:-1]
        rr, ti, t = rr[head], ti[head], t[head]
        better = t < best_t[rr]
        best_t[rr[better]] = t[better]
        best_i[rr[better]] = ti[better]

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


def _moller_trumbore(o, d, v0, e1, e2, t_min):
    """Ray-triangle distances (inf where no hit), float64, rows in parallel (component-wise for speed)."""
    ox, oy, oz = o.T
    dx, dy, dz = d.T
    ax, ay, az = e1.T
    bx, by, bz = e2.T
    px, py, pz = dy * bz - dz * by, dz * bx - dx * bz, dx * by - dy * bx  # d x e2
    det = ax * px + ay * py + az * pz
    sx, sy, sz = ox - v0[:, 0], oy - v0[:, 1], oz - v0[:, 2]
    qx, qy, qz = sy * az - sz * ay, sz * ax - sx * az, sx * ay - sy * ax  # s x e1
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        u = (sx * px + sy * py + sz * pz) * inv
        v = (dx * qx + dy * qy + dz * qz) * inv
        t = (bx * qx + by * qy + bz * qz) * inv
        ok = (det != 0) & (u >= -_BARY_TOL) & (v >= -_BARY_TOL) & (u + v <= 1 + _BARY_TOL) & (t > t_min)
    return np.where(ok, t, np.inf)


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


def trace_rays(scene, cam, pose, uv=None, *, ties: bool = True) -> TracedRays:
    """Trace pixel rays (default: every pixel centre) of the rig ``cam`` placed by ``pose``
    (``x_M = R x_W + t``) through the mirror into ``scene`` (in W), in float64.

    ``ties``: also find the pixels whose first hit is ambiguous (a second query excluding
    the first hit's label; about doubles the time)."""
    if uv is None:
        uv = cam.pinhole.pixel_grid()
    uv = as_float_array(uv, "uv", 2)
    rays = cam.backproject(uv)
    shape = uv.shape[:-1]
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
