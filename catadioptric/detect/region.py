"""The mirror's image region: the pixels whose ray meets the mirror and leaves it for the world
(``cam.backproject(uv).valid``), eroded so that the rim of the mirror (a strong edge between
the reflection and the black outside) and the pixels next to it are left out."""
from __future__ import annotations

import numpy as np

from .._checks import as_count

__all__ = ["mirror_region"]


def mirror_region(cam, erode_px: int = 3) -> np.ndarray:
    """Boolean ``(H, W)`` mask of the pixels of ``cam`` whose centre sees the world through the
    mirror, eroded by ``erode_px`` pixels (a disc). The rays of every pixel come from
    :func:`catadioptric.render.tracer.pixel_rays` (computed once per rig and kept)."""
    import cv2

    from ..render.tracer import pixel_rays

    erode_px = as_count(erode_px, "erode_px", minimum=0)
    valid = np.asarray(pixel_rays(cam).valid, bool)
    if erode_px == 0:
        return valid.copy()
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * erode_px + 1, 2 * erode_px + 1))
    # pixels beyond the image border count as outside the region
    m = cv2.erode(valid.astype(np.uint8), k, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    return m.astype(bool)
