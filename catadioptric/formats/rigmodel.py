"""The central model a rig is written through by the exports (:mod:`catadioptric.formats`
writers): exactly for a central rig whose pinhole looks along the mirror axis
(:func:`catadioptric.unified.unified_from_central`), otherwise its best central approximation
without tilt (:func:`catadioptric.unified.fit_unified` with ``tilt=False``, the form OpenCV
omnidir uses), with how far that model is from the rig (the per-pixel angular error between the
rig's exact rays and the model's). Frames and signs: docs/formats.md, "Exports".
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._checks import CatadioptricError
from ..cameras import CatadioptricCamera
from ..unified import UnifiedCamera, fit_unified, unified_from_central

__all__ = ["CentralModel", "central_model", "as_export_model", "float_text", "header_lines", "skew_cost_px", "FLIP_Y"]

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
    from ..centrality import angular_error_map

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


def as_export_model(model_or_cam, rig: str) -> CentralModel:
    if isinstance(model_or_cam, CentralModel):
        return model_or_cam
    return central_model(model_or_cam, rig=rig)


def float_text(x: float) -> str:
    """A float in 17 significant digits (reads back to the same double)."""
    return repr(float(x))


def header_lines(m: CentralModel, comment: str, what: str) -> list[str]:
    lines = [f"{comment} catadioptric export ({what}) of rig {m.rig}, {m.width}x{m.height} pixels"]
    lines.append(f"{comment} {m.summary()}")
    return lines


def skew_cost_px(m: CentralModel) -> dict:
    """The pixel shift of dropping the skew: ``|s y|`` over the rig's valid pixels (``y`` the
    normalised coordinate of each pixel, ``(v - cy) / fy``)."""
    K = m.camera.K
    s = float(K[0, 1])
    if s == 0.0 or m.pixels is None or not len(m.pixels):
        return {"max_px": 0.0, "median_px": 0.0}
    y = (m.pixels[:, 1] - K[1, 2]) / K[1, 1]
    d = np.abs(s * y)
    return {"max_px": float(d.max()), "median_px": float(np.median(d))}
