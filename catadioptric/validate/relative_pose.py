"""Relative pose of a rendered view pair from its lines, against the ground truth.

For each noise draw: the pixels of every labelled line in both views (:mod:`.observations`,
noise added), the relative pose by the exact model (:func:`catadioptric.pose.relative_pose`)
and by the fair central baseline: the same pixels, the same estimator, through the best central
approximation of the rig (the unified model with tilt, fitted once per rig); for a central
rig that approximation is exact. Line correspondences and families come from the labels; the
signs of the families (which end is which) are searched unless ``ends="given"`` (the paper's
matched vanishing points, taken from the ground truth).

Frames: ``x_B = R x_A + t`` between the mirror frames of views A and B, so with the stored poses
``x_M = R_V x_W + t_V``: ``R_gt = R_B R_A^T`` and ``t_gt = t_B - R_gt t_A``.
"""
from __future__ import annotations

import json
import time

import numpy as np

from .._checks import CatadioptricError

__all__ = ["evaluate_pair", "central_approximation", "central_model_error_px", "ENDS", "angle_between_deg",
           "length_observable", "translation_text", "noise_rng"]

ENDS = ("unknown", "given")
_UNIFIED_CACHE: dict = {}


def central_approximation(cam):
    """The best central approximation of a rig (unified model with tilt), fitted once per rig;
    a central rig's own exact unified model."""
    return _central_fit(cam)[0]


def central_model_error_px(cam) -> float:
    """How far the rig's best central approximation (:func:`central_approximation`) is from its
    exact pixels: the rms pixel distance of the fit (0 for a central rig). The central answer's
    ``relative_pose(..., model_error_px=)``."""
    return _central_fit(cam)[1]


def _central_fit(cam):
    """``(unified camera, its rms error in pixels)``: the best central approximation of the rig and
    how far it is from the exact pixels (0 for a central rig)."""
    from ..unified import fit_unified, unified_from_central

    key = json.dumps(cam.to_dict(), sort_keys=True)
    if key not in _UNIFIED_CACHE:
        if cam.is_central:
            _UNIFIED_CACHE[key] = (unified_from_central(cam), 0.0)
        else:
            fit = fit_unified(cam, tilt=True, step=16)
            _UNIFIED_CACHE[key] = (fit.camera, float(fit.rms_px))
    return _UNIFIED_CACHE[key]


def angle_between_deg(a, b) -> float:
    """The angle between two 3-vectors (degrees; a translation's direction against the truth); nan
    when either is zero (a translation found zero: the camera turned in place)."""
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    n = np.linalg.norm(a) * np.linalg.norm(b)
    if n == 0:
        return float("nan")
    return float(np.degrees(np.arccos(np.clip(a @ b / n, -1.0, 1.0))))


def _rotation_error_deg(R, R_gt) -> float:
    from ..pose import rotation_angle_deg

    return rotation_angle_deg(R @ R_gt.T)


def _record(res, R_gt, t_gt, centre_a, centre_b, seconds) -> dict:
    """One estimate against the truth, in the report's schema."""
    from ..pose.relative import MIN_MEETINGS

    out = {"R": res.R, "t": res.t, "metric": res.metric, "ambiguous": res.ambiguous, "margin": res.margin,
           "rotation_error_deg": _rotation_error_deg(res.R, R_gt),
           "frobenius_error": float(np.linalg.norm(res.R - R_gt)),
           "rotation_std_deg": res.rotation_std_deg, "translation_std": res.translation_std,
           "translation_error_m": None, "translation_direction_error_deg": None,
           "families_used": len(res.families), "lines_used": int(res.lines_matched), "sigma_px": res.sigma_px,
           "meeting_rays": res.meeting_rays, "bar": res.bar,
           "candidates_count": len(res.candidates), "seconds": seconds, "notes": res.notes}
    fit = res.candidates[0].fit if res.candidates else None
    if res.metric and hasattr(fit, "scale_held"):  # the refinement's scale: held far, or fixed by the pixels
        out["scale_held"], out["far_gap"], out["scale_std"] = bool(fit.scale_held), float(fit.far_gap), float(fit.scale_std)
    if res.t is not None:
        if res.metric:
            out["translation_error_m"] = float(np.linalg.norm(res.t - t_gt))
            out["translation_direction_error_deg"] = angle_between_deg(res.t, t_gt)
        else:  # the direction between the two views' centres
            out["translation_direction_error_deg"] = angle_between_deg(res.t, R_gt @ centre_a + t_gt - centre_b)
    # every candidate also where the first stage was weak (few meeting rays): the wide pairs' calibration
    # of the bar reads the rivals' margins there (docs/relative_pose.md, "The verdict at wide baselines")
    weak = res.meeting_rays is not None and res.meeting_rays < MIN_MEETINGS
    if res.ambiguous or weak:
        out["candidates"] = [c.summary() | {"rotation_error_deg": _rotation_error_deg(c.R, R_gt)}
                             for c in res.candidates]
    return out


def _draw_pixels(base, rng, noise_px, max_pixels):
    uv = []
    for u in base.uv:
        if max_pixels is not None and len(u) > max_pixels:
            u = u[np.round(np.linspace(0, len(u) - 1, max_pixels)).astype(int)]
        uv.append(u + rng.normal(0.0, noise_px, u.shape) if noise_px > 0 else u.copy())
    return uv


def noise_rng(seed, noise: float, draw: int):
    """``(seed list, numpy Generator)`` of draw ``draw`` at ``noise`` pixels: the seed is
    ``[*seed, round(1000 noise), draw]``, so each level and draw has its own stream (the label path's
    draws, and the PoseLib peers' on the same pair, :mod:`.peers`)."""
    draw_seed = [*np.atleast_1d(seed).tolist(), int(round(noise * 1000)), int(draw)]
    return draw_seed, np.random.default_rng(draw_seed)


def evaluate_pair(dataset, names, *, noise_levels=(2.0,), draws: int = 1, seed=0, pixels: str = "curve",
                  min_pixels: int = 30, max_pixels: int | None = None, ends: str = "unknown",
                  central: bool = True, decisive: float = 25.0, threads: int = 2) -> dict:
    """Every noise level and draw of the view pair ``names = (A, B)`` of ``dataset`` (a folder or a
    :class:`catadioptric.Dataset`): ``draws`` noise draws per level above 0, one at level 0 (its
    pixels are the same in every draw). ``threads``: as :func:`catadioptric.pose.relative_pose`'s
    (the answers do not depend on it). Returns the report dict (docs/relative_pose.md, "Report")."""
    if ends not in ENDS:
        raise CatadioptricError(f"ends: expected one of {list(ENDS)}, got {ends!r}")
    if not (isinstance(draws, (int, np.integer)) and draws >= 1):
        raise CatadioptricError(f"draws: expected a positive integer, got {draws!r}")
    noise_levels = [float(x) for x in np.atleast_1d(noise_levels)]
    if any(not np.isfinite(x) or x < 0 for x in noise_levels):
        raise CatadioptricError(f"noise: expected non-negative pixel noise levels, got {noise_levels}")
    from threadpoolctl import threadpool_limits

    # the solves here are small: a multithreaded BLAS only fights other processes for the cores
    with threadpool_limits(1):
        return _evaluate_pair(dataset, names, noise_levels, draws, seed, pixels, min_pixels, max_pixels, ends, central,
                              decisive, threads)


def _evaluate_pair(dataset, names, noise_levels, draws, seed, pixels, min_pixels, max_pixels, ends, central, decisive,
                   threads):
    from ..dataset import Dataset
    from ..pose import ViewLines, choose_model, relative_pose
    from ..pose.families import rays_centre
    from ..observations import line_pixels

    ds = dataset if isinstance(dataset, Dataset) else Dataset(dataset)
    va, vb = ds.view_pair(names)
    pa, pb = va["pose"], vb["pose"]
    R_gt = pb.R @ pa.R.T
    t_gt = pb.t - R_gt @ pa.t
    cams = (va["camera"], vb["camera"])
    base = [line_pixels(v, pixels=pixels, min_pixels=min_pixels) for v in (va, vb)]
    seen = {n: {"families": len(b.counts), "lines": int(sum(c["lines"] for c in b.counts.values())),
                "pixels": int(sum(c["pixels"] for c in b.counts.values())), "short_lines": b.short,
                "per_family": {str(k): v for k, v in sorted(b.counts.items())}} for n, b in zip(names, base)}
    common = sorted(set(base[0].counts) & set(base[1].counts))
    fam_dirs = {int(f["index"]): np.asarray(f["direction_W"], float) for f in va["families"]}
    hints = {f: (pa.directions_to_mirror(fam_dirs[f]), pb.directions_to_mirror(fam_dirs[f])) for f in common}
    uni = [central_approximation(c) for c in cams] if central else None
    # the approximation's own error: an error every pixel of a line shares (pose.relative_pose)
    model_px = max(central_model_error_px(c) for c in cams) if central else 0.0
    centres = [rays_centre(c) for c in cams]
    uni_centres = [np.asarray(u.viewpoint, float) for u in uni] if central else None
    out = {"views": list(names), "R_gt": R_gt, "t_gt": t_gt, "baseline_m": float(np.linalg.norm(t_gt)),
           "rig": cams[0].to_dict(), "pixels": pixels, "min_pixels": min_pixels, "max_pixels": max_pixels,
           "ends": ends, "seen": seen, "families_in_both": len(common), "draws": []}
    for noise in noise_levels:
        # without added noise every draw would see the same pixels: one draw, not `draws` copies
        for k in range(draws if noise > 0 else 1):
            draw_seed, rng = noise_rng(seed, noise, k)
            uvs = [_draw_pixels(b, rng, noise, max_pixels) for b in base]
            rec = {"noise_px": noise, "draw": k, "seed": draw_seed}
            answers = {}
            for label, cam_pair, cen in (("exact", cams, centres), ("central", uni, uni_centres)):
                if label == "central" and not central:
                    continue
                views = [ViewLines(c, u, b.family, b.segment) for c, u, b in zip(cam_pair, uvs, base)]
                t0 = time.perf_counter()
                try:
                    res = relative_pose(views[0], views[1], ends=hints if ends == "given" else None, seed=k,
                                        decisive=decisive, max_pixels=max_pixels, threads=threads,
                                        model_error_px=model_px if label == "central" else 0.0)
                except CatadioptricError as exc:
                    msg = str(exc)
                    short = [b.short for b in base]
                    if any(short):
                        msg += (f"; lines with fewer than {min_pixels} pixels, not used: {short[0]} in {names[0]}, "
                                f"{short[1]} in {names[1]} (min_pixels, --min-pixels, sets the minimum)")
                    rec[label] = {"error": msg, "seconds": time.perf_counter() - t0}
                    continue
                rec[label] = _record(res, R_gt, t_gt, cen[0], cen[1], time.perf_counter() - t0)
                answers[label] = res
            if "exact" in answers and "central" in answers:
                pick = choose_model(answers["exact"], answers["central"])
                rec["selected"] = {"model": pick.model, "rotation_error_deg": _rotation_error_deg(pick.R, R_gt),
                                   "frobenius_error": float(np.linalg.norm(pick.R - R_gt)),
                                   "rotation_std_deg": pick.rotation_std_deg, "ambiguous": pick.pose.ambiguous,
                                   "reason": pick.reason}
            # the report's schema: the exact model's fields at the top of each draw
            exact = rec.pop("exact")
            out["draws"].append(rec | exact)
    return out


def length_observable(d: dict) -> bool:
    """Whether a draw's metric translation has a known length: its deviation (``translation_std``,
    metres) is finite and smaller than the length itself (docs/relative_pose.md, ``pose.json``). A
    direction (the central model) has no length to observe."""
    t, std = d.get("t"), d.get("translation_std")
    if not d.get("metric") or t is None or std is None or not np.isfinite(std):
        return False
    return bool(std < np.linalg.norm(np.asarray(t, float)))


def translation_text(d: dict) -> str:
    """A draw's translation error for a reader: metres when its length is observable (a metric
    translation whose deviation is below its length), else ``not observable`` with the deviation
    that says so (``not known`` without a deviation); ``-`` when there is no metric translation."""
    if d.get("translation_error_m") is None:
        return "-"
    if length_observable(d):
        return f"{d['translation_error_m']:.3g}"
    std = d.get("translation_std")
    if std is None or not np.isfinite(std):
        return "not known (its deviation was not estimated)"
    return f"not observable (std {std:.3g} m, length {np.linalg.norm(np.asarray(d['t'], float)):.3g} m)"


def pair_markdown(res: dict, command: str) -> str:
    """The Markdown summary of :func:`evaluate_pair`'s result."""
    from .report import md_table

    A, B = res["views"]
    rows = []
    unobservable = False
    for d in res["draws"]:
        c = d.get("central", {})
        if "error" in d:
            rows.append([d["noise_px"], d["draw"], "failed: " + d["error"][:100], "", "", "", "", "", ""])
            continue
        t_m = translation_text(d)
        unobservable |= t_m.startswith("not observable")
        t_d = "-" if d["translation_direction_error_deg"] is None else f"{d['translation_direction_error_deg']:.3g}"
        c_r = c.get("error", "")[:60] if "error" in c else (f"{c['rotation_error_deg']:.3g}" if c else "-")
        c_t = "-" if not c or "error" in c or c["translation_direction_error_deg"] is None else \
            f"{c['translation_direction_error_deg']:.3g}"
        sel = d.get("selected")
        s_r = "-" if not sel or sel["ambiguous"] else f"{sel['rotation_error_deg']:.3g} ({sel['model']})"
        rows.append([d["noise_px"], d["draw"], "AMBIGUOUS" if d["ambiguous"] else f"{d['rotation_error_deg']:.3g}",
                     f"{d['frobenius_error']:.3g}", t_m, t_d, c_r + (" (ambiguous)" if c.get("ambiguous") else ""),
                     c_t, s_r])
    seen = [[n, s["families"], s["lines"], s["pixels"], s["short_lines"]] for n, s in res["seen"].items()]
    per_line = "every pixel of each line" if res["max_pixels"] is None else f"at most {res['max_pixels']} per line"
    text = [f"# Relative pose of views {A} and {B}", "",
            f"Baseline {res['baseline_m']:.2f} m; line pixels `{res['pixels']}` (lines of at least "
            f"{res['min_pixels']} pixels, {per_line} used); ends of the families "
            f"{'given (matched vanishing points)' if res['ends'] == 'given' else 'searched'}; "
            f"{res['families_in_both']} families seen in both views.", "",
            md_table(["view", "families", "lines", "pixels", "lines too short"], seen), "",
            "Errors against the ground truth (`x_B = R x_A + t` between the mirror frames): the exact "
            "(non-central) model, then the central baseline (the best central approximation of the rig), then "
            "the rotation of whichever of the two claims the smaller deviation (`pose.choose_model`, the model "
            "chosen in brackets).", "",
            md_table(["noise (px)", "draw", "rotation (deg)", "Frobenius", "translation length error (m)",
                      "translation direction (deg)", "central rotation (deg)", "central translation direction (deg)",
                      "selected rotation (deg)"], rows), "",
            *(["A translation whose standard deviation is larger than its length has a direction but no known "
               "length: its length is *not observable* from these pixels (docs/relative_pose.md, \"What limits "
               "the translation\"), and only its direction is compared.", ""] if unobservable else []),
            "The paper (Miraldo et al., CVPR 2018, Sec. 5.4) reports a Frobenius error of 0.0446 for its POV-Ray pair "
            "(non-central ellipsoidal rig, 2 px noise).", "", f"Reproduce: `{command}`", ""]
    return "\n".join(text)


def pair_figure(res: dict, dataset):
    """Both beauty images with each line's pixels coloured by family and the true vanishing points of
    the families used (rings: +s, squares: -s)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..dataset import Dataset
    from ..observations import line_pixels

    ds = dataset if isinstance(dataset, Dataset) else Dataset(dataset)
    fig, axes = plt.subplots(1, 2, figsize=(12.8, 5.0), dpi=100)
    cmap = plt.get_cmap("tab10")
    for ax, name in zip(axes, res["views"]):
        v = ds[name]
        ax.imshow(v["beauty"])
        lp = line_pixels(v, pixels=res["pixels"], min_pixels=res["min_pixels"])
        fams = sorted(set(lp.family))
        for uv, f in zip(lp.uv, lp.family):
            ax.plot(uv[:, 0], uv[:, 1], ".", ms=1.0, color=cmap(fams.index(f) % 10))
        vp = v["vanishing_points"]
        for f in fams:
            for k in range(vp["sign"].shape[1]):
                if vp["sign"][f, k] != 0 and vp["visible"][f, k] and vp["in_image"][f, k]:
                    ax.plot(*vp["uv"][f, k], "o" if vp["sign"][f, k] > 0 else "s", ms=9, mfc="none",
                            mec=cmap(fams.index(f) % 10), mew=1.5)
        ax.set_title(f"view {name}: line pixels by family, true vanishing points", fontsize=9)
        ax.set_axis_off()
    d = [x for x in res["draws"] if "error" not in x]
    if d:
        x = d[-1]
        td = x["translation_direction_error_deg"]
        fig.suptitle(f"noise {x['noise_px']} px: rotation error {x['rotation_error_deg']:.3f} deg"
                     + ("" if td is None else f", translation direction error {td:.2f} deg")
                     + (" (AMBIGUOUS)" if x["ambiguous"] else ""), fontsize=10)
    fig.tight_layout()
    return fig
