"""Linking points (band centres and step edges, :mod:`catadioptric.detect.centres`) into chains:
ordered lists of points along one line of the image.

1. :func:`link_chains`: each point is linked to its best neighbour ahead and its best neighbour
   behind along its tangent (within ``radius`` pixels, at most ``max_lateral`` pixels plus a third
   of the distance ahead off the tangent, tangents within ``max_turn_deg``, the same polarity,
   band widths within a factor 2); a link is kept when both points choose it. Every point then
   has at most two links, so the linked components are paths (or closed loops, opened at one
   point), walked from one end, each resampled to one point per ``step`` pixels of arc length
   (the mean of the points in each step). A chain ends where the band turns a corner, meets
   another (a junction) or changes polarity.
2. :func:`join_chains`: chains joined end to end where one continues another, whatever their
   polarity (see its docstring).
"""
from __future__ import annotations

import numpy as np

from .centres import Centres

__all__ = ["link_chains", "join_chains", "resample_chain"]

# points per block of the linking's neighbour search (its arrays hold 12 neighbours per point)
_BLOCK = 1 << 15


def _choices(c: Centres, radius: float, max_lateral: float, max_turn_deg: float, min_step: float, k: int):
    from scipy.spatial import cKDTree

    N = len(c)
    k = min(k, N)
    tree = cKDTree(c.uv)
    T_all = c.tangent
    fwd = np.full(N, -1, dtype=np.int64)
    bwd = np.full(N, -1, dtype=np.int64)
    # in blocks of points (each point's choice is its own): bounded (points, k) arrays
    for a in range(0, N, _BLOCK):
        b = min(a + _BLOCK, N)
        uv, T, nrm, pol, wid = c.uv[a:b], T_all[a:b], c.normal[a:b], c.polarity[a:b], c.width[a:b]
        M = b - a
        dist, idx = tree.query(uv, k=k, distance_upper_bound=radius)
        ok = np.isfinite(dist) & (idx != np.arange(a, b)[:, None])
        idx = np.where(ok, idx, 0)
        d = c.uv[idx] - uv[:, None, :]
        along = np.einsum("ni,nki->nk", T, d)
        lat = np.abs(T[:, None, 0] * d[..., 1] - T[:, None, 1] * d[..., 0])
        # bands: tangents parallel either way; step edges: gradients the same way
        turn = np.einsum("ni,nki->nk", nrm, c.normal[idx])
        turn = np.where(pol[:, None] == 0, turn, np.abs(turn))
        ok &= (lat <= max_lateral + np.abs(along) / 3.0) & (turn >= np.cos(np.radians(max_turn_deg)))
        ok &= (np.abs(along) >= min_step) & (c.polarity[idx] == pol[:, None])
        wr = c.width[idx] / np.maximum(wid[:, None], 1e-9)
        ok &= ((wr <= 2.0) & (wr >= 0.5)) | (pol[:, None] == 0)
        cost = np.hypot(along, lat) + 2.0 * lat
        fw = np.where(ok & (along > 0), cost, np.inf)
        bw = np.where(ok & (along < 0), cost, np.inf)
        r = np.arange(M)
        jf, jb = np.argmin(fw, axis=1), np.argmin(bw, axis=1)
        fwd[a:b] = np.where(np.isfinite(fw[r, jf]), idx[r, jf], -1)
        bwd[a:b] = np.where(np.isfinite(bw[r, jb]), idx[r, jb], -1)
    return fwd, bwd


def link_chains(c: Centres, *, radius: float = 2.0, max_lateral: float = 0.75, max_turn_deg: float = 35.0,
                min_step: float = 0.25, step: float = 1.0, min_points: int = 2) -> list[dict]:
    """Chains of the centre points ``c``: a list of dicts, each with ``uv (M, 2)`` (resampled to
    one point per ``step`` pixels of arc length, in order), ``members`` (indices of the points of
    ``c`` walked, in order), ``polarity``, ``width`` (median), ``strength`` (median). Points less
    than ``min_step`` apart along the tangent are not linked (near duplicates). Chains with fewer
    than ``min_points`` resampled points are left out."""
    N = len(c)
    if N == 0:
        return []
    fwd, bwd = _choices(c, radius, max_lateral, max_turn_deg, min_step, 12)
    links = [[] for _ in range(N)]
    for i in range(N):
        for j in (fwd[i], bwd[i]):
            if j >= 0 and (fwd[j] == i or bwd[j] == i) and j not in links[i]:
                links[i].append(j)
    seen = np.zeros(N, dtype=bool)
    chains = []
    # the tangents once: ``c.tangent`` is a fresh (N, 2) array, and a chain that kept a row of it kept
    # the whole array alive (6,241 chains of an HD render held 3.0 GiB); each chain copies its row
    tangent = c.tangent
    starts = [i for i in range(N) if len(links[i]) == 1] + [i for i in range(N) if len(links[i]) == 2]
    for s in starts:
        if seen[s]:
            continue
        path, prev, cur = [s], -1, s
        seen[s] = True
        while True:
            nxt = [j for j in links[cur] if j != prev and not seen[j]]
            if not nxt:
                break
            prev, cur = cur, nxt[0]
            seen[cur] = True
            path.append(cur)
        members = np.asarray(path)
        uv = resample_chain(c.uv[members], step)
        if len(uv) >= min_points:
            chains.append({"uv": uv, "members": members, "polarity": int(c.polarity[s]),
                           "width": float(np.median(c.width[members])),
                           "strength": float(np.median(c.strength[members])), "tangent": tangent[s].copy()})
    return chains


def _ends(chains: list[dict], span: int = 8, skip: int = 2):
    """Per chain its two ends: positions ``(2K, 2)`` and outward unit directions ``(2K, 2)``
    (end ``2k`` the start of chain k, ``2k + 1`` its end). The direction is that of the chain's
    last ``span`` points but the ``skip`` outermost (which bend where the band meets another)."""
    pos, out = [], []
    for ch in chains:
        uv = ch["uv"]
        M = len(uv)
        if M >= 2:
            sk = skip if M > span + skip else 0
            a = uv[sk] - uv[min(sk + span, M - 1)]
            b = uv[M - 1 - sk] - uv[max(M - 1 - sk - span, 0)]
        else:
            a, b = -ch["tangent"], ch["tangent"]
        pos += [uv[0], uv[-1]]
        out += [a / max(np.linalg.norm(a), 1e-12), b / max(np.linalg.norm(b), 1e-12)]
    return np.array(pos).reshape(-1, 2), np.array(out).reshape(-1, 2)


def join_chains(chains: list[dict], *, radius: float = 5.0, max_lateral: float = 2.0, max_angle_deg: float = 30.0,
                step: float = 1.0) -> list[dict]:
    """Chains joined end to end where one continues another: an end within ``radius`` pixels of
    another chain's end, ahead of it (the gap within ``max_lateral`` of its outward direction, and
    the outward directions opposite within ``max_angle_deg``), whatever their polarity (a tube
    seen as a band over part of its length and as a single edge elsewhere, or a band interrupted
    by a crossing line). Each end joins at most one other, the closest pairs first."""
    from scipy.spatial import cKDTree

    K = len(chains)
    if K < 2:
        return chains
    pos, out = _ends(chains)
    pairs = np.array(sorted(cKDTree(pos).query_pairs(radius)), dtype=np.int64).reshape(-1, 2)
    pairs = pairs[pairs[:, 0] // 2 != pairs[:, 1] // 2]
    if len(pairs) == 0:
        return chains
    a, b = pairs[:, 0], pairs[:, 1]
    gap = pos[b] - pos[a]
    dist = np.linalg.norm(gap, axis=1)
    cos_max = np.cos(np.radians(max_angle_deg))
    opposite = np.sum(out[a] * out[b], axis=1) <= -cos_max

    def lateral(e, g):
        return np.abs(out[e, 0] * g[:, 1] - out[e, 1] * g[:, 0])

    ahead = (np.sum(out[a] * gap, axis=1) >= -0.5) & (np.sum(out[b] * -gap, axis=1) >= -0.5)
    ok = opposite & ahead & (lateral(a, gap) <= max_lateral) & (lateral(b, -gap) <= max_lateral)
    pairs, cost = pairs[ok], (dist + 2.0 * np.maximum(lateral(a, gap), lateral(b, -gap)))[ok]
    partner = np.full(2 * K, -1, dtype=np.int64)
    for k in np.argsort(cost, kind="stable"):
        x, y = pairs[k]
        if partner[x] < 0 and partner[y] < 0:
            partner[x], partner[y] = y, x
    # walk the chains of chains from ends that are not joined
    seen = np.zeros(K, dtype=bool)
    joined = []

    def walk(first_end):
        parts, e = [], first_end
        while True:
            k = e // 2
            if seen[k]:
                break
            seen[k] = True
            uv = chains[k]["uv"] if e % 2 == 0 else chains[k]["uv"][::-1]
            parts.append((k, uv))
            exit_end = e ^ 1
            nxt = partner[exit_end]
            if nxt < 0:
                break
            e = nxt
        return parts

    starts = [e for e in range(2 * K) if partner[e] < 0] + list(range(0, 2 * K, 2))
    for e in starts:
        if seen[e // 2]:
            continue
        parts = walk(e)
        if len(parts) == 1:
            joined.append(chains[parts[0][0]])
            continue
        ks = [k for k, _ in parts]
        n = [len(chains[k]["uv"]) for k in ks]
        main = ks[int(np.argmax(n))]
        joined.append({"uv": np.concatenate([uv for _, uv in parts]),
                       "members": np.concatenate([chains[k]["members"] for k in ks]),
                       "polarity": chains[main]["polarity"], "width": chains[main]["width"],
                       "strength": chains[main]["strength"], "tangent": chains[main]["tangent"], "parts": ks})
    return joined


def resample_chain(uv: np.ndarray, step: float = 1.0) -> np.ndarray:
    """The ordered points ``uv (M, 2)`` averaged in bins of ``step`` pixels of arc length."""
    if len(uv) < 2:
        return uv.copy()
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(uv, axis=0), axis=1))]
    b = np.floor(s / step).astype(np.int64)
    counts = np.bincount(b)
    keep = counts > 0
    out = np.stack([np.bincount(b, uv[:, 0])[keep], np.bincount(b, uv[:, 1])[keep]], axis=1)
    return out / counts[keep][:, None]
