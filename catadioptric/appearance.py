"""What a line looks like: the colours either side of its curve (:class:`LineAppearance`), and
whether two lines of two views can be one line under a candidate rotation (:func:`contrasts_agree`).

A line's two sides are named by its plane: the side where ``m . d > 0`` for the rays ``d`` of the
pixels beside the curve, with ``m`` a normal of the plane that holds the line's rays. The detector
measures each side once, against the normal it fitted (``normal``); the estimator asks for the
sides against its own, oriented normal (its sign set by the family's direction and the side the
line is seen on), and a candidate rotation says which side of a line of B is which side of a line
of A (:mod:`catadioptric.pose.matching`). A wall left of a building's edge and the sky right of it
stay so in any view that sees the edge from the same side: a candidate that puts a bright-left line
onto a dark-left one is not that line.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._numeric import LUMA

__all__ = ["LineAppearance", "contrasts_agree"]


@dataclass
class LineAppearance:
    """Per line ``i``: ``sides[i] (2, C)`` the median colour (grey levels of an 8-bit scale, ``C``
    channels) on the side of its curve where ``normal[i] . d > 0`` (``[0]``) and where it is
    negative (``[1]``); ``offset_px[i]`` how far from the curve they were sampled; ``noise``: the
    image's noise (grey levels), the scale of a contrast that means nothing."""

    normal: np.ndarray
    sides: np.ndarray
    offset_px: np.ndarray
    noise: float

    def __len__(self) -> int:
        return len(self.normal)

    def take(self, idx) -> "LineAppearance":
        idx = np.asarray(idx, dtype=np.int64)
        return LineAppearance(self.normal[idx], self.sides[idx], self.offset_px[idx], self.noise)

    def oriented(self, idx, m) -> np.ndarray:
        """``(K, 2, C)``: the colours of lines ``idx`` on the side ``m . d > 0`` (``[:, 0]``) and the
        other (``[:, 1]``), for normals ``m (K, 3)`` of their planes (any sign)."""
        idx = np.asarray(idx, dtype=np.int64)
        s = self.sides[idx]
        flip = np.sum(np.asarray(m, float) * self.normal[idx], axis=-1) < 0
        return np.where(flip[:, None, None], s[:, ::-1], s)

    def contrast(self, idx, m) -> np.ndarray:
        """The luminance (:data:`catadioptric._numeric.LUMA` for three channels, else their mean) on the side ``m . d > 0``
        of lines ``idx`` minus the other side's, for normals ``m (K, 3)`` of their planes (any sign:
        the side follows ``m``'s)."""
        s = self.oriented(idx, m)
        lum = s @ LUMA if s.shape[-1] == 3 else s.mean(axis=-1)
        return lum[:, 0] - lum[:, 1]

    def to_dict(self, i: int) -> dict:
        return {"positive": self.sides[i, 0].tolist(), "negative": self.sides[i, 1].tolist(),
                "offset_px": float(self.offset_px[i])}


def contrasts_agree(c_a, c_b, min_contrast: float) -> np.ndarray:
    """Whether oriented contrasts ``c_a`` and ``c_b`` (:meth:`LineAppearance.contrast`, the same side
    of one line in two views) can be one line's: False only where both exceed ``min_contrast`` in
    size and their signs differ (a line without contrast, or NaN, agrees with anything)."""
    c_a, c_b = np.asarray(c_a, float), np.asarray(c_b, float)
    strong = (np.abs(c_a) > min_contrast) & (np.abs(c_b) > min_contrast)
    return ~(strong & (np.sign(c_a) != np.sign(c_b)))
