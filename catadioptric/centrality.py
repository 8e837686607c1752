"""How far a rig is from central: the error of its best central (unified-model) approximation.

For a rig ``cam`` (:class:`~catadioptric.cameras.CatadioptricCamera`) the report fits two
approximations with :func:`catadioptric.unified.fit_unified`:

- ``central``: the unified model with Barreto's tilt ``R_tilt``, the model class that holds
  every central rig exactly (a pinhole at a focus, tilted or not). Its error measures the
  non-centrality alone; it is the headline.
- ``omnidir``: the pure Mei model (no tilt), the form OpenCV's omnidir module uses; exported
  as omnidir parameters. Without the tilt it cannot absorb a lateral offset of the camera (the
  best central model of a laterally displaced pinhole has a tilted virtual pinhole), so its
  errors are an order of magnitude larger (docs/unified.md).

For each approximation: the per-pixel angular error (for every pixel whose exact ray is valid,
the angle between the exact reflected ray's direction and the direction of the
approximation's ray through the same pixel) and the vanishing-point errors for a fixed
seeded set of directions plus the six signed axes: in pixels (exact vanishing point against the
approximation's) and in degrees (the angle between the direction ``s`` and the direction the
approximation's back-projection of the exact vanishing point gives; the analogue of the 17
degrees of Miraldo et al., CVPR 2018, Sec. 5.5). ``catadioptric centrality`` writes
``report.json``, ``report.md`` and ``heatmap.png``; see docs/unified.md.
"""
from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field

import numpy as np

from ._checks import CatadioptricError, as_float_array
from .cameras import CatadioptricCamera
from .unified import DEFAULT_DEPTHS, UnifiedCamera, UnifiedFit, fit_unified

__all__ = ["CentralityReport", "centrality_report", "default_directions", "exact_vanishing_points",
           "angular_error_map", "PAPER_DEG"]

PAPER_DEG = 17.0  # Miraldo, Eiras, Ramalingam, CVPR 2018, Sec. 5.5 / Fig. 7: rig about 9 % off central


# ----------------------------------------------------------------------------- helpers
def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle in degrees between vectors ``(..., 3)`` (atan2 form: exact near 0 and 180)."""
    cr = np.linalg.norm(np.cross(a, b), axis=-1)
    dt = np.sum(a * b, axis=-1)
    return np.degrees(np.arctan2(cr, dt))


def default_directions(n: int = 200, seed: int = 0) -> np.ndarray:
    """``n`` unit directions drawn uniformly on the sphere with ``numpy.random.default_rng(seed)``,
    followed by the six signed axes ``+-e1, +-e2, +-e3`` of M: ``(n + 6, 3)``."""
    if not (isinstance(n, (int, np.integer)) and n >= 0):
        raise CatadioptricError(f"n: expected a non-negative integer, got {n!r}")
    rng = np.random.default_rng(seed)
    s = rng.normal(size=(int(n), 3))
    s /= np.linalg.norm(s, axis=-1, keepdims=True)
    axes = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)
    return np.concatenate([s, axes])


def _first_valid(uv: np.ndarray, valid: np.ndarray):
    k = np.argmax(valid, axis=-1)
    pick = np.take_along_axis(uv, k[..., None, None], axis=-2)[..., 0, :]
    ok = valid.any(axis=-1)
    return np.where(ok[..., None], pick, np.nan), ok


def _extrapolated_vanishing_points(cam: CatadioptricCamera, s: np.ndarray, levels: int = 4):
    """Vanishing points of ``s (N, 3)`` from the exact forward projection of ``q + lambda s`` at
    lambda = L, 2L, 4L, 8L (L = 100 m; q on the axis in the middle of the patch) and Richardson
    extrapolation to 1/lambda = 0 (a cubic in 1/lambda through the four images). The image at
    each lambda is the valid one nearest the previous level's. Accurate to about 1e-11 px."""
    m = cam.mirror
    q = np.array([0.0, 0.0, 0.5 * (m.z_min + m.z_max)])
    L = 100.0
    lams = L * 2.0 ** np.arange(levels)
    prev = None
    U = []
    count = None
    for lam in lams:
        pr = cam.project(q + lam * s)
        uv = np.where(pr.valid[..., None], pr.uv, np.nan)
        if prev is None:
            cur, ok = _first_valid(pr.uv, pr.valid)
            count = pr.valid.sum(-1)
        else:
            d = np.linalg.norm(uv - prev[:, None, :], axis=-1)
            d = np.where(pr.valid, d, np.inf)
            k = np.argmin(d, axis=-1)
            cur = np.take_along_axis(uv, k[:, None, None], axis=1)[:, 0]
            cur = np.where(np.isfinite(d.min(-1))[:, None], cur, np.nan)
        U.append(cur)
        prev = cur
    U = np.array(U)  # (levels, N, 2)
    h = 1.0 / lams
    V = np.vander(h, levels)  # last column: the constant term
    coef = np.linalg.solve(V, U.reshape(levels, -1))
    ext = coef[-1].reshape(-1, 2)
    ok = np.all(np.isfinite(U), axis=(0, 2))
    return np.where(ok[:, None], ext, np.nan), ok, count


def exact_vanishing_points(cam: CatadioptricCamera, directions, *, method: str = "auto"):
    """The exact (observable, ``+s``) vanishing point of each direction ``(N, 3)`` in M.

    Returns ``(uv (N, 2), valid (N,), count (N,), method)``: the first observable vanishing point
    (``count`` says how many the direction has; the rigs here have at most one), and the method
    used: ``"solver"`` (``cam.vanishing_points``, catadioptric.vanishing) or ``"extrapolation"``
    (forward projection of far points, see :func:`_extrapolated_vanishing_points`). ``"auto"``
    prefers the solver when the camera has it.
    """
    s = as_float_array(directions, "directions", 3)
    s = s.reshape(-1, 3)
    if method not in ("auto", "solver", "extrapolation"):
        raise CatadioptricError(f"method: expected 'auto', 'solver' or 'extrapolation', got {method!r}")
    has_solver = callable(getattr(cam, "vanishing_points", None))
    if method == "solver" and not has_solver:
        raise CatadioptricError("method: 'solver' needs CatadioptricCamera.vanishing_points (catadioptric.vanishing)")
    if method == "solver" or (method == "auto" and has_solver):
        vp = cam.vanishing_points(s)
        uv, ok = _first_valid(vp.uv, vp.valid)
        return uv, ok, vp.valid.sum(-1), "solver"
    uv, ok, count = _extrapolated_vanishing_points(cam, s)
    return uv, ok, count, "extrapolation"


def angular_error_map(cam: CatadioptricCamera, approx: UnifiedCamera, step: int = 1):
    """Per-pixel angular error (degrees) of ``approx`` against the exact rig, on every ``step``-th
    pixel: ``(err (H', W'), uv (H', W', 2), exact_valid (H', W'), approx_valid (H', W'))``;
    ``err`` is NaN where the exact ray is invalid or the approximation has no ray."""
    uv = cam.pinhole.pixel_grid(step)
    ex = cam.backproject(uv)
    ap = approx.backproject(uv)
    both = ex.valid & ap.valid
    err = np.full(uv.shape[:-1], np.nan)
    err[both] = _angle_deg(ex.directions[both], ap.directions[both])
    return err, uv, ex.valid, ap.valid


def _stats(x: np.ndarray) -> dict:
    x = x[np.isfinite(x)]
    if x.size == 0:
        return {"n": 0, "max": None, "median": None, "mean": None, "p95": None}
    return {"n": int(x.size), "max": float(x.max()), "median": float(np.median(x)), "mean": float(x.mean()),
            "p95": float(np.percentile(x, 95))}


def _offset_from_focus(cam: CatadioptricCamera) -> dict:
    m = cam.mirror
    foci = m.foci
    if len(foci) != 2 or m.kind not in ("ellipsoid", "hyperboloid"):
        return {"nearest_focus": None, "offset_m": None, "focal_distance_m": None, "offset_pct": None}
    F = min(foci, key=lambda F: float(np.linalg.norm(cam.center - F)))
    off = float(np.linalg.norm(cam.center - F))
    fd = float(np.linalg.norm(foci[1] - foci[0]))
    return {"nearest_focus": np.asarray(F).tolist(), "offset_m": off, "focal_distance_m": fd,
            "offset_pct": 100.0 * off / fd}


# ----------------------------------------------------------------------------- the report
@dataclass
class Approximation:
    """One fitted approximation with its errors (part of :class:`CentralityReport`)."""

    name: str
    fit: UnifiedFit
    error_map_deg: np.ndarray  # (H', W'), NaN off the mirror
    pixel_error: dict
    n_exact_pixels: int
    n_unmodelled_pixels: int  # exact ray valid, approximation has no ray
    vp_uv: np.ndarray  # (N, 2) approximation's vanishing points of +s
    vp_valid: np.ndarray
    vp_px: np.ndarray  # (N,) NaN where not compared
    vp_deg: np.ndarray
    vp_px_stats: dict
    vp_deg_stats: dict
    n_vp_unmodelled: int  # exact VP seen, the approximation gives none


@dataclass
class CentralityReport:
    """See :func:`centrality_report`. ``summary()`` holds the headline figures."""

    rig: str
    cam: CatadioptricCamera
    directions: np.ndarray
    exact_vp_uv: np.ndarray
    exact_vp_valid: np.ndarray
    exact_vp_count: np.ndarray
    vp_method: str
    central: Approximation
    omnidir: Approximation
    step: int
    fit_step: int
    seconds: float
    settings: dict = field(default_factory=dict)

    # ---------------------------------------------------------------- summaries
    def summary(self) -> dict:
        """Headline figures: for both approximations, max/median per-pixel angular error (deg),
        max/median vanishing-point error (px, deg), and the fit's rms reprojection error (px)."""
        out = {"rig": self.rig, "is_central": bool(self.cam.is_central), **_offset_from_focus(self.cam),
               "paper_deg": PAPER_DEG, "vp_method": self.vp_method,
               "n_directions": int(len(self.directions)), "n_vp_seen": int(self.exact_vp_valid.sum())}
        for a in (self.central, self.omnidir):
            out[a.name] = {
                "pixel_max_deg": a.pixel_error["max"],
                "pixel_median_deg": a.pixel_error["median"],
                "vp_max_px": a.vp_px_stats["max"],
                "vp_median_px": a.vp_px_stats["median"],
                "vp_max_deg": a.vp_deg_stats["max"],
                "vp_median_deg": a.vp_deg_stats["median"],
                "fit_rms_px": a.fit.rms_px,
            }
        return out

    def _vp_rows(self) -> list[dict]:
        rows = []
        for i, s in enumerate(self.directions):
            r = {"s": np.round(s, 12).tolist(), "exact_uv": None, "n_exact": int(self.exact_vp_count[i])}
            if self.exact_vp_valid[i]:
                r["exact_uv"] = np.round(self.exact_vp_uv[i], 9).tolist()
            for a in (self.central, self.omnidir):
                r[a.name] = {
                    "uv": np.round(a.vp_uv[i], 9).tolist() if a.vp_valid[i] else None,
                    "px": None if not np.isfinite(a.vp_px[i]) else round(float(a.vp_px[i]), 9),
                    "deg": None if not np.isfinite(a.vp_deg[i]) else round(float(a.vp_deg[i]), 9),
                }
            rows.append(r)
        return rows

    def to_dict(self) -> dict:
        def approx(a: Approximation) -> dict:
            d = {
                "model": ("unified sphere model with tilt R_tilt (Barreto): exact for every central rig"
                          if a.fit.tilt else "pure unified model (Mei, OpenCV omnidir), no tilt"),
                "fit": a.fit.to_dict(),
                "pixel_error_deg": a.pixel_error,
                "n_exact_pixels": a.n_exact_pixels,
                "n_unmodelled_pixels": a.n_unmodelled_pixels,
                "vp_error_px": a.vp_px_stats,
                "vp_error_deg": a.vp_deg_stats,
                "n_vp_unmodelled": a.n_vp_unmodelled,
            }
            if a.fit.camera.is_pure:
                d["omnidir"] = a.fit.camera.to_omnidir()
            return d

        return {
            "summary": self.summary(),
            "rig": {"name": self.rig, "camera": self.cam.to_dict(), "mirror_kind": self.cam.mirror.kind},
            "settings": {"pixel_step": self.step, "fit_step": self.fit_step, **self.settings},
            "central": approx(self.central),
            "omnidir": approx(self.omnidir),
            "vanishing_points": self._vp_rows(),
            "seconds": self.seconds,
        }

    def to_markdown(self) -> str:
        S = self.summary()
        c, o = S["central"], S["omnidir"]

        def f(x, fmt="{:.3f}"):
            return "n/a" if x is None else fmt.format(x)

        off = ("" if S["offset_m"] is None else
               f"{S['offset_m'] * 1e3:.3g} mm from the nearest focus, {S['offset_pct']:.3g} % of the focal "
               f"distance {S['focal_distance_m'] * 1e3:.4g} mm")
        cam = self.cam
        lines = [
            f"# Centrality report: `{self.rig}`",
            "",
            f"Mirror: {cam.mirror.kind} (A={cam.mirror.A:.6g}, B={cam.mirror.B:.6g}, C={cam.mirror.C:.6g}, "
            f"z in [{cam.mirror.z_min:g}, {cam.mirror.z_max:g}] m); pinhole "
            f"{cam.pinhole.width}x{cam.pinhole.height} px, fx = {cam.pinhole.K[0, 0]:.2f} px; camera at "
            f"{np.round(cam.center, 6).tolist()} m ({off}); central: {cam.is_central}.",
            "",
            "Two central approximations fitted by least squares (docs/unified.md): **central** = unified "
            "model with Barreto's tilt (holds every central rig exactly, so its error is the "
            "non-centrality alone); **omnidir** = pure Mei model, OpenCV omnidir's form (no tilt).",
            "",
            "| figure | central (with tilt) | omnidir (no tilt) |",
            "|---|---|---|",
            f"| per-pixel angular error, max (deg) | {f(c['pixel_max_deg'])} | {f(o['pixel_max_deg'])} |",
            f"| per-pixel angular error, median (deg) | {f(c['pixel_median_deg'])} | {f(o['pixel_median_deg'])} |",
            f"| vanishing point error, max (px) | {f(c['vp_max_px'])} | {f(o['vp_max_px'])} |",
            f"| vanishing point error, median (px) | {f(c['vp_median_px'])} | {f(o['vp_median_px'])} |",
            f"| vanishing point direction error, max (deg) | {f(c['vp_max_deg'])} | {f(o['vp_max_deg'])} |",
            f"| vanishing point direction error, median (deg) | {f(c['vp_median_deg'])} | {f(o['vp_median_deg'])} |",
            f"| fit reprojection rms (px) | {f(c['fit_rms_px'])} | {f(o['fit_rms_px'])} |",
            "",
            f"The paper (Miraldo et al., CVPR 2018, Sec. 5.5) reports {PAPER_DEG:g} degrees between the exact "
            "direction and the unified model's for a real hyperbolic rig about 9 % off the central "
            "configuration (one vanishing point; calibration, mirror and camera unpublished).",
            "",
            f"Vanishing points: {S['n_directions']} directions "
            + (f"({self.settings['n_random']} seeded random, seed {self.settings['seed']}, plus +-e1, +-e2, +-e3 "
               "of the mirror frame); " if self.settings.get("n_random") is not None else "(given by the caller); ")
            + f"{S['n_vp_seen']} have an observable exact vanishing point (method: {self.vp_method}). "
            "Pixel error: exact vanishing point against the approximation's. Degrees: the angle between s "
            "and the approximation's ray through the exact vanishing point.",
            "",
            "## Definitions",
            "",
            f"- Per-pixel angular error: every {self.step}-th pixel whose exact reflected ray is valid; the angle "
            "between the exact ray's direction and the direction of the approximation's ray through the "
            "same pixel (the rays start at different points: the mirror point and the viewpoint).",
            f"- Fit: every {self.fit_step}-th pixel whose exact ray is valid; points along the exact ray at "
            f"{', '.join('inf' if not np.isfinite(t) else f'{t:g} m' for t in self.central.fit.depths)} from its "
            "mirror point; minimised: the sum of squared pixel distances between the model's image of "
            "each point and its pixel, over xi, K (fx, fy, skew, cx, cy), viewpoint (3), sphere rotation (3), "
            "and for the central model the tilt (2).",
            "",
            "## Fitted models",
            "",
        ]
        for a in (self.central, self.omnidir):
            u = a.fit.camera
            lines += [
                f"**{a.name}**: xi = {u.xi:.9f}; K = {np.round(u.K, 6).tolist()}; viewpoint = "
                f"{np.round(u.center, 9).tolist()} m; R_sphere_from_mirror = "
                f"{np.round(u.R_sphere_from_mirror, 9).tolist()}; R_tilt = {np.round(u.R_tilt, 9).tolist()}; "
                f"fit rms {a.fit.rms_px:.4g} px, max {a.fit.max_px:.4g} px over {a.fit.n_points} points "
                f"({a.fit.n_pixels} pixels); {a.n_unmodelled_pixels} of {a.n_exact_pixels} pixels have no "
                "ray in the approximation.",
                "",
            ]
        if self.omnidir.fit.camera.is_pure:
            om = self.omnidir.fit.camera.to_omnidir()
            lines += [
                "OpenCV omnidir parameters of the omnidir approximation (`X_c = R(rvec) X_M + tvec`, M the mirror "
                "frame):",
                "",
                "```",
                f"K    = {np.round(np.array(om['K']), 9).tolist()}",
                f"D    = {om['D']}",
                f"xi   = {om['xi']:.12g}",
                f"rvec = {np.round(om['rvec'], 12).tolist()}",
                f"tvec = {np.round(om['tvec'], 12).tolist()}",
                "```",
                "",
            ]
        lines += [
            "`heatmap.png`: the per-pixel angular error of both approximations; white circles are the exact "
            "vanishing points, black crosses the approximation's, joined by a line.",
            "",
            f"Reproduce: `catadioptric centrality --rig {self.rig} --out <folder>` "
            f"({self.seconds:.1f} s here).",
            "",
        ]
        return "\n".join(lines)

    # ---------------------------------------------------------------- files
    def heatmap(self, path: str) -> None:
        """Write the two-panel heat map PNG to ``path`` (atomically)."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        W, H = self.cam.pinhole.width, self.cam.pinhole.height
        fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.4), dpi=90, constrained_layout=True)
        ext = (-0.5, W - 0.5, H - 0.5, -0.5)
        for ax, a in zip(axes, (self.central, self.omnidir)):
            cmap = plt.get_cmap("viridis").with_extremes(bad="0.85")
            im = ax.imshow(a.error_map_deg, cmap=cmap, extent=ext, interpolation="nearest")
            fig.colorbar(im, ax=ax, shrink=0.85, label="angular error (deg)")
            sel = self.exact_vp_valid & a.vp_valid
            ex, ap = self.exact_vp_uv[sel], a.vp_uv[sel]
            for p, r in zip(ex, ap):
                ax.plot([p[0], r[0]], [p[1], r[1]], "-", color="k", lw=0.6)
            ax.plot(ex[:, 0], ex[:, 1], "o", mfc="none", mec="w", ms=3.5, mew=0.8)
            ax.plot(ap[:, 0], ap[:, 1], "x", color="k", ms=3.5, mew=0.8)
            ax.set_xlim(-0.5, W - 0.5)
            ax.set_ylim(H - 0.5, -0.5)
            pe = a.pixel_error
            title = "central (unified + tilt)" if a.fit.tilt else "omnidir (pure Mei model)"
            ax.set_title(f"{self.rig}: {title}\nper-pixel max {pe['max']:.3g} deg, median {pe['median']:.3g} deg; "
                         f"VP max {a.vp_deg_stats['max'] if a.vp_deg_stats['max'] is not None else float('nan'):.3g} deg",
                         fontsize=8)
            ax.tick_params(labelsize=7)
        import io

        from ._io import atomic_write_bytes

        buf = io.BytesIO()
        fig.savefig(buf, format="png")
        plt.close(fig)
        atomic_write_bytes(path, buf.getvalue())

    def save(self, out_dir: str) -> dict:
        """Write ``report.json``, ``report.md`` and ``heatmap.png`` into ``out_dir`` (each written to a
        temporary file in the folder and moved into place with ``os.replace``)."""
        os.makedirs(out_dir, exist_ok=True)
        paths = {k: os.path.join(out_dir, n) for k, n in
                 (("json", "report.json"), ("md", "report.md"), ("png", "heatmap.png"))}
        from ._io import atomic_write_bytes

        for key, text in (("json", _json_text(self.to_dict())), ("md", self.to_markdown())):
            atomic_write_bytes(paths[key], text.encode())
        self.heatmap(paths["png"])
        return paths


def _json_text(d: dict) -> str:
    """JSON with one line per vanishing-point row and per small array (compact but diffable)."""
    rows = d.pop("vanishing_points")
    body = json.dumps(d, indent=1)
    body = body[: body.rstrip().rfind("}")].rstrip()
    lines = ",\n  ".join(json.dumps(r, separators=(",", ":")) for r in rows)
    return body + ',\n "vanishing_points": [\n  ' + lines + "\n ]\n}\n"


def _approximation(name, cam, fit, step, directions, exact_uv, exact_ok) -> Approximation:
    u = fit.camera
    err, _, exv, apv = angular_error_map(cam, u, step)
    vp = u.vanishing_points(directions)
    both = exact_ok & vp.valid
    px = np.full(len(directions), np.nan)
    px[both] = np.linalg.norm(exact_uv[both] - vp.uv[both], axis=-1)
    deg = np.full(len(directions), np.nan)
    rays = u.backproject(np.where(exact_ok[:, None], exact_uv, 0.0))
    okd = exact_ok & rays.valid
    deg[okd] = _angle_deg(directions[okd], rays.directions[okd])
    return Approximation(name, fit, err, _stats(err), int(exv.sum()), int((exv & ~apv).sum()), vp.uv, vp.valid, px,
                         deg, _stats(px), _stats(deg), int((exact_ok & ~(vp.valid & rays.valid)).sum()))


def centrality_report(cam: CatadioptricCamera, directions=None, *, rig: str = "rig", n_directions: int = 200,
                      seed: int = 0, step: int = 1, fit_step: int = 4, depths=DEFAULT_DEPTHS,
                      vp_method: str = "auto") -> CentralityReport:
    """The centrality report of ``cam`` (see the module docstring).

    ``directions (N, 3)`` in M (default :func:`default_directions` ``(n_directions, seed)``: seeded
    random plus the six signed axes); ``step``: pixel stride of the per-pixel error map;
    ``fit_step``, ``depths``: samples of the fits (:func:`catadioptric.unified.fit_unified`);
    ``vp_method``: how the exact vanishing points are found (:func:`exact_vanishing_points`).
    For an exactly central rig every figure is zero to rounding.
    """
    t0 = time.perf_counter()
    if not isinstance(cam, CatadioptricCamera):
        raise CatadioptricError(f"cam: expected a CatadioptricCamera, got {type(cam).__name__}")
    for name, v in (("step", step), ("fit_step", fit_step)):
        if not (isinstance(v, (int, np.integer)) and v >= 1):
            raise CatadioptricError(f"{name}: expected a positive integer, got {v!r}")
    if directions is None:
        s = default_directions(n_directions, seed)
    else:
        s = as_float_array(directions, "directions", 3).reshape(-1, 3)
        n = np.linalg.norm(s, axis=-1)
        if np.any(n == 0):
            raise CatadioptricError(f"directions: expected nonzero direction vectors, got a zero vector at index "
                                    f"{int(np.argmax(n == 0))}")
        s = s / n[:, None]
    exact_uv, exact_ok, count, method = exact_vanishing_points(cam, s, method=vp_method)
    exact_ok = exact_ok & cam.pinhole.in_image(np.nan_to_num(exact_uv, nan=-1e9))
    fits = {
        "central": fit_unified(cam, step=fit_step, depths=depths, tilt=True),
        "omnidir": fit_unified(cam, step=fit_step, depths=depths, tilt=False),
    }
    apx = {k: _approximation(k, cam, f, step, s, exact_uv, exact_ok) for k, f in fits.items()}
    settings = {"seed": seed, "n_random": (n_directions if directions is None else None),
                "depths_m": ["inf" if not np.isfinite(t) else float(t) for t in np.atleast_1d(depths)]}
    return CentralityReport(rig, cam, s, exact_uv, exact_ok, count, method, apx["central"], apx["omnidir"],
                            int(step), int(fit_step), time.perf_counter() - t0, settings)
