"""The packaged render presets: image quality (``quality.toml``) and image size
(``resolution.toml``), both in ``catadioptric/data``; what the renderers, the dataset writer and
the command line's ``--quality`` and ``--resolution`` read. :mod:`catadioptric.render.common`
re-exports them."""
from __future__ import annotations

import os
import re
import tomllib
from pathlib import Path

from ._checks import CatadioptricError
from ._data import data_path

__all__ = ["load_quality", "load_resolution", "PRESET_DIR", "MAX_PIXELS", "BYTES_PER_PIXEL"]

# the packaged presets quality.toml and resolution.toml (catadioptric/data, read with importlib.resources)
PRESET_DIR = data_path()
# the largest image a view may have: rendering, tracing and the ground truth of a view took about
# BYTES_PER_PIXEL bytes per pixel at the peak (urban_street, 320x240 -> 1280x960, any quality preset:
# 0.40 -> 0.63 GB), so 4096 x 4096 pixels need about 3.5 GB
MAX_PIXELS = 4096 * 4096
BYTES_PER_PIXEL = 200

_QUALITY_KEYS = {"povray_antialias": float, "povray_aa_depth": int, "mitsuba_spp": int, "max_depth": int,
                 "shadows": bool}


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
