"""A rig in the formats of the tools people already use: OpenCV's omnidir (FileStorage YAML),
Kalibr's camchain (``omni`` + ``radtan``) and COLMAP's camera line (``EUCM``).

Each tool holds a *central* model (Mei's unified model), so a rig is exported through
:func:`central_model`: exactly for a central rig whose pinhole looks along the mirror axis
(:func:`catadioptric.unified.unified_from_central`), otherwise through its best central
approximation without tilt (:func:`catadioptric.unified.fit_unified` with ``tilt=False``, the
form OpenCV omnidir uses), and every export states how far that model is from the rig (the
centrality figures: the per-pixel angular error between the rig's exact rays and the model's).

Frames and signs (docs/formats.md, "Exports", has the formulas):

- OpenCV: the model as it is (:meth:`UnifiedCamera.to_omnidir`): ``K`` (with skew), ``D = 0``,
  ``xi`` and the pose ``rvec``, ``tvec`` of the mirror frame M in the omnidir camera frame.
- Kalibr and COLMAP want positive focal lengths, but a catadioptric image is a mirror image:
  with a right-handed sphere frame ``fy < 0`` (docs/unified.md). Their camera frame is
  therefore the sphere frame with its y axis reversed, ``C = diag(1, -1, 1) S`` (a reflection,
  so it is left-handed in M), which turns ``fy`` into ``-fy > 0`` and ``s`` into ``-s``.
  Neither tool has a skew: it is dropped, and the largest pixel shift that costs on the
  rig's image is stated.
- COLMAP's EUCM with ``beta = 1`` is the unified model (``alpha = xi / (1 + xi)``, focal
  lengths divided by ``1 + xi``); COLMAP's pixel centres are at ``+0.5`` (its top-left pixel
  centre is (0.5, 0.5)); it refuses points with ``z <= 0`` in its camera frame, so the part
  of the field of view beyond 90 degrees from the sphere's axis is lost: stated.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

from ._checks import CatadioptricError
from .cameras import CatadioptricCamera
from .unified import UnifiedCamera, fit_unified, unified_from_central

__all__ = ["FORMATS", "CentralModel", "central_model", "opencv_yaml", "kalibr_parameters", "kalibr_camchain",
           "colmap_parameters", "colmap_camera_line", "export_json", "export_rig", "register"]

FORMATS = ("opencv", "kalibr", "colmap", "json")
_ALIASES = {"opencv-yaml": "opencv"}
#: The reflection from the sphere frame S to the camera frame of the Kalibr and COLMAP exports.
FLIP_Y = np.diag([1.0, -1.0, 1.0])


@dataclass
class CentralModel:
    """The central (pure unified) model a rig is exported through.

    ``camera``: the :class:`UnifiedCamera` (``R_tilt = I``); ``exact``: True when it is the rig's
    exact model; ``fit``: the fit's pixel residuals (``rms_px``, ``max_px``; None when exact);
    ``angular_error_deg``: over the rig's image (every ``step``-th pixel whose exact ray is
    valid), the angle between the exact ray's direction and the model's ray through the same
    pixel (``max``, ``median``; zero to rounding when exact); ``rig``: the rig's name."""

    camera: UnifiedCamera
    exact: bool
    rig: str
    width: int
    height: int
    fit: dict | None = None
    angular_error_deg: dict = field(default_factory=dict)
    pixels: np.ndarray = field(default=None, repr=False)  # the rig's sampled valid pixels (N, 2)

    def summary(self) -> str:
        """One line: exact, or how far the approximation is off."""
        if self.exact:
            return f"rig {self.rig}: central, exported exactly"
        a = self.angular_error_deg
        return (f"rig {self.rig}: no exact model of this form (a non-central rig, or a pinhole tilted off the "
                f"mirror axis); exported through its best central approximation (OpenCV omnidir form, no tilt): "
                f"per-pixel angular error max {a['max']:.4g} deg, "
                f"median {a['median']:.4g} deg; fit rms {self.fit['rms_px']:.4g} px, max {self.fit['max_px']:.4g} px")


def central_model(cam: CatadioptricCamera, *, rig: str = "rig", step: int = 4) -> CentralModel:
    """The central model of ``cam`` for the exports: exact for a central rig whose pinhole looks
    along the mirror axis, else the best central approximation without tilt (fitted on every
    ``step``-th pixel); with the angular error over every ``step``-th pixel."""
    from .centrality import angular_error_map

    if not isinstance(cam, CatadioptricCamera):
        raise CatadioptricError(f"cam: expected a CatadioptricCamera, got {type(cam).__name__}")
    if not (isinstance(step, (int, np.integer)) and step >= 1):
        raise CatadioptricError(f"step: expected a positive integer, got {step!r}")
    u, fit = None, None
    if cam.viewpoint is not None:
        exact = unified_from_central(cam)
        if exact.is_pure:
            u = exact
    if u is None:
        f = fit_unified(cam, step=int(step), tilt=False)
        u, fit = f.camera, {"rms_px": f.rms_px, "max_px": f.max_px, "median_px": f.median_px}
    err, _, exv, _ = angular_error_map(cam, u, int(step))
    e = err[np.isfinite(err)]
    ang = {"max": float(e.max()) if e.size else float("nan"), "median": float(np.median(e)) if e.size else float("nan")}
    uv = cam.pinhole.pixel_grid(int(step)).reshape(-1, 2)
    ok = cam.backproject(uv).valid
    return CentralModel(u, fit is None, rig, cam.pinhole.width, cam.pinhole.height, fit, ang, uv[ok])


def _model(model_or_cam, rig: str) -> CentralModel:
    if isinstance(model_or_cam, CentralModel):
        return model_or_cam
    return central_model(model_or_cam, rig=rig)


def _g(x: float) -> str:
    """A float in 17 significant digits (reads back to the same double)."""
    return repr(float(x))


def _header(m: CentralModel, comment: str, what: str) -> list[str]:
    lines = [f"{comment} catadioptric export ({what}) of rig {m.rig}, {m.width}x{m.height} pixels"]
    lines.append(f"{comment} {m.summary()}")
    return lines


# ------------------------------------------------------------------ OpenCV omnidir
def _cv_matrix(name: str, a) -> list[str]:
    a = np.atleast_2d(np.asarray(a, dtype=float))
    return [f"{name}: !!opencv-matrix", f"   rows: {a.shape[0]}", f"   cols: {a.shape[1]}", "   dt: d",
            "   data: [ " + ", ".join(_g(x) for x in a.reshape(-1)) + " ]"]


def opencv_yaml(model_or_cam, *, rig: str = "rig") -> str:
    """OpenCV FileStorage YAML that ``cv2.FileStorage`` reads straight into ``cv2.omnidir``:
    ``camera_matrix`` (3x3, with skew), ``distortion_coefficients`` (1x4, zero), ``xi`` (1x1),
    ``rvec``/``tvec`` (3x1: ``X_c = R(rvec) X_M + tvec``), ``image_width``, ``image_height``."""
    m = _model(model_or_cam, rig)
    om = m.camera.to_omnidir()
    lines = ["%YAML:1.0", "---"] + _header(m, "#", "OpenCV omnidir, Mei's model; pixels: OpenCV's")
    lines += [f"image_width: {m.width}", f"image_height: {m.height}"]
    lines += _cv_matrix("camera_matrix", om["K"])
    lines += _cv_matrix("distortion_coefficients", [om["D"]])
    lines += _cv_matrix("xi", [[om["xi"]]])
    lines += _cv_matrix("rvec", np.reshape(om["rvec"], (3, 1)))
    lines += _cv_matrix("tvec", np.reshape(om["tvec"], (3, 1)))
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------ Kalibr
def _skew_cost_px(m: CentralModel) -> dict:
    """The pixel shift of dropping the skew: ``|s y|`` over the rig's valid pixels (``y`` the
    normalised coordinate of each pixel, ``(v - cy) / fy``)."""
    K = m.camera.K
    s = float(K[0, 1])
    if s == 0.0 or m.pixels is None or not len(m.pixels):
        return {"max_px": 0.0, "median_px": 0.0}
    y = (m.pixels[:, 1] - K[1, 2]) / K[1, 1]
    d = np.abs(s * y)
    return {"max_px": float(d.max()), "median_px": float(np.median(d))}


def kalibr_parameters(model_or_cam, *, rig: str = "rig") -> dict:
    """Kalibr's ``omni`` intrinsics ``[xi, fu, fv, pu, pv]`` (``fv = -fy > 0``, camera frame
    ``C = diag(1, -1, 1) S``), the ``radtan`` coefficients (zero), the resolution, the rotation
    ``R_cam_from_mirror = diag(1, -1, 1) R_sphere_from_mirror`` (det -1), the viewpoint in M and
    the cost of the dropped skew (``skew_dropped_px``)."""
    m = _model(model_or_cam, rig)
    u = m.camera
    K = u.K
    return {"camera_model": "omni", "intrinsics": [u.xi, float(K[0, 0]), float(-K[1, 1]), float(K[0, 2]),
                                                  float(K[1, 2])],
            "distortion_model": "radtan", "distortion_coeffs": [0.0, 0.0, 0.0, 0.0],
            "resolution": [m.width, m.height], "R_cam_from_mirror": (FLIP_Y @ u.R_sphere_from_mirror).tolist(),
            "viewpoint_M": u.center.tolist(), "skew": float(K[0, 1]), "skew_dropped_px": _skew_cost_px(m)}


def kalibr_camchain(model_or_cam, *, rig: str = "rig", name: str = "cam0", rostopic: str = "/cam0/image_raw") -> str:
    """A Kalibr camchain YAML block (``omni`` + ``radtan``) for one camera (see :func:`kalibr_parameters`)."""
    m = _model(model_or_cam, rig)
    k = kalibr_parameters(m)
    sk = k["skew_dropped_px"]
    lines = _header(m, "#", "Kalibr camchain, omni + radtan")
    lines += ["# camera frame: the unified model's sphere frame with its y axis reversed (a catadioptric image is a",
              "# mirror image; this makes both focal lengths positive): x_cam = R_cam_from_mirror (x_M - viewpoint_M),",
              "# R_cam_from_mirror = " + json.dumps(k["R_cam_from_mirror"]) + " (det -1)",
              "# viewpoint_M = " + json.dumps(k["viewpoint_M"]),
              f"# skew {k['skew']!r} dropped (Kalibr has none): moves pixels by at most {sk['max_px']:.3g} px "
              f"(median {sk['median_px']:.3g} px)"]
    intr = ", ".join(_g(x) for x in k["intrinsics"])
    lines += [f"{name}:", "  camera_model: omni", f"  intrinsics: [{intr}]", "  distortion_model: radtan",
              "  distortion_coeffs: [0.0, 0.0, 0.0, 0.0]", f"  resolution: [{m.width}, {m.height}]",
              f"  rostopic: {rostopic}"]
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------ COLMAP
def colmap_parameters(model_or_cam, *, rig: str = "rig") -> dict:
    """COLMAP's ``EUCM`` parameters ``fx, fy, cx, cy, alpha, beta`` of the model: ``alpha = xi /
    (1 + xi)``, ``beta = 1``, focal lengths divided by ``1 + xi`` (``fy`` sign-flipped: camera
    frame ``diag(1, -1, 1) S``), principal point shifted by +0.5 (COLMAP's pixel centres); the
    dropped skew's cost, and the field of view COLMAP loses (pixels whose ray has ``z <= 0`` in
    the camera frame: ``lost_pixels`` of ``pixels`` sampled, ``lost_fraction``)."""
    m = _model(model_or_cam, rig)
    u = m.camera
    K = u.K
    g = 1.0 + u.xi
    params = [float(K[0, 0]) / g, float(-K[1, 1]) / g, float(K[0, 2]) + 0.5, float(K[1, 2]) + 0.5, u.xi / g, 1.0]
    n = len(m.pixels) if m.pixels is not None else 0
    lost = 0
    if n:
        r = u.backproject(m.pixels)
        zs = (r.directions @ u.R_sphere_from_mirror.T)[:, 2]
        lost = int(np.sum(~r.valid | ~(zs > 0)))
    return {"model": "EUCM", "params": params, "width": m.width, "height": m.height,
            "R_cam_from_mirror": (FLIP_Y @ u.R_sphere_from_mirror).tolist(), "viewpoint_M": u.center.tolist(),
            "skew": float(K[0, 1]), "skew_dropped_px": _skew_cost_px(m), "pixels": n, "lost_pixels": lost,
            "lost_fraction": lost / n if n else 0.0}


def colmap_camera_line(model_or_cam, *, rig: str = "rig", camera_id: int = 1, comments: bool = True) -> str:
    """A line of COLMAP's ``cameras.txt`` (``CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]``), with comment
    lines stating the frame, the dropped skew and the field of view COLMAP loses."""
    m = _model(model_or_cam, rig)
    c = colmap_parameters(m)
    line = f"{int(camera_id)} EUCM {m.width} {m.height} " + " ".join(_g(x) for x in c["params"])
    if not comments:
        return line + "\n"
    sk = c["skew_dropped_px"]
    lines = _header(m, "#", "COLMAP cameras.txt, EUCM with beta = 1: the unified model")
    lines += ["# camera frame: the unified model's sphere frame with its y axis reversed (det -1 in M):",
              "# x_cam = R_cam_from_mirror (x_M - viewpoint_M), R_cam_from_mirror = " + json.dumps(c["R_cam_from_mirror"]),
              "# viewpoint_M = " + json.dumps(c["viewpoint_M"]),
              f"# skew {c['skew']!r} dropped (COLMAP has none): moves pixels by at most {sk['max_px']:.3g} px",
              f"# COLMAP images only points with z > 0 in this frame: {c['lost_pixels']} of {c['pixels']} sampled "
              f"pixels of the rig ({100 * c['lost_fraction']:.3g} %) see directions it cannot image",
              "# CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[] (fx, fy, cx, cy, alpha, beta)"]
    return "\n".join(lines) + "\n" + line + "\n"


# ------------------------------------------------------------------ JSON and dispatch
def export_json(model_or_cam, *, rig: str = "rig") -> dict:
    """Everything at once: the model (``UnifiedCamera.to_dict``), whether it is exact, the
    centrality figures, and the parameters of each tool."""
    m = _model(model_or_cam, rig)
    return {"format": "catadioptric-export/1", "rig": m.rig, "width": m.width, "height": m.height,
            "exact": m.exact, "fit": m.fit, "angular_error_deg": m.angular_error_deg,
            "unified": m.camera.to_dict(), "opencv": m.camera.to_omnidir(), "kalibr": kalibr_parameters(m),
            "colmap": colmap_parameters(m)}


def export_rig(model_or_cam, fmt: str, *, rig: str = "rig") -> str:
    """The text of one export format (``opencv``, ``kalibr``, ``colmap`` or ``json``)."""
    f = _ALIASES.get(fmt, fmt)
    if f not in FORMATS:
        raise CatadioptricError(f"format: expected one of {list(FORMATS)}, got {fmt!r}")
    m = _model(model_or_cam, rig)
    if f == "opencv":
        return opencv_yaml(m)
    if f == "kalibr":
        return kalibr_camchain(m)
    if f == "colmap":
        return colmap_camera_line(m)
    from ._io import jsonable

    return json.dumps(jsonable(export_json(m)), indent=1, allow_nan=False) + "\n"


# ------------------------------------------------------------------ CLI
def _run(args) -> int:
    import os
    import sys

    from ._io import atomic_write_bytes
    from .cliargs import resolve_rig

    cam, _ = resolve_rig(args.rig, width=args.width, height=args.height)
    if args.out is not None:
        if not args.out.strip() or os.path.isdir(args.out):
            raise CatadioptricError(f"--out: expected a file path, got {args.out!r}")
        from .cliargs import check_out_dir

        check_out_dir(os.path.dirname(os.path.abspath(args.out)), "--out")
    m = central_model(cam, rig=args.rig, step=args.step)
    text = export_rig(m, args.format, rig=args.rig)
    if args.out is None:
        sys.stdout.write(text)
    else:
        atomic_write_bytes(args.out, text.encode())
        print(f"wrote {args.out}", file=sys.stderr)
    print(m.summary(), file=sys.stderr)
    return 0


def register(sub) -> None:
    from .cliargs import RIG_HELP, positive_int

    p = sub.add_parser("export", help="a rig's central model for OpenCV omnidir, Kalibr or COLMAP (or JSON)",
                       description="Export a rig's central (unified) model: exactly for a central rig, else its "
                                   "best central approximation, with how far it is off (docs/formats.md, Exports).")
    p.add_argument("--rig", required=True, help=RIG_HELP)
    p.add_argument("--format", required=True, choices=list(FORMATS) + list(_ALIASES),
                   help="opencv (FileStorage YAML for cv2.omnidir), kalibr (camchain), colmap (cameras.txt line), json")
    p.add_argument("--out", metavar="FILE", help="write here (default: standard output)")
    p.add_argument("--width", type=positive_int, help="image width in pixels (default: the rig's)")
    p.add_argument("--height", type=positive_int, help="image height in pixels (default: the rig's)")
    p.add_argument("--step", type=positive_int, default=4,
                   help="pixel stride of the fit and of the error figures (default 4)")
    p.set_defaults(func=_run)
