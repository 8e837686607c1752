"""The relative-pose benchmark spec (``validate/relative_pose.toml``; format in docs/formats.md,
"Benchmark specs") and the seeded view pairs it describes.

Pairs are pure functions of (spec, configuration, pair index): the random stream of pair ``k``
of configuration ``c`` is ``default_rng([seed, c, k])``, so adding a configuration or a pair
leaves the others unchanged.
"""
from __future__ import annotations

import os
import tomllib
from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError
from ..frames import RigPose
from ..spectable import SpecTable

__all__ = ["read_benchmark_spec", "load_benchmark_spec", "quick_spec", "quality_of", "quality_text", "Pair",
           "pairs_of", "select_pairs", "with_quality", "RENDERERS", "PIXEL_MODES"]

RENDERERS = ("mitsuba", "povray")
PIXEL_MODES = ("curve", "ridge")


def _interval(t: SpecTable, key: str, default, *, positive=False):
    v = t.numbers(key, default, length=2, what="two increasing numbers" + (" > 0" if positive else ""))
    if v[0] > v[1] or (positive and v[0] <= 0):
        raise t.error(key, f"expected two increasing numbers{' > 0' if positive else ''}, got {v}")
    return v


def _preset(t: SpecTable, key: str) -> None:
    """A quality preset (a name of catadioptric/data/quality.toml or a .toml file), checked now
    rather than when the first view renders."""
    from ..render.common import load_quality

    v = t.string(key, "standard")
    try:
        load_quality(v)
    except CatadioptricError as exc:
        raise t.error(key, str(exc).removeprefix("quality: ")) from None


def read_benchmark_spec(data, path: str = "benchmark") -> dict:
    """Check a parsed benchmark spec; return it normalised (every default present)."""
    t = SpecTable(data, path)
    t.string("name", "relative_pose")
    t.string("scene")
    t.string("resolution", "640x480")
    if isinstance(t.raw("quality"), dict):
        # one preset per renderer (Mitsuba's default is noisy: the image path wants "high" there)
        qt = t.table("quality")
        for r in RENDERERS:
            _preset(qt, r)
    else:
        _preset(t, "quality")
    t.integer("seed", 0, min=0)
    t.integer("pairs", min=1, max=1000)
    t.strings("renderers", list(RENDERERS), choices=RENDERERS)
    t.numbers("noise_px", [0.0, 0.5, 1.0, 2.0, 3.0], nonnegative=True)
    t.integer("draws", 3, min=1, max=1000)
    t.string("pixels", "curve", choices=PIXEL_MODES)
    t.integer("min_pixels", 30, min=5)
    t.integer("max_pixels", 60, min=5)
    p = t.table("placement")
    _interval(p, "x_range", [-50.0, 50.0])
    _interval(p, "y_range", [-6.5, 6.5])
    _interval(p, "height_range", [1.6, 2.6], positive=True)
    _interval(p, "baseline_range", [2.0, 8.0], positive=True)
    p.number("heading_spread_deg", 35.0, min=0.0, max=180.0)
    p.number("turn_deg", 30.0, min=0.0, max=180.0)
    p.number("tilt_deg", 3.0, min=0.0, max=45.0)
    names = []
    for c in t.tables("configs", min_count=1):
        names.append(c.string("name"))
        c.string("rig")
        c.number("roll_deg", 0.0, min=-360.0, max=360.0)
    if len(set(names)) != len(names):
        raise t.error("configs", f"expected distinct names, got {names}")
    im = t.table("images")
    im.numbers("max_rotation_deg", [60.0], positive=True)
    q = t.table("quick")
    q.strings("configs", names[:1], choices=names)
    q.integer("pairs", 1, min=1)
    q.string("resolution", "320x240")
    q.string("quality", "draft")
    q.numbers("noise_px", [1.0], nonnegative=True)
    q.integer("draws", 1, min=1)
    spec = t.done()
    if spec["min_pixels"] > spec["max_pixels"]:
        raise CatadioptricError(f"{path}.min_pixels: expected at most max_pixels ({spec['max_pixels']}), got "
                                f"{spec['min_pixels']}")
    return spec


def load_benchmark_spec(path) -> dict:
    """Read and check a benchmark spec file (TOML)."""
    path = os.fspath(path)
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except FileNotFoundError:
        raise CatadioptricError(f"spec: no file {path!r}") from None
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise CatadioptricError(f"spec: {path!r} is not a readable TOML file ({exc})") from None
    spec = read_benchmark_spec(data, "benchmark")
    spec["source"] = os.path.abspath(path)
    return spec


def quality_of(spec: dict, renderer: str) -> str:
    """The quality preset the spec renders ``renderer``'s views at: ``quality`` is one preset for
    every renderer or a table of one per renderer."""
    q = spec["quality"]
    return q[renderer] if isinstance(q, dict) else q


def quality_text(spec: dict) -> str:
    """The spec's quality for a report: ``standard``, or ``mitsuba high, povray standard``."""
    q = spec["quality"]
    if not isinstance(q, dict):
        return f"`{q}`"
    return ", ".join(f"{r} `{q[r]}`" for r in spec["renderers"])


def quick_spec(spec: dict) -> dict:
    """The CI size of a benchmark: the ``[quick]`` table's configurations, pairs, resolution,
    quality, noise levels and draws."""
    q = spec["quick"]
    out = dict(spec)
    out["configs"] = [c for c in spec["configs"] if c["name"] in q["configs"]]
    for k in ("pairs", "resolution", "quality", "noise_px", "draws"):
        out[k] = q[k]
    out["name"] = spec["name"] + "_quick"
    return out


def with_quality(spec: dict, values, flag: str = "--quality") -> dict:
    """The spec with its quality presets replaced: each of ``values`` is a preset for every
    renderer (``standard``) or for one (``mitsuba=standard``). Only the image path reads the
    beauty images, so only its results are keyed by the quality (a copy of the benchmark's views
    at another preset, in a data folder of its own, compares the two)."""
    from ..render.common import load_quality

    q = dict(spec["quality"]) if isinstance(spec["quality"], dict) else {r: spec["quality"] for r in RENDERERS}
    for v in values:
        renderer, _, preset = v.rpartition("=")
        if renderer and renderer not in RENDERERS:
            raise CatadioptricError(f"{flag}: expected PRESET or RENDERER=PRESET with RENDERER one of "
                                    f"{list(RENDERERS)}, got {v!r}")
        try:
            load_quality(preset)
        except CatadioptricError as exc:
            raise CatadioptricError(f"{flag}: {str(exc).removeprefix('quality: ')}") from None
        for r in ([renderer] if renderer else RENDERERS):
            q[r] = preset
    if not isinstance(spec["quality"], dict) and len(set(q.values())) == 1:
        return spec | {"quality": q[RENDERERS[0]]}  # one preset stays one (the results keep their key)
    return spec | {"quality": q}


def select_pairs(spec: dict, text: str, flag: str = "--only") -> list[tuple[str, int]]:
    """The pairs named by ``text``, comma-separated: ``CONFIG:PAIR`` (one pair), ``CONFIG`` (its
    pairs) or a renderer (the pairs it renders), in the spec's order. Unknown names are an error
    naming the spec's."""
    names = [c["name"] for c in spec["configs"]]
    every = [(c["name"], p.index, p.renderer) for c in spec["configs"] for p in pairs_of(spec, c)]
    chosen = set()
    for item in (x.strip() for x in text.split(",")):
        config, sep, index = item.partition(":")
        if sep:
            try:
                k = int(index)
            except ValueError:
                k = -1
            if config not in names or not 0 <= k < spec["pairs"]:
                raise CatadioptricError(f"{flag}: expected CONFIG:PAIR with CONFIG one of {names} and PAIR below "
                                        f"{spec['pairs']}, got {item!r}")
            chosen.add((config, k))
        elif item in names:
            chosen |= {(c, k) for c, k, _ in every if c == item}
        elif item in spec["renderers"]:
            chosen |= {(c, k) for c, k, r in every if r == item}
        else:
            raise CatadioptricError(f"{flag}: expected CONFIG:PAIR, a configuration ({', '.join(names)}) or a "
                                    f"renderer ({', '.join(spec['renderers'])}), got {item!r}")
    return [(c, k) for c, k, _ in every if (c, k) in chosen]


@dataclass(frozen=True)
class Pair:
    """One view pair of a configuration: ``index``, ``renderer``, the view names and poses."""

    config: str
    index: int
    renderer: str
    names: tuple
    poses: tuple


def _pose(position, yaw, pitch, roll) -> RigPose:
    from ..scenes.spec import view_rotation

    return RigPose.from_mirror_in_world(view_rotation(yaw, pitch, roll), np.asarray(position, dtype=float))


def pairs_of(spec: dict, config: dict) -> list[Pair]:
    """The seeded view pairs of one configuration (``spec["pairs"]`` of them); pair ``k`` is
    rendered by ``renderers[k % len(renderers)]``."""
    ci = [c["name"] for c in spec["configs"]].index(config["name"]) if config in spec["configs"] else 0
    pl = spec["placement"]
    out = []
    for k in range(spec["pairs"]):
        rng = np.random.default_rng([spec["seed"], ci, k])
        a = np.array([rng.uniform(*pl["x_range"]), rng.uniform(*pl["y_range"]), rng.uniform(*pl["height_range"])])
        for _ in range(100):  # B stays over the road or the sidewalks
            base = rng.uniform(*pl["baseline_range"])
            heading = np.radians(rng.uniform(-pl["heading_spread_deg"], pl["heading_spread_deg"])
                                 + (180.0 if rng.random() < 0.5 else 0.0))
            b = a + [base * np.cos(heading), base * np.sin(heading), 0.0]
            b[2] = rng.uniform(*pl["height_range"])
            if pl["y_range"][0] <= b[1] <= pl["y_range"][1] and pl["x_range"][0] - 10 <= b[0] <= pl["x_range"][1] + 10:
                break
        yaw_a = rng.uniform(0.0, 360.0)
        yaw_b = yaw_a + rng.uniform(-pl["turn_deg"], pl["turn_deg"])
        tilts = rng.uniform(-pl["tilt_deg"], pl["tilt_deg"], 4)
        roll = config["roll_deg"]
        poses = (_pose(a, yaw_a, tilts[0], roll + tilts[1]), _pose(b, yaw_b, tilts[2], roll + tilts[3]))
        renderer = spec["renderers"][k % len(spec["renderers"])]
        out.append(Pair(config["name"], k, renderer, (f"p{k:02d}A", f"p{k:02d}B"), poses))
    return out
