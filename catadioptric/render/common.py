"""What both renderers share: inputs checks, presets, the sky and sun, the render result,
the label encoding of PNG files, and atomic file writes."""
from __future__ import annotations

import os
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._checks import CatadioptricError
from .._data import data_path
from ..cameras import CatadioptricCamera, PinholeCamera
from ..frames import RigPose
from .tracer import LABEL_MIRROR_AGAIN, LABEL_NO_MIRROR, LABEL_SKY

__all__ = ["RenderError", "RenderResult", "load_quality", "load_resolution", "rescale_camera", "check_view",
           "sky_radiance", "linear_to_srgb8", "encode_labels_png", "decode_labels_png", "atomic_write_bytes",
           "atomic_write_json", "jsonable", "PRESET_DIR", "MAX_LABEL", "MAX_PIXELS", "LABEL_SKY", "LABEL_NO_MIRROR", "LABEL_MIRROR_AGAIN"]

# the packaged presets quality.toml and resolution.toml (catadioptric/data, read with importlib.resources)
PRESET_DIR = data_path()
# labels are stored in 16-bit PNGs; the two top values stand for -1 and -2
MAX_LABEL = 65533
# the largest image a view may have: rendering, tracing and the ground truth of a view took about
# BYTES_PER_PIXEL bytes per pixel at the peak (urban_street, 320x240 -> 1280x960, any quality preset:
# 0.40 -> 0.63 GB), so 4096 x 4096 pixels need about 3.5 GB
MAX_PIXELS = 4096 * 4096
BYTES_PER_PIXEL = 200

_QUALITY_KEYS = {"povray_antialias": float, "povray_aa_depth": int, "mitsuba_spp": int, "max_depth": int,
                 "shadows": bool}


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


# ------------------------------------------------------------------------ presets
def _read_toml(path: Path, what: str) -> dict:
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except FileNotFoundError:
        raise CatadioptricError(f"{what}: no such file {str(path)!r}") from None
    except tomllib.TOMLDecodeError as exc:
        raise CatadioptricError(f"{what}: {str(path)!r} is not valid TOML ({exc})") from None


def load_quality(preset="standard") -> dict:
    """A quality preset: a name in the packaged ``quality.toml`` (``catadioptric/data``), a path to a TOML file with one
    table (or the keys at top level), or a dict. Returns the checked settings plus ``name``."""
    if isinstance(preset, dict):
        table, name = dict(preset), preset.get("name", "custom")
    else:
        s = str(preset)
        if s.endswith(".toml") or os.sep in s:
            data = _read_toml(Path(s), "quality")
            tables = {k: v for k, v in data.items() if isinstance(v, dict)}
            if len(tables) == 1 and not set(data) & set(_QUALITY_KEYS):
                name, table = next(iter(tables.items()))
            else:
                name, table = Path(s).stem, data
        else:
            presets = _read_toml(PRESET_DIR / "quality.toml", "quality")
            if s not in presets:
                raise CatadioptricError(f"quality: expected one of {sorted(presets)} or a .toml file, got {s!r}")
            name, table = s, presets[s]
    table = {k: v for k, v in table.items() if k != "name"}
    unknown = set(table) - set(_QUALITY_KEYS)
    missing = set(_QUALITY_KEYS) - set(table)
    if unknown or missing:
        raise CatadioptricError(f"quality: preset {name!r} has unknown keys {sorted(unknown)} and lacks "
                                f"{sorted(missing)} (expected exactly {sorted(_QUALITY_KEYS)})")
    out = {"name": name}
    for k, typ in _QUALITY_KEYS.items():
        v = table[k]
        if typ is bool:
            ok = isinstance(v, bool)
        elif typ is int:
            ok = isinstance(v, int) and not isinstance(v, bool) and v >= 1
        else:
            ok = isinstance(v, (int, float)) and not isinstance(v, bool) and 0 <= v <= 3
        if not ok:
            want = {bool: "true or false", int: "an integer >= 1", float: "a number in [0, 3]"}[typ]
            raise CatadioptricError(f"quality.{k}: expected {want}, got {v!r} (preset {name!r})")
        out[k] = typ(v)
    return out


def load_resolution(spec) -> tuple[int, int]:
    """``(width, height)`` from a name in the packaged ``resolution.toml`` or ``"WIDTHxHEIGHT"``:
    each side in [8, 16384] pixels and at most :data:`MAX_PIXELS` pixels in all."""
    s = str(spec).strip()
    m = re.fullmatch(r"(\d+)x(\d+)", s)
    if m:
        w, h = int(m.group(1)), int(m.group(2))
    else:
        table = _read_toml(PRESET_DIR / "resolution.toml", "resolution")
        if s not in table:
            raise CatadioptricError(f"resolution: expected one of {sorted(table)} or WIDTHxHEIGHT (two positive "
                                    f"integers, e.g. 640x480), got {s!r}")
        w, h = table[s]["width"], table[s]["height"]
    if not (isinstance(w, int) and isinstance(h, int) and 8 <= w <= 16384 and 8 <= h <= 16384):
        raise CatadioptricError(f"resolution: expected a size between 8 and 16384 pixels, got {w!r}x{h!r}")
    if w * h > MAX_PIXELS:
        raise CatadioptricError(f"resolution: expected at most {MAX_PIXELS} pixels (4096x4096; a view takes about "
                                f"{BYTES_PER_PIXEL} bytes of memory per pixel), got {w}x{h} = {w * h}")
    return w, h


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
