"""The pixels the detector looks at.

* An exact rig (:class:`~catadioptric.CatadioptricCamera`): the pixels whose ray meets the
  mirror and leaves it for the world (``cam.backproject(uv).valid``), eroded so that the rim of
  the mirror (a strong edge between the reflection and the black outside) and the pixels next to
  it are left out.
* A calibration of another tool (:mod:`catadioptric.models`): its formula holds over the whole
  image and knows nothing of the mirror's rim, so the region is the model's own
  (:meth:`~catadioptric.models.CentralCamera.region`: pixels whose ray projects back onto them,
  inside the calibration's ROI when it gives one) and the annulus the photograph shows
  (:func:`scene_annulus`): the bright disc of the mirror inside the dark ring around it, without
  the dark disc at its centre (the camera's own reflection), each boundary moved inwards by a
  margin (:data:`ANNULUS_MARGIN_PX`).
* A user's mask (non-zero: use the pixel) is applied on top of either.
"""
from __future__ import annotations

import json
from typing import NamedTuple

import numpy as np

from .._checks import CatadioptricError, as_count

__all__ = ["mirror_region", "scene_annulus", "Annulus", "check_mask", "ANNULUS_MARGIN_PX"]

#: the annulus of a photograph is narrowed by this many pixels at both edges (the rim's blur and
#: the gradients' reach)
ANNULUS_MARGIN_PX = 8.0

_REGIONS: dict = {}
#: rows of pixels back-projected at once for an exact rig's region (bounded memory: the rays of a
#: block are dropped once their ``valid`` is kept)
REGION_BLOCK_PIXELS = 1 << 18


def _rig_region(cam) -> np.ndarray:
    """``cam.backproject(pixel centre).valid`` for every pixel of an exact rig, a block of rows at a
    time (each pixel's ray does not depend on the batch it is in: the same mask as at once)."""
    W, H = cam.pinhole.width, cam.pinhole.height
    grid = cam.pinhole.pixel_grid()
    rows = max(1, REGION_BLOCK_PIXELS // W)
    out = np.zeros((H, W), bool)
    for r0 in range(0, H, rows):
        out[r0:r0 + rows] = np.asarray(cam.backproject(grid[r0:r0 + rows]).valid, bool)
    return out


def mirror_region(cam, erode_px: int = 3) -> np.ndarray:
    """Boolean ``(H, W)`` mask of the pixels of ``cam`` whose centre sees the world, eroded by
    ``erode_px`` pixels (a disc). Exact rigs: through the mirror (``cam.backproject(uv).valid``,
    a block of rows at a time); camera models: :meth:`~catadioptric.models.CentralCamera.region`.
    The masks of the last two cameras are kept."""
    import cv2

    from ..models.base import CentralCamera

    erode_px = as_count(erode_px, "erode_px", minimum=0)
    key = (type(cam).__name__, json.dumps(cam.to_dict(), sort_keys=True))
    valid = _REGIONS.get(key)
    if valid is None:
        valid = cam.region() if isinstance(cam, CentralCamera) else _rig_region(cam)
        valid.setflags(write=False)
        if len(_REGIONS) >= 2:
            _REGIONS.pop(next(iter(_REGIONS)))
        _REGIONS[key] = valid
    if erode_px == 0:
        return valid.copy()
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * erode_px + 1, 2 * erode_px + 1))
    # pixels beyond the image border count as outside the region
    m = cv2.erode(valid.astype(np.uint8), k, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    return m.astype(bool)


class Annulus(NamedTuple):
    """The centre ``(u0, v0)`` and radii ``r_in``, ``r_out`` (pixels) of the mirror's bright annulus."""

    u0: float
    v0: float
    r_in: float
    r_out: float

    def mask(self, shape, margin: float = 0.0) -> np.ndarray:
        H, W = shape
        v, u = np.ogrid[:H, :W]
        r = np.hypot(u - self[0], v - self[1])
        return (r >= self[2] + margin) & (r <= self[3] - margin)


def scene_annulus(grey: np.ndarray, region: np.ndarray, centre, *, bins: int = 720) -> Annulus | None:
    """The mirror's bright annulus in a catadioptric photograph (``grey (H, W)``) around
    ``centre`` (the pixel of the mirror's axis, :meth:`~catadioptric.models.CentralCamera.axis_pixel`),
    within ``region``: along ``bins`` directions from the centre, the median grey level at each
    radius (robust to the dark objects a few directions meet) is bright on the mirror and dark on
    the camera's own reflection at the centre and on the ring around the mirror; with the dark
    level (5th percentile of that profile) and the bright one (75th), the threshold is a quarter
    of the way up, ``r_in`` the first radius above it and ``r_out`` the last one before the profile
    stays below it for 5 % of the image's size. None when the profile shows no such disc (e.g. an
    image without a dark ring)."""
    g = np.asarray(grey, np.float64)
    H, W = g.shape
    u0, v0 = (float(c) for c in centre)
    if not (np.isfinite(u0) and np.isfinite(v0)):
        return None
    r_max = int(np.ceil(np.hypot(max(u0, W - 1 - u0), max(v0, H - 1 - v0))))
    rr = np.arange(r_max, dtype=float)
    th = np.linspace(0, 2 * np.pi, bins, endpoint=False)
    prof = np.empty(r_max)
    for r0 in range(0, r_max, 256):  # bounded memory
        U = u0 + np.cos(th)[:, None] * rr[None, r0:r0 + 256]
        V = v0 + np.sin(th)[:, None] * rr[None, r0:r0 + 256]
        ui, vi = np.rint(U).astype(int), np.rint(V).astype(int)
        ok = (ui >= 0) & (ui < W) & (vi >= 0) & (vi < H)
        ok[ok] &= region[vi[ok], ui[ok]]
        vals = np.full(U.shape, np.nan)
        vals[ok] = g[vi[ok], ui[ok]]
        with np.errstate(all="ignore"), __import__("warnings").catch_warnings():
            __import__("warnings").simplefilter("ignore", RuntimeWarning)
            prof[r0:r0 + 256] = np.nanmedian(vals, axis=0)
    have = np.isfinite(prof)
    if have.sum() < 20:
        return None
    dark, bright = np.percentile(prof[have], [5, 75])
    if not bright > dark + 10.0 / 255.0 * max(1.0, float(np.nanmax(g))):
        return None
    thr = dark + 0.25 * (bright - dark)
    above = have & (prof > thr)
    idx = np.flatnonzero(above)
    if len(idx) == 0:
        return None
    r_in = int(idx[0])
    gap = max(5, int(0.05 * min(H, W)))
    r_out = float("inf")
    run = 0
    for r in range(r_in, r_max):
        if not have[r]:
            break  # beyond the image (or the region): no outer edge seen
        run = 0 if above[r] else run + 1
        if run >= gap:
            r_out = float(r - run)
            break
    if r_in == 0 and not np.isfinite(r_out):
        return None
    return Annulus(float(u0), float(v0), float(r_in), float(r_out))


def check_mask(mask, shape, name: str = "mask") -> np.ndarray:
    """A user's mask (non-zero: use the pixel) as a boolean ``(H, W)`` array of the image's size."""
    m = np.asarray(mask)
    if m.ndim == 3:
        m = m.max(axis=2)
    if m.ndim != 2:
        raise CatadioptricError(f"{name}: expected a 2-D mask, got an array of shape {m.shape}")
    if m.shape != tuple(shape):
        raise CatadioptricError(f"{name}: expected {shape[1]}x{shape[0]} pixels (the image's size), got "
                                f"{m.shape[1]}x{m.shape[0]}")
    return m != 0
