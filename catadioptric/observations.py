"""The pixels of each labelled line in a rendered view: what the relative-pose experiments
observe, with the labels used only to say which pixels belong to which line.

Two ways (``pixels``):

* ``"curve"``: the line's exact image curve (ground truth, every vertex an exact forward
  projection) where the label image shows the line: a vertex counts when the line is visible
  there (``line_visible``, on the image) and the line's label covers a pixel centre within one
  pixel of it. The visible runs are thinned to about one vertex per pixel of arc length. These
  are the paper's "image points": exact, sub-pixel, with no rasterisation bias.
* ``"ridge"``: integer pixel centres on the centre line of the line's label band (a one-pixel
  ridge of the distance transform). Off the true curve by up to half a pixel, the same way
  along the line: a bias that sets an error floor (kept for comparison).

Gaussian noise of ``noise_px`` (per coordinate) is added to either.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._checks import CatadioptricError

__all__ = ["LinePixels", "line_pixels", "ridge_pixels", "curve_pixels", "label_near", "PIXEL_MODES"]

PIXEL_MODES = ("curve", "ridge")


@dataclass
class LinePixels:
    """Per line seen by a view (at least ``min_pixels``): ``uv`` (list of ``(M_i, 2)``), ``family``,
    ``segment`` (the segment index, shared by all views of one scene) and ``label``; ``counts``:
    per family ``{"lines": n, "pixels": n}`` of what the view sees, and ``short``: lines dropped
    for having fewer than ``min_pixels``."""

    uv: list
    family: list
    segment: list
    label: list
    counts: dict
    short: int


def ridge_pixels(labels: np.ndarray, label: int) -> np.ndarray:
    """Pixel centres ``(M, 2)`` (u, v) on the ridge of the label band of ``label``: a pixel is kept
    where the band's distance transform is a strict local maximum across the band."""
    import cv2

    mask = labels == label
    d = cv2.distanceTransform(np.pad(mask, 1).astype(np.uint8), cv2.DIST_L2, 5)
    core = d[1:-1, 1:-1]
    ridge = np.zeros_like(mask)
    for dy, dx in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = d[1 + dy: d.shape[0] - 1 + dy, 1 + dx: d.shape[1] - 1 + dx]
        b = d[1 - dy: d.shape[0] - 1 - dy, 1 - dx: d.shape[1] - 1 - dx]
        ridge |= (core >= a) & (core >= b) & ((core > a) | (core > b))
    rows, cols = np.nonzero(mask & ridge)
    return np.stack([cols, rows], axis=1).astype(float)


def label_near(labels: np.ndarray, uv: np.ndarray, label) -> np.ndarray:
    """True where ``label`` covers a pixel centre within one pixel (3 x 3 neighbourhood) of ``uv``.
    ``label``: one label, or one per point ``(M,)``."""
    H, W = labels.shape
    c = np.rint(uv).astype(int)
    label = np.broadcast_to(np.asarray(label), (len(uv),))
    hit = np.zeros(len(uv), dtype=bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            x, y = c[:, 0] + dx, c[:, 1] + dy
            ok = (x >= 0) & (x < W) & (y >= 0) & (y < H)
            hit[ok] |= labels[y[ok], x[ok]] == label[ok]
    return hit


def _thin(uv: np.ndarray, step: float = 1.0) -> np.ndarray:
    """The vertices of the polyline ``uv`` (exact curve points, at most one pixel apart) nearest each
    multiple of ``step`` pixels of arc length: about one point per pixel, each exactly on the curve
    (interpolating between vertices would put points off the curve by the chords' sagitta)."""
    if len(uv) < 2:
        return uv
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(uv, axis=0), axis=1))]
    k = np.unique(np.clip(np.searchsorted(s, np.arange(0.0, s[-1] + 1e-9, step)), 0, len(uv) - 1))
    return uv[k]


def _shown(curves: list, labels: np.ndarray, label_of: dict) -> dict:
    """Per segment of ``label_of`` (segment -> its label), each of its curves' vertices where the
    label image shows it (visible, on the image, the label within one pixel): ``{segment: [(uv, ok)]}``.
    Every curve's vertices are tested in one pass."""
    mine = [c for c in curves if c["segment"] in label_of]
    out: dict = {}
    if not mine:
        return out
    uv = np.concatenate([np.nan_to_num(c["uv"]) for c in mine])
    ok = np.concatenate([c["visible"] & c["in_image"] for c in mine])
    lab = np.concatenate([np.full(len(c["uv"]), label_of[c["segment"]]) for c in mine])
    ok[ok] = label_near(labels, uv[ok], lab[ok])
    start = np.cumsum([0] + [len(c["uv"]) for c in mine])
    for c, a, b in zip(mine, start[:-1], start[1:]):
        out.setdefault(c["segment"], []).append((c["uv"], ok[a:b]))
    return out


def _runs_thinned(shown: list) -> np.ndarray:
    """The visible runs (at least two vertices) of a segment's curves, each thinned to one vertex per
    pixel of arc length, concatenated."""
    out = []
    for uv, ok in shown:
        edges = np.flatnonzero(np.diff(np.r_[0, ok.astype(np.int8), 0]))
        for a, b in zip(edges[::2], edges[1::2]):
            if b - a >= 2:
                out.append(_thin(uv[a:b]))
    return np.concatenate(out) if out else np.zeros((0, 2))


def curve_pixels(curves: list, labels: np.ndarray, segment: int, label: int) -> np.ndarray:
    """Sub-pixel points of segment ``segment``'s exact image curves where the label image shows it,
    one per pixel of arc length."""
    return _runs_thinned(_shown(curves, labels, {segment: label}).get(segment, []))


def line_pixels(view, *, pixels: str = "curve", noise_px: float = 0.0, rng=None, min_pixels: int = 30,
                max_pixels: int | None = None) -> LinePixels:
    """The pixels of every labelled line of a dataset view (a :class:`catadioptric.DatasetView`):
    ``pixels`` (``"curve"`` or ``"ridge"``, module docstring), lines with at least ``min_pixels``
    kept, at most ``max_pixels`` per line (evenly spaced), then Gaussian noise of ``noise_px``
    pixels per coordinate (``rng``: a numpy Generator)."""
    if pixels not in PIXEL_MODES:
        raise CatadioptricError(f"pixels: expected one of {list(PIXEL_MODES)}, got {pixels!r}")
    if not (isinstance(min_pixels, (int, np.integer)) and min_pixels >= 2):
        raise CatadioptricError(f"min_pixels: expected an integer >= 2, got {min_pixels!r}")
    if noise_px < 0 or not np.isfinite(noise_px):
        raise CatadioptricError(f"noise_px: expected a non-negative number, got {noise_px!r}")
    rng = np.random.default_rng(0) if rng is None else rng
    labels = view["labels"]
    curves = view["curves"] if pixels == "curve" else None
    uvs, fams, segs, labs = [], [], [], []
    counts, short = {}, 0
    if pixels == "curve":
        shown = _shown(curves, labels, {int(ln["index"]): int(ln.get("label", 0) or 0) for ln in view["lines"]
                                        if int(ln.get("label", 0) or 0) > 0})
    for ln in view["lines"]:
        lab = int(ln.get("label", 0) or 0)
        if lab <= 0:
            continue
        if pixels == "curve":
            uv = _runs_thinned(shown.get(int(ln["index"]), []))
        else:
            uv = ridge_pixels(labels, lab)
        if len(uv) == 0:
            continue
        if len(uv) < min_pixels:
            short += 1
            continue
        if max_pixels is not None and len(uv) > max_pixels:
            uv = uv[np.round(np.linspace(0, len(uv) - 1, max_pixels)).astype(int)]
        if noise_px > 0:
            uv = uv + rng.normal(0.0, noise_px, uv.shape)
        f = int(ln["family"])
        uvs.append(uv)
        fams.append(f)
        segs.append(int(ln["index"]))
        labs.append(lab)
        c = counts.setdefault(f, {"lines": 0, "pixels": 0})
        c["lines"] += 1
        c["pixels"] += int(len(uv))
    return LinePixels(uvs, fams, segs, labs, counts, short)
