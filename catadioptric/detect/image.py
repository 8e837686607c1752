"""The beauty image as the detector reads it: grey levels, how noisy they are, and the denoising.

Any of RGB ``uint8``, ``uint16`` (16-bit PNG) or float images (or single-channel ones) become
one grey image in units of the 8-bit scale (0-255), so that every threshold of the detector has
one meaning whatever the file. Colour is reduced to luminance (Rec. 601 weights, OpenCV's): the
scene's line tubes are darker shades of the surfaces they are drawn on.

Noise: Mitsuba's path tracer leaves Monte-Carlo noise that depends on the surface (about 11
grey levels of standard deviation on a lit facade at 16 samples per pixel, none on the sky,
which is an environment map); POV-Ray has none. :func:`noise_level` measures it where it is
(the upper quartile of robust local estimates over the textured part of the region), and
:func:`denoise` applies non-local means (OpenCV ``fastNlMeansDenoising``) with a strength set
from it. Measured costs and their effect on detection: docs/detect.md.
"""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError
from .._numeric import LUMA

__all__ = ["to_channels", "luminance", "to_grey", "noise_level", "denoise", "DENOISE_MODES", "MAX_PIXELS",
           "check_image_size"]

#: The largest image (pixels, width x height) that ``detect``, ``relative-pose`` and ``export
#: --width/--height`` take: 4096 x 4096 (16.8 megapixels), the renderer's own limit. Detection peaks
#: at about 0.1 GB plus 0.36 GB per megapixel (1.55 GB at 2000x2000, of which 1.2 GB is the mirror
#: region's pixel rays), so an image at the limit takes about 6 GB, and the two images of
#: ``relative-pose`` (detected one after the other) about 7 GB: well inside the 24 GB of the
#: machine the project is tested on, with room for another job. docs/detect.md, "Image size".
MAX_PIXELS = 4096 * 4096

DENOISE_MODES = ("auto", "nlmeans", "bilateral", "none")

# Immerkaer's operator: the difference of two Laplacians, blind to planes and to linear shading
_NOISE_KERNEL = np.array([[1.0, -2.0, 1.0], [-2.0, 4.0, -2.0], [1.0, -2.0, 1.0]])


def check_image_size(width, height, what: str = "image") -> None:
    """Raise a :class:`CatadioptricError` (one line, addressed to ``what``: a flag or an argument's
    name) when a ``width`` x ``height`` image has more than :data:`MAX_PIXELS` pixels."""
    w, h = int(width), int(height)
    if w * h > MAX_PIXELS:
        raise CatadioptricError(f"{what}: expected at most {MAX_PIXELS / 1e6:.1f} megapixels ({MAX_PIXELS} pixels, "
                                f"e.g. 4096x4096: the memory limit of docs/detect.md, \"Image size\"), got {w}x{h}")


def to_channels(image) -> np.ndarray:
    """``image`` (``(H, W)``, ``(H, W, 3)`` RGB or ``(H, W, 4)`` RGBA; ``uint8``, ``uint16`` or
    float in [0, 1]) as float64 ``(H, W, C)`` levels on the 8-bit scale (0-255), C = 1 or 3 (alpha
    dropped)."""
    a = np.asarray(image)
    if a.ndim not in (2, 3) or (a.ndim == 3 and a.shape[2] not in (1, 3, 4)) or min(a.shape[:2]) < 8:
        raise CatadioptricError(f"image: expected an (H, W) or (H, W, 3) array of at least 8 x 8 pixels, "
                                f"got an array of shape {a.shape}")
    if a.dtype == np.uint8:
        scale = 1.0
    elif a.dtype == np.uint16:
        scale = 255.0 / 65535.0
    elif a.dtype.kind == "f":
        if not np.all(np.isfinite(a)):
            raise CatadioptricError("image: expected finite values, got NaN or infinity")
        scale = 255.0
    else:
        raise CatadioptricError(f"image: expected uint8, uint16 or float pixels, got dtype {a.dtype}")
    a = a.astype(np.float64) * scale
    if a.ndim == 2:
        return a[..., None]
    return a[..., :1] if a.shape[2] == 1 else a[..., :3]


def luminance(channels: np.ndarray) -> np.ndarray:
    """Grey levels ``(H, W)`` of ``(H, W, C)`` levels: the channel itself, or the luminance of RGB
    (:data:`catadioptric._numeric.LUMA`: Rec. 601 weights, OpenCV's)."""
    if channels.shape[2] == 1:
        return channels[..., 0]
    return LUMA[0] * channels[..., 0] + LUMA[1] * channels[..., 1] + LUMA[2] * channels[..., 2]


def to_grey(image) -> np.ndarray:
    """``image`` (as :func:`to_channels` takes it) as float64 grey levels on the 8-bit scale."""
    return luminance(to_channels(image))


def _local_mad(grey: np.ndarray, block: int = 16) -> np.ndarray:
    """Robust noise estimates (grey levels) in ``block x block`` tiles: the median absolute response
    of Immerkaer's operator, which is 6 sigma for Gaussian noise."""
    import cv2

    r = np.abs(cv2.filter2D(grey, cv2.CV_64F, _NOISE_KERNEL, borderType=cv2.BORDER_REFLECT))
    H, W = r.shape
    h, w = H // block, W // block
    tiles = r[:h * block, :w * block].reshape(h, block, w, block).transpose(0, 2, 1, 3).reshape(h, w, -1)
    return np.median(tiles, axis=-1) / 0.6745 / 6.0


def noise_level(grey: np.ndarray, mask: np.ndarray | None = None, *, block: int = 16) -> float:
    """The noise of ``grey`` (standard deviation in grey levels) where it is noisy: the upper
    quartile of robust per-tile estimates over the tiles wholly inside ``mask`` (the sky, which
    has none, would otherwise set the median)."""
    est = _local_mad(grey, block)
    if mask is not None:
        H, W = grey.shape
        h, w = est.shape
        m = np.asarray(mask, bool)[:h * block, :w * block].reshape(h, block, w, block).all(axis=(1, 3))
        est = est[m]
    est = est[np.isfinite(est)]
    return float(np.percentile(est, 75)) if est.size else 0.0


def denoise(channels: np.ndarray, mode: str = "auto", noise: float | None = None, *, strength: float = 0.6,
            auto_threshold: float = 2.0) -> tuple[np.ndarray, str]:
    """Denoised ``channels`` (``(H, W, C)`` or ``(H, W)`` levels, 8-bit scale) and the mode applied,
    each channel on its own. ``mode``: ``"nlmeans"`` (non-local means, filter strength
    ``h = strength * noise``), ``"bilateral"``, ``"none"``, or ``"auto"`` (non-local means when
    ``noise`` exceeds ``auto_threshold`` grey levels, else nothing)."""
    import cv2

    if mode not in DENOISE_MODES:
        raise CatadioptricError(f"denoise: expected one of {list(DENOISE_MODES)}, got {mode!r}")
    a = np.asarray(channels, dtype=np.float64)
    if noise is None:
        noise = noise_level(a if a.ndim == 2 else luminance(a))
    if mode == "auto":
        mode = "nlmeans" if noise > auto_threshold else "none"
    if mode == "none" or noise <= 0:
        return a, "none"
    flat = a[..., None] if a.ndim == 2 else a
    out = np.empty_like(flat)
    for k in range(flat.shape[2]):
        if mode == "bilateral":
            out[..., k] = cv2.bilateralFilter(flat[..., k].astype(np.float32), 5, float(3.0 * noise), 1.5)
        else:
            # 16-bit non-local means keeps sub-level precision of the 8-bit scale (x 256)
            src = np.clip(np.rint(flat[..., k] * 256.0), 0, 65535).astype(np.uint16)
            out[..., k] = cv2.fastNlMeansDenoising(src, [float(strength * noise * 256.0)], None, 7, 21,
                                                   cv2.NORM_L1) / 256.0
    return (out[..., 0] if a.ndim == 2 else out), mode
