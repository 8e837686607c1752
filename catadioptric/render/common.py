"""What both renderers share: inputs checks, presets, the sky and sun, the render result,
the label encoding of PNG files, and atomic file writes."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._checks import CatadioptricError
from ..cameras import CatadioptricCamera, PinholeCamera
from ..frames import RigPose
# the presets have their own module (below cliargs, which reads --resolution); re-exported here
from ..render_presets import BYTES_PER_PIXEL, MAX_PIXELS, PRESET_DIR, load_quality, load_resolution  # noqa: F401
from .tracer import LABEL_MIRROR_AGAIN, LABEL_NO_MIRROR, LABEL_SKY

__all__ = ["RenderError", "RenderResult", "load_quality", "load_resolution", "rescale_camera", "check_view",
           "sky_radiance", "linear_to_srgb8", "encode_labels_png", "decode_labels_png", "atomic_write_bytes",
           "atomic_write_json", "jsonable", "PRESET_DIR", "MAX_LABEL", "MAX_PIXELS", "LABEL_SKY", "LABEL_NO_MIRROR", "LABEL_MIRROR_AGAIN"]

# labels are stored in 16-bit PNGs; the two top values stand for -1 and -2
MAX_LABEL = 65533


class RenderError(CatadioptricError):
    """A renderer is missing or failed; the message says which and shows the relevant log lines."""


@dataclass
class RenderResult:
    """One rendered view: ``beauty (H, W, 3)`` RGB uint8, ``labels (H, W)`` int32, and facts about the run;
    ``linear``: the beauty in linear RGB floats before 8-bit quantisation (Mitsuba), else None."""

    beauty: np.ndarray
    labels: np.ndarray
    info: dict = field(default_factory=dict)
    linear: np.ndarray | None = None


def rescale_camera(cam: CatadioptricCamera, width: int, height: int) -> CatadioptricCamera:
    """The same rig with an image of ``width`` x ``height``: pixels are rescaled about the outer corner
    (-0.5, -0.5) so that the image covers the same rays (``u' + 0.5 = s (u + 0.5)``)."""
    p = cam.pinhole
    if (width, height) == (p.width, p.height):
        return cam
    sx, sy = width / p.width, height / p.height
    K = p.K.copy()
    K[0, 0] *= sx
    K[0, 1] *= sx
    K[0, 2] = sx * (K[0, 2] + 0.5) - 0.5
    K[1, 1] *= sy
    K[1, 2] = sy * (K[1, 2] + 0.5) - 0.5
    return CatadioptricCamera(cam.mirror, PinholeCamera(K, width, height), cam.center, cam.R_cam_from_mirror)


def check_view(scene, cam, pose) -> None:
    """Type and range checks shared by the renderers (errors name the bad value)."""
    from ..scenes.scene import Scene

    if not isinstance(scene, Scene):
        raise CatadioptricError(f"scene: expected a catadioptric.scenes.Scene, got {type(scene).__name__}")
    if not isinstance(cam, CatadioptricCamera):
        raise CatadioptricError(f"cam: expected a CatadioptricCamera, got {type(cam).__name__}")
    if not isinstance(pose, RigPose):
        raise CatadioptricError(f"pose: expected a RigPose (x_M = R x_W + t), got {type(pose).__name__}")
    for i, obj in enumerate(scene.objects):
        lab = int(obj.label)
        if not 1 <= lab <= MAX_LABEL:
            raise CatadioptricError(f"scene.objects[{i}].label: expected an integer in [1, {MAX_LABEL}] "
                                    f"(0 is the sky), got {obj.label!r} (object {obj.name!r})")
        c = np.asarray(obj.color, dtype=float)
        if c.shape != (3,) or not np.all((c >= 0) & (c <= 1)):
            raise CatadioptricError(f"scene.objects[{i}].color: expected RGB in [0, 1], got {obj.color!r} "
                                    f"(object {obj.name!r})")
    sun = np.asarray(scene.sun, dtype=float)
    if sun.shape != (3,) or not np.isfinite(sun).all() or np.linalg.norm(sun) == 0:
        raise CatadioptricError(f"scene.sun: expected a non-zero direction (3,), got {scene.sun!r}")


# ------------------------------------------------------------------ sky and sun
# a clear sky in linear RGB: horizon -> zenith, brightness in the renderers' units
SKY_HORIZON = np.array([0.78, 0.85, 0.95])
SKY_ZENITH = np.array([0.22, 0.42, 0.85])
SKY_GROUND = np.array([0.30, 0.29, 0.27])   # below the horizon (seen only where there is no ground mesh)
SUN_IRRADIANCE = 2.6                        # Mitsuba directional emitter; POV-Ray light colour 1
AMBIENT = 0.30                              # POV-Ray ambient term (stands for the sky light)


def sky_radiance(elevation_sin) -> np.ndarray:
    """Linear RGB of the sky toward directions whose sine of elevation is ``elevation_sin`` (...,)."""
    e = np.asarray(elevation_sin, dtype=float)[..., None]
    up = np.clip(e, 0.0, 1.0)
    sky = SKY_HORIZON + (SKY_ZENITH - SKY_HORIZON) * np.sqrt(up)
    return np.where(e >= 0, sky, SKY_GROUND)


def linear_to_srgb8(rgb) -> np.ndarray:
    """Linear RGB floats -> sRGB uint8 (deterministic rounding)."""
    x = np.clip(np.nan_to_num(np.asarray(rgb, dtype=np.float64), nan=0.0), 0.0, 1.0)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return np.floor(s * 255.0 + 0.5).astype(np.uint8)


# --------------------------------------------------------------- label encoding
def encode_labels_png(labels: np.ndarray) -> np.ndarray:
    """int32 labels -> uint16 image: labels 0..65533 as they are, -2 -> 65534, -1 -> 65535."""
    lab = np.asarray(labels)
    if lab.size and (lab.min() < LABEL_MIRROR_AGAIN or lab.max() > MAX_LABEL):
        raise CatadioptricError(f"labels: expected values in [-2, {MAX_LABEL}], got [{lab.min()}, {lab.max()}]")
    return lab.astype(np.int64).astype(np.uint16)  # two's complement wrap: -1 -> 65535, -2 -> 65534


def decode_labels_png(img: np.ndarray) -> np.ndarray:
    """uint16 image -> int32 labels (inverse of :func:`encode_labels_png`)."""
    a = np.asarray(img)
    if a.dtype != np.uint16 or a.ndim != 2:
        raise CatadioptricError(f"labels image: expected a single-channel 16-bit image, got {a.dtype} {a.shape}")
    out = a.astype(np.int32)
    out[out > MAX_LABEL] -= 65536
    return out


# ------------------------------------------------------------------ file writes
# atomic writes (temporary file + os.replace) live in catadioptric._io, shared with reports and benchmarks
from .._io import atomic_write_bytes, atomic_write_json, jsonable  # noqa: E402,F401
