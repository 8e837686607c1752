"""The compiled inner loops of the float64 label tracer (:mod:`catadioptric.render.tracer`), numba.

One ray at a time, depth first through the hierarchy (the nearer child box first, boxes
beyond the best hit so far skipped), Moeller-Trumbore on the leaves' triangles, all in
float64 with the same operations in the same order as the formulas in the tracer's
docstring (no fast-math: every distance is the correctly rounded result of those
operations, whatever the batch or the thread). A ray's answer is the nearest hit; among
hits at exactly the same distance, the triangle of lowest index in the hierarchy's order.

Imported only through :func:`catadioptric.render.tracer.TriangleBVH.intersect` (numba is
the ``render`` extra's).
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["intersect_rays", "BARY_TOL"]

BARY_TOL = 1e-12  # barycentric slack: a ray through a shared edge hits one of its triangles (at least)

_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


@njit(**_JIT)
def _slab(boxes, k, ox, oy, oz, ix, iy, iz, near, far):
    """Entry distance of the ray into box ``k`` (rows lo_x, lo_y, lo_z, hi_x, hi_y, hi_z) clipped
    to ``[near, far]``, and whether it enters. An axis along which the origin lies on a slab plane
    of a parallel ray (0 * inf = NaN) does not clip."""
    t0 = (boxes[k, 0] - ox) * ix
    t1 = (boxes[k, 3] - ox) * ix
    if t0 == t0 and t1 == t1:
        near = max(near, min(t0, t1))
        far = min(far, max(t0, t1))
    t0 = (boxes[k, 1] - oy) * iy
    t1 = (boxes[k, 4] - oy) * iy
    if t0 == t0 and t1 == t1:
        near = max(near, min(t0, t1))
        far = min(far, max(t0, t1))
    t0 = (boxes[k, 2] - oz) * iz
    t1 = (boxes[k, 5] - oz) * iz
    if t0 == t0 and t1 == t1:
        near = max(near, min(t0, t1))
        far = min(far, max(t0, t1))
    return near, near <= far


@njit(**_JIT)
def _triangle(ox, oy, oz, dx, dy, dz, v0, e1, e2, i, t_min):
    """Distance along the ray to triangle ``i`` (inf where it misses), Moeller-Trumbore."""
    ax, ay, az = e1[i, 0], e1[i, 1], e1[i, 2]
    bx, by, bz = e2[i, 0], e2[i, 1], e2[i, 2]
    px = dy * bz - dz * by  # d x e2
    py = dz * bx - dx * bz
    pz = dx * by - dy * bx
    det = ax * px + ay * py + az * pz
    if det == 0.0:
        return np.inf
    inv = 1.0 / det
    sx = ox - v0[i, 0]
    sy = oy - v0[i, 1]
    sz = oz - v0[i, 2]
    u = (sx * px + sy * py + sz * pz) * inv
    if not u >= -BARY_TOL:
        return np.inf
    qx = sy * az - sz * ay  # s x e1
    qy = sz * ax - sx * az
    qz = sx * ay - sy * ax
    v = (dx * qx + dy * qy + dz * qz) * inv
    if not (v >= -BARY_TOL and u + v <= 1.0 + BARY_TOL):
        return np.inf
    t = (bx * qx + by * qy + bz * qz) * inv
    if not t > t_min:
        return np.inf
    return t


@njit(**_JIT)
def intersect_rays(o, d, t_min, t_max, exclude, use_exclude, boxes, leaf_bounds, depth, v0, e1, e2, labels,
                   out_t, out_i):
    """First hit ``t_min < t < t_max`` of each ray ``o[r] + t d[r]``: ``out_t`` (inf: none) and
    ``out_i`` (-1: none). ``boxes (2^(depth+1) - 1, 6)``: the complete tree in heap order (node
    ``k``'s children ``2k + 1``, ``2k + 2``; leaf ``j`` is node ``2^depth - 1 + j`` and holds
    triangles ``leaf_bounds[j]:leaf_bounds[j + 1]``). With ``use_exclude``, triangles whose label
    is ``exclude[r]`` are ignored for ray ``r``."""
    first_leaf = (1 << depth) - 1
    stack_node = np.empty(2 * depth + 8, np.int64)
    stack_near = np.empty(2 * depth + 8, np.float64)
    for r in range(o.shape[0]):
        ox, oy, oz = o[r, 0], o[r, 1], o[r, 2]
        dx, dy, dz = d[r, 0], d[r, 1], d[r, 2]
        ix, iy, iz = 1.0 / dx, 1.0 / dy, 1.0 / dz
        lo = t_min[r]
        best_t = t_max[r]
        best_i = -1
        sp = 0
        near, enters = _slab(boxes, 0, ox, oy, oz, ix, iy, iz, lo, best_t)
        if enters:
            stack_node[0] = 0
            stack_near[0] = near
            sp = 1
        while sp > 0:
            sp -= 1
            node = stack_node[sp]
            if stack_near[sp] > best_t:
                continue
            if node >= first_leaf:
                leaf = node - first_leaf
                for i in range(leaf_bounds[leaf], leaf_bounds[leaf + 1]):
                    if use_exclude and labels[i] == exclude[r]:
                        continue
                    t = _triangle(ox, oy, oz, dx, dy, dz, v0, e1, e2, i, lo)
                    if t < best_t or (t == best_t and best_i >= 0 and i < best_i):
                        best_t = t
                        best_i = i
                continue
            c = 2 * node + 1
            n0, ok0 = _slab(boxes, c, ox, oy, oz, ix, iy, iz, lo, best_t)
            n1, ok1 = _slab(boxes, c + 1, ox, oy, oz, ix, iy, iz, lo, best_t)
            # pushed last = visited first: the nearer child
            if ok0 and ok1:
                if n0 <= n1:
                    stack_node[sp], stack_near[sp] = c + 1, n1
                    stack_node[sp + 1], stack_near[sp + 1] = c, n0
                else:
                    stack_node[sp], stack_near[sp] = c, n0
                    stack_node[sp + 1], stack_near[sp + 1] = c + 1, n1
                sp += 2
            elif ok0:
                stack_node[sp], stack_near[sp] = c, n0
                sp += 1
            elif ok1:
                stack_node[sp], stack_near[sp] = c + 1, n1
                sp += 1
        out_t[r] = best_t if best_i >= 0 else np.inf
        out_i[r] = best_i
