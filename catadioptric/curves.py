"""Tracing image curves of one-parameter families of exactly computed points.

A curve here is given by a function of a parameter (an angle of direction for a
vanishing curve, a position along a 3-D line for a line image) that returns every
image point for each parameter value, NaN-padded along a fixed axis K with a
``valid`` mask. :func:`trace` samples the parameter, bisects it wherever two
neighbouring samples are more than ``max_step_px`` apart on and around the image (far
off it, the allowed step grows with the distance) or where the curve leaves the observable
region (down to ``param_tol``), links each point to the
nearest point of the next sample, and returns the connected pieces as polylines.
Every vertex is an exactly computed point; nothing is interpolated.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._checks import CatadioptricError, as_count, as_scalar

__all__ = ["Piece", "trace", "sweep_options", "MAX_VERTICES", "image_size"]

MIN_STEP_PX = 1e-6
OFF_IMAGE = 0.5  # off the image, the allowed step grows by this fraction of the distance from it
MAX_VERTICES = 250_000  # samples of one curve: a curve across a 16k image at 1 px needs far fewer


def sweep_options(max_step_px, n_start, max_rounds):
    """The checked options of a curve sweep (:func:`trace`)."""
    step = as_scalar(max_step_px, "max_step_px", positive=True)
    if step < MIN_STEP_PX:
        raise CatadioptricError(f"max_step_px: expected a step of at least {MIN_STEP_PX:g} px (pixels are exact to "
                                f"about 1e-9 px; finer steps only multiply vertices), got {step!r}")
    return (step, as_count(n_start, "n_start", minimum=2, maximum=1_000_000),
            as_count(max_rounds, "max_rounds", minimum=0, maximum=10_000))


@dataclass
class Piece:
    """One connected piece of a traced curve: ``uv (M, 2)``, ``mirror_points (M, 3)``,
    ``params (M,)``, ``closed`` (the last vertex connects to the first), and whether the
    piece reaches the ``start`` / ``stop`` of the parameter range."""

    curve: int
    uv: np.ndarray
    mirror_points: np.ndarray
    params: np.ndarray
    closed: bool = False
    at_start: bool = False
    at_stop: bool = False


class _Reach:
    """The largest allowed distance between neighbouring vertices at pixels ``uv``: ``max_step_px``
    on the image and within one image size around it (``image = (width, height)``); beyond, plus
    half the distance from that margin, so that a curve running off toward infinity (a point near
    the camera's horizon) needs a number of vertices that grows with the logarithm of its length,
    not with its length."""

    def __init__(self, step: float, image):
        self.step, self.image = step, image

    def __call__(self, uv: np.ndarray) -> np.ndarray:
        if self.image is None:
            return np.full(uv.shape[:-1], self.step)
        W, H = self.image
        m = max(W, H)
        with np.errstate(invalid="ignore"):
            du = np.maximum(np.maximum(-0.5 - m - uv[..., 0], uv[..., 0] - (W - 0.5 + m)), 0.0)
            dv = np.maximum(np.maximum(-0.5 - m - uv[..., 1], uv[..., 1] - (H - 0.5 + m)), 0.0)
            out = self.step + OFF_IMAGE * np.hypot(du, dv)
        return np.where(np.isfinite(out), out, self.step)


def trace(evaluate, start, stop, *, periodic=False, max_step_px=1.0, n_start=64, param_tol=1e-9,
          max_rounds=60, seeds=None, image=None) -> list[list[Piece]]:
    """Trace curves ``c = 0 .. C-1`` over parameters ``[start[c], stop[c]]``.

    ``evaluate(curve_ids (n,), params (n,)) -> (uv (n, K, 2), mirror_points (n, K, 3), valid (n, K))``.
    With ``periodic``, ``stop`` is identified with ``start`` (e.g. angles over a full turn).
    ``seeds = (curve_ids, params)``: extra starting samples, e.g. parameters known to be
    seen by some pixel (see :func:`image_seeds`), so that pieces visible over a tiny range of
    the parameter are not missed between the uniform samples.
    ``image = (width, height)``: beyond one image size around the image, the step grows with the
    distance (half of it is added to ``max_step_px``).
    Returns, for each curve, its list of pieces. A curve that needs more than
    :data:`MAX_VERTICES` samples (a step far below a pixel) is refused, not traced for ever.
    """
    max_step_px, n_start, max_rounds = sweep_options(max_step_px, n_start, max_rounds)
    reach = _Reach(max_step_px, image)
    start = np.atleast_1d(np.asarray(start, float))
    stop = np.atleast_1d(np.asarray(stop, float))
    C = len(start)
    u = np.linspace(0.0, 1.0, n_start, endpoint=not periodic)
    cid = np.repeat(np.arange(C), n_start)
    par = (start[:, None] + (stop - start)[:, None] * u[None, :]).ravel()
    if seeds is not None and len(seeds[0]):
        sc, sp = np.asarray(seeds[0], dtype=np.intp), np.asarray(seeds[1], float)
        inside = (sp >= start[sc]) & (sp < stop[sc]) if periodic else (sp >= start[sc]) & (sp <= stop[sc])
        cid = np.r_[cid, sc[inside]]
        par = np.r_[par, sp[inside]]
        order = np.lexsort((par, cid))
        cid, par = cid[order], par[order]
    uv, r, valid = evaluate(cid, par)
    # intervals between neighbouring samples of one curve (and the wrap of a periodic one); only
    # the intervals created in the last round are checked again
    same = np.r_[cid[1:] == cid[:-1], False]
    left = np.nonzero(same)[0]
    right = left + 1
    if periodic:
        first = np.r_[0, np.nonzero(cid[1:] != cid[:-1])[0] + 1]
        last = np.r_[first[1:] - 1, len(cid) - 1]
        left, right = np.r_[left, last], np.r_[right, first]
    period = (stop - start)[cid]
    for _ in range(max_rounds):
        if len(left) == 0:
            break
        pl = par[left]
        pr_ = par[right] + np.where(par[right] < pl, period[left], 0.0)  # the wrap of a periodic curve
        va, vb = valid[left], valid[right]
        kk = max(int(va.sum(axis=1).max(initial=0)), int(vb.sum(axis=1).max(initial=0)), 1)  # valid slots come first
        d = np.linalg.norm(uv[left, :kk, None, :] - uv[right, None, :kk, :], axis=-1)
        d = np.where(va[:, :kk, None] & vb[:, None, :kk], d, np.inf)
        far = np.any(va[:, :kk] & (d.min(axis=2) > reach(uv[left, :kk])), axis=1) | \
            np.any(vb[:, :kk] & (d.min(axis=1) > reach(uv[right, :kk])), axis=1)
        need = far & (pr_ - pl > param_tol)
        if not np.any(need):
            break
        l, rr = left[need], right[need]
        mc = cid[l]
        counts = np.bincount(np.r_[cid, mc], minlength=C)
        if counts.max() > MAX_VERTICES:
            raise CatadioptricError(
                f"max_step_px: a step of {max_step_px!r} px needs more than {MAX_VERTICES} samples on one curve; "
                f"expected a larger step")
        mid = 0.5 * (pl[need] + pr_[need])
        if periodic:
            mid = np.where(mid >= stop[mc], mid - (stop - start)[mc], mid)
        uv2, r2, v2 = evaluate(mc, mid)
        new = np.arange(len(cid), len(cid) + len(mc))
        cid, par = np.r_[cid, mc], np.r_[par, mid]
        period = np.r_[period, (stop - start)[mc]]
        uv, r, valid = np.concatenate([uv, uv2]), np.concatenate([r, r2]), np.concatenate([valid, v2])
        left, right = np.r_[l, new], np.r_[new, rr]
    order = np.lexsort((par, cid))
    cid, par, uv, r, valid = cid[order], par[order], uv[order], r[order], valid[order]
    cut = np.searchsorted(cid, np.arange(C + 1))  # curve c is samples cut[c]:cut[c + 1]
    return [_merge(_chain(c, *(x[cut[c]:cut[c + 1]] for x in (par, uv, r, valid)), periodic, reach,
                          start[c], stop[c]), periodic, reach) for c in range(C)]


def _near(a: np.ndarray, b: np.ndarray, reach: _Reach, factor: float = 1.0) -> bool:
    return bool(np.linalg.norm(a - b) <= factor * max(reach(a), reach(b)))


def _merge(pieces: list[Piece], periodic: bool, reach: _Reach) -> list[Piece]:
    """Join pieces that continue one another (the end of one within a step of the start of the
    next: where two branches touch, the matching of samples can cut a curve), and close loops."""
    pieces = list(pieces)
    changed = True
    while changed:
        changed = False
        for a in range(len(pieces)):
            A = pieces[a]
            if A.closed:
                continue
            for b in range(len(pieces)):
                B = pieces[b]
                if b == a or B.closed or not _near(A.uv[-1], B.uv[0], reach):
                    continue
                pieces[a] = Piece(A.curve, np.concatenate([A.uv, B.uv]), np.concatenate([A.mirror_points, B.mirror_points]),
                                  np.concatenate([A.params, B.params]), False, A.at_start, B.at_stop)
                del pieces[b]
                changed = True
                break
            if changed:
                break
    for p in pieces:
        if periodic and not p.closed and len(p.uv) > 2 and _near(p.uv[-1], p.uv[0], reach):
            p.closed = True
    return pieces


def _piece(c, uv, r, par, ii, kk, closed, periodic, start, stop):
    if len(ii) > 1:  # the bisection can stack vertices at a piece's end: drop repeats
        keep = np.r_[True, np.linalg.norm(np.diff(uv[ii, kk], axis=0), axis=1) > 1e-9]
        ii, kk = ii[keep], kk[keep]
    return Piece(c, uv[ii, kk], r[ii, kk], par[ii], closed,
                 at_start=(not periodic) and bool(par[ii[0]] == start),
                 at_stop=(not periodic) and bool(par[ii[-1]] == stop))


def _chain(c, par, uv, r, valid, periodic, reach, start, stop) -> list[Piece]:
    """Link each valid point to the nearest valid point of the next sample (within twice the step)."""
    n, K = valid.shape
    if n and valid.sum(axis=1).max(initial=0) <= 1:
        return _chain_single(c, par, uv, r, valid, periodic, reach, start, stop)
    allow = reach(uv)
    succ, pred = {}, {}
    for i in range(n if periodic else n - 1):
        j = (i + 1) % n
        if not np.any(valid[i]) or not np.any(valid[j]):
            continue
        d = np.linalg.norm(uv[i][:, None, :] - uv[j][None, :, :], axis=-1)
        d = np.where(valid[i][:, None] & valid[j][None, :], d, np.inf)
        d = np.where(d <= 2 * np.maximum(allow[i][:, None], allow[j][None, :]), d, np.inf)
        # greedy one-to-one matching, closest pairs first
        for flat in np.argsort(d, axis=None):
            a, b = divmod(int(flat), K)
            if not np.isfinite(d[a, b]):
                break
            if (i, a) in succ or (j, b) in pred:
                continue
            succ[(i, a)] = (j, b)
            pred[(j, b)] = (i, a)
    nodes = [(i, k) for i in range(n) for k in range(K) if valid[i, k]]
    pieces, seen = [], set()
    for st in [nd for nd in nodes if nd not in pred] + nodes:
        if st in seen:
            continue
        chain, cur, closed = [st], st, False
        seen.add(st)
        while cur in succ:
            cur = succ[cur]
            if cur == st:
                closed = True
                break
            if cur in seen:
                break
            chain.append(cur)
            seen.add(cur)
        ii = np.array([p[0] for p in chain])
        kk = np.array([p[1] for p in chain])
        pieces.append(_piece(c, uv, r, par, ii, kk, closed, periodic, start, stop))
    return pieces


def _chain_single(c, par, uv, r, valid, periodic, reach, start, stop) -> list[Piece]:
    """Fast path when every sample has at most one valid point: pieces are runs of linked samples."""
    n = len(par)
    k = np.argmax(valid, axis=1)
    has = valid[np.arange(n), k]
    p = uv[np.arange(n), k]
    nxt = np.r_[np.arange(1, n), 0]
    link = has & has[nxt] & (np.linalg.norm(p[nxt] - p, axis=1) <= 2 * np.maximum(reach(p), reach(p[nxt])))
    if not periodic:
        link[-1] = False
    idx = np.arange(n)
    if periodic and np.all(link):
        return [_piece(c, uv, r, par, idx, k, True, periodic, start, stop)]
    # runs: a run starts at a valid sample not linked from its predecessor
    prev_link = np.r_[link[-1] if periodic else False, link[:-1]]
    starts = np.nonzero(has & ~prev_link)[0]
    if len(starts) == 0:
        return []
    rot = np.roll(idx, -starts[0]) if periodic else idx  # periodic: begin at a run start
    link_r, starts_r = link[rot], np.searchsorted(rot, starts) if not periodic else (starts - starts[0]) % n
    starts_r = np.sort(starts_r)
    breaks = np.nonzero(~link_r)[0]
    ends = breaks[np.searchsorted(breaks, starts_r)]  # last sample of each run
    return [_piece(c, uv, r, par, rot[a:b + 1], k[rot[a:b + 1]], False, periodic, start, stop)
            for a, b in zip(starts_r, ends)]


def image_size(cam) -> tuple[int, int]:
    """``(width, height)`` of any camera: a model of this package, an exact rig (its pinhole's)
    or a :class:`~catadioptric.unified.UnifiedCamera` with a size."""
    pin = getattr(cam, "pinhole", None)
    if pin is not None:
        return int(pin.width), int(pin.height)
    w, h = getattr(cam, "width", None), getattr(cam, "height", None)
    if w is None or h is None:
        raise CatadioptricError(f"cam: expected a camera with an image size, got {type(cam).__name__} without one")
    return int(w), int(h)


def pixel_grid_rays(cam, step: int):
    """Reflected rays of every ``step``-th pixel of the image that sees the world, with the
    angle between each ray and its grid neighbours (the angular resolution of the grid there)."""
    grid = (cam.pinhole if hasattr(cam, "pinhole") else cam).pixel_grid(step)
    rays = cam.backproject(grid)
    d = rays.directions
    ang = np.full(d.shape[:2], np.nan)
    with np.errstate(invalid="ignore"):
        for axis in (0, 1):
            a = np.arccos(np.clip(np.sum(np.take(d, range(1, d.shape[axis]), axis=axis)
                                         * np.take(d, range(d.shape[axis] - 1), axis=axis), axis=-1), -1, 1))
            pad = [(0, 0), (0, 0)]
            pad[axis] = (0, 1)
            ang = np.fmax(ang, np.pad(a, pad, constant_values=np.nan))
    ok = rays.valid & np.isfinite(ang)
    return rays.origins[ok], rays.directions[ok], ang[ok]
