"""``detect_lines``: one image of a rig -> its line curves and families (the stages in order:
image, region, edges, band centres, chains, line curves, families)."""
from __future__ import annotations

import time

import numpy as np

from .._checks import CatadioptricError, as_count, as_scalar
from .centres import Centres, pair_edges, step_edges
from .chains import join_chains, link_chains
from .curves import line_covariance, merge_pieces, order_along, split_chain
from .appearance import side_colours
from .edges import subpixel_edges
from .families import GroupingOptions, LinePlanes, group_families
from .grow import grow_lines
from .image import DENOISE_MODES, check_image_size, denoise, luminance, noise_level, to_channels
from ..linefit.planes import pixel_rays_with_jacobian
from .region import ANNULUS_MARGIN_PX, check_mask, mirror_region, scene_annulus
from .result import DetectedLines

__all__ = ["detect_lines", "check_options", "preset_options", "DEFAULTS", "PRESETS"]

#: The options of :func:`detect_lines` and their defaults (docs/detect.md says what each does).
DEFAULTS = {
    "colour": True,             # edges on the RGB channels (the strongest per pixel), else on luminance
    "denoise": "auto",          # "auto" | "nlmeans" | "bilateral" | "none"
    "denoise_strength": 0.6,    # non-local means h = strength x the measured noise
    "erode_px": 3,              # the mirror region eroded by this many pixels
    "sigma": 1.0,               # Gaussian of the gradients (pixels)
    "low": None,                # Canny hysteresis thresholds (grey levels per pixel); None: from the noise
    "high": None,
    "max_width": 6.0,           # widest band whose two edges are paired (pixels)
    "step_edges": True,         # keep edges without a partner (a tube against a background of its shade)
    "threshold": 1.0,           # pixel distance of a line's pixels to its curve
    "min_points": 12,           # shortest piece of a chain kept as a line (points, about pixels)
    "min_pixels": 20,           # shortest line kept after merging
    "merge_angle_deg": 10.0,    # pieces whose planes are this close are tried for merging
    "grow_gap_px": 0.0,         # lines grown along their curves over every point, across gaps this long (0: off)
    "sigma_floor": 0.3,         # pixel noise assumed at least, for the lines' covariances
    "systematic_px": 0.15,      # systematic pixel error along a line, for the lines' covariances
    "chi2_max": 9.0,            # families: a line agrees with a direction within this chi-square
    "angle_floor_deg": 0.1,     # families: angular error added to each line's covariance
    "min_family_lines": 3,      # families: fewest lines of a family
    "family_search_pixels": 20, # families: lines at least this long find families, shorter ones only join
    "max_log_nfa": -4.0,        # families: significance a family must reach (log of its number of false alarms)
    "concurrency_px": 5.0,      # families: reject a direction whose lines mostly end this close to its image
}


#: Named sets of options for a kind of scene (docs/detect.md, "Presets"). ``chessboard``: every edge
#: of a chessboard is a step edge that changes polarity at each corner, and a board far or out of
#: focus is already blurred: no band of two edges to pair (``max_width`` 2), less smoothing of the
#: gradients (``sigma`` 0.7), and pieces joined across the corners a little off one curve
#: (``threshold`` 1.5). Measured on ../shared/real (docs/cameras.md).
PRESETS = {
    "chessboard": {"threshold": 1.5, "sigma": 0.7, "max_width": 2.0},
}


def preset_options(name: str | None, options: dict | None = None) -> dict:
    """The options of preset ``name`` (:data:`PRESETS`; None: none), overridden by ``options``."""
    if name is not None and name not in PRESETS:
        raise CatadioptricError(f"preset: expected one of {sorted(PRESETS)}, got {name!r}")
    return {**(PRESETS[name] if name is not None else {}), **(options or {})}


def check_options(options: dict) -> dict:
    """The options of :func:`detect_lines` completed with :data:`DEFAULTS` and checked (a
    :class:`CatadioptricError` names a bad one)."""
    bad = sorted(set(options) - set(DEFAULTS))
    if bad:
        raise CatadioptricError(f"options: expected some of {sorted(DEFAULTS)}, got unknown {bad}")
    o = {**DEFAULTS, **options}
    if o["denoise"] not in DENOISE_MODES:
        raise CatadioptricError(f"denoise: expected one of {list(DENOISE_MODES)}, got {o['denoise']!r}")
    for k in ("denoise_strength", "sigma", "max_width", "threshold", "merge_angle_deg", "sigma_floor", "chi2_max"):
        o[k] = as_scalar(o[k], k, positive=True)
    for k in ("angle_floor_deg", "systematic_px", "concurrency_px", "grow_gap_px"):
        o[k] = as_scalar(o[k], k)
        if o[k] < 0:
            raise CatadioptricError(f"{k}: expected a number >= 0, got {o[k]!r}")
    for k in ("low", "high"):
        if o[k] is not None:
            o[k] = as_scalar(o[k], k, positive=True)
    o["erode_px"] = as_count(o["erode_px"], "erode_px", minimum=0)
    o["min_points"] = as_count(o["min_points"], "min_points", minimum=4)
    o["min_pixels"] = as_count(o["min_pixels"], "min_pixels", minimum=4)
    o["min_family_lines"] = as_count(o["min_family_lines"], "min_family_lines", minimum=2)
    o["family_search_pixels"] = as_count(o["family_search_pixels"], "family_search_pixels", minimum=0)
    o["max_log_nfa"] = as_scalar(o["max_log_nfa"], "max_log_nfa")
    for k in ("step_edges", "colour"):
        if not isinstance(o[k], (bool, np.bool_)):
            raise CatadioptricError(f"{k}: expected True or False, got {o[k]!r}")
    return o


def detect_lines(image, cam, *, mask=None, **options) -> DetectedLines:
    """The line curves and families of one beauty ``image`` (RGB ``uint8``, ``uint16`` or float
    in [0, 1], or grey) of the camera ``cam``: an exact rig (a
    :class:`~catadioptric.CatadioptricCamera` whose pinhole has the image's size) or a calibration
    of another tool (a camera model of :mod:`catadioptric.models`, e.g. from
    :func:`catadioptric.formats.load_camera`). ``mask`` (optional, the image's size): non-zero
    where the pixel may be used (what moves or does not belong to the scene is zero). Options:
    :data:`DEFAULTS`; the method, and the region looked at: docs/detect.md."""
    from ..cameras import CatadioptricCamera
    from ..models.base import CentralCamera, image_size

    if not isinstance(cam, (CatadioptricCamera, CentralCamera)):
        raise CatadioptricError(f"cam: expected a CatadioptricCamera or a camera model of catadioptric.models, got "
                                f"{type(cam).__name__}")
    o = check_options(options)
    seconds = {}
    t = time.perf_counter()

    def lap(name):
        nonlocal t
        now = time.perf_counter()
        seconds[name] = now - t
        t = now

    chan = to_channels(image)
    if not o["colour"]:
        chan = luminance(chan)[..., None]
    W, H = image_size(cam)
    check_image_size(chan.shape[1], chan.shape[0], "image")
    if chan.shape[:2] != (H, W):
        raise CatadioptricError(f"image: expected {W}x{H} pixels (the camera's image size), got "
                                f"{chan.shape[1]}x{chan.shape[0]}")
    user = None if mask is None else check_mask(mask, (H, W))
    mask = mirror_region(cam, o["erode_px"])
    annulus = None
    if isinstance(cam, CentralCamera):  # a calibration knows no mirror rim: the photograph shows it
        annulus = scene_annulus(luminance(chan), mask, cam.axis_pixel())
        if annulus is not None:
            mask &= annulus.mask((H, W), ANNULUS_MARGIN_PX)
    if user is not None:
        mask &= user
    lap("region")
    noise_in = noise_level(luminance(chan), mask)
    chan, mode = denoise(chan, o["denoise"], noise_in, strength=o["denoise_strength"])
    noise_out = noise_level(luminance(chan), mask) if mode != "none" else noise_in
    lap("denoise")
    edges = subpixel_edges(chan, mask, sigma=o["sigma"], noise=noise_out, low=o["low"], high=o["high"])
    lap("edges")
    centres, used = pair_edges(edges, max_width=o["max_width"])
    if o["step_edges"]:
        centres = Centres.concatenate([centres, step_edges(edges, np.flatnonzero(~used))])
    chains = link_chains(centres, min_points=1)
    chains = [c for c in join_chains(chains) if len(c["uv"]) >= o["min_points"]]
    lap("chains")
    # rays of every chain point at once
    allrays = pixel_rays_with_jacobian(cam, np.concatenate([c["uv"] for c in chains]) if chains else np.zeros((0, 2)))
    pieces, start = [], 0
    for k, c in enumerate(chains):
        m = len(c["uv"])
        pieces += split_chain(c["uv"], allrays.take(slice(start, start + m)), threshold=o["threshold"],
                              min_points=o["min_points"], source=k, polarity=c["polarity"])
        start += m
    lines = merge_pieces(pieces, threshold=o["threshold"], merge_angle_deg=o["merge_angle_deg"])
    if o["grow_gap_px"] > 0 and lines:
        lines = grow_lines(lines, centres.uv, centres.normal, pixel_rays_with_jacobian(cam, centres.uv),
                           threshold=o["threshold"], max_gap=o["grow_gap_px"])
        lines = merge_pieces(lines, threshold=o["threshold"], merge_angle_deg=o["merge_angle_deg"])
    lines = [p for p in lines if p.length >= o["min_pixels"]]
    lines.sort(key=lambda p: -p.length)
    lap("curves")
    uv, normals, covs, rms, pol, width = [], [], [], [], [], []
    for p in lines:
        order = order_along(p)
        uv.append(p.uv[order])
        normals.append(p.normal)
        covs.append(line_covariance(p, o["sigma_floor"], o["systematic_px"]))
        rms.append(p.rms)
        pol.append(p.polarity)
        width.append(float(np.median([chains[s]["width"] for s in p.sources])))
    normals = np.array(normals).reshape(-1, 3)
    covs = np.array(covs).reshape(-1, 3, 3)
    planes = LinePlanes(normals, covs, [len(u) for u in uv], cam=cam if o["concurrency_px"] > 0 else None,
                        ends=np.array([[u[0], u[-1]] for u in uv]).reshape(-1, 2, 2))
    family, families = group_families(planes, GroupingOptions(
        chi2_max=o["chi2_max"], angle_floor_deg=o["angle_floor_deg"], min_lines=o["min_family_lines"],
        min_search_pixels=o["family_search_pixels"], max_log_nfa=o["max_log_nfa"], concurrency_px=o["concurrency_px"]))
    lap("families")
    appearance = side_colours(chan, [p.rays for p in lines], normals, width, noise_out)
    lap("appearance")
    seconds["total"] = float(sum(seconds.values()))
    return DetectedLines(cam=cam, uv=uv, normal=normals, normal_cov=covs, rms=np.array(rms), polarity=np.array(pol),
                         width=np.array(width), family=family, families=families, image_size=(W, H),
                         noise={"image": noise_in, "denoised": noise_out}, denoise=mode,
                         chains=[c["uv"] for c in chains], seconds=seconds, annulus=annulus,
                         options={k: v for k, v in o.items()}, appearance=appearance)
