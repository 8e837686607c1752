"""Kalibr camchain YAML, both directions: :func:`kalibr_camchain` writes a rig's central model
(``omni`` + ``radtan``); the reader takes a camchain of ``omni``, ``eucm``, ``ds`` or ``pinhole``
cameras."""
from __future__ import annotations

import json

import numpy as np

from .rigmodel import FLIP_Y, as_export_model, float_text, header_lines, skew_cost_px

__all__ = ["kalibr_parameters", "kalibr_camchain"]


# ------------------------------------------------------------------ writer
def kalibr_parameters(model_or_cam, *, rig: str = "rig") -> dict:
    """Kalibr's ``omni`` intrinsics ``[xi, fu, fv, pu, pv]`` (``fv = -fy > 0``, camera frame
    ``C = diag(1, -1, 1) S``), the ``radtan`` coefficients (zero), the resolution, the rotation
    ``R_cam_from_mirror = diag(1, -1, 1) R_sphere_from_mirror`` (det -1), the viewpoint in M and
    the cost of the dropped skew (``skew_dropped_px``)."""
    m = as_export_model(model_or_cam, rig)
    u = m.camera
    K = u.K
    return {"camera_model": "omni", "intrinsics": [u.xi, float(K[0, 0]), float(-K[1, 1]), float(K[0, 2]),
                                                  float(K[1, 2])],
            "distortion_model": "radtan", "distortion_coeffs": [0.0, 0.0, 0.0, 0.0],
            "resolution": [m.width, m.height], "R_cam_from_mirror": (FLIP_Y @ u.R_sphere_from_mirror).tolist(),
            "viewpoint_M": u.center.tolist(), "skew": float(K[0, 1]), "skew_dropped_px": skew_cost_px(m)}


def kalibr_camchain(model_or_cam, *, rig: str = "rig", name: str = "cam0", rostopic: str = "/cam0/image_raw") -> str:
    """A Kalibr camchain YAML block (``omni`` + ``radtan``) for one camera (see :func:`kalibr_parameters`)."""
    m = as_export_model(model_or_cam, rig)
    k = kalibr_parameters(m)
    sk = k["skew_dropped_px"]
    lines = header_lines(m, "#", "Kalibr camchain, omni + radtan")
    lines += ["# camera frame: the unified model's sphere frame with its y axis reversed (a catadioptric image is a",
              "# mirror image; this makes both focal lengths positive): x_cam = R_cam_from_mirror (x_M - viewpoint_M),",
              "# R_cam_from_mirror = " + json.dumps(k["R_cam_from_mirror"]) + " (det -1)",
              "# viewpoint_M = " + json.dumps(k["viewpoint_M"]),
              f"# skew {k['skew']!r} dropped (Kalibr has none): moves pixels by at most {sk['max_px']:.3g} px "
              f"(median {sk['median_px']:.3g} px)"]
    intr = ", ".join(float_text(x) for x in k["intrinsics"])
    lines += [f"{name}:", "  camera_model: omni", f"  intrinsics: [{intr}]", "  distortion_model: radtan",
              "  distortion_coeffs: [0.0, 0.0, 0.0, 0.0]", f"  resolution: [{m.width}, {m.height}]",
              f"  rostopic: {rostopic}"]
    return "\n".join(lines) + "\n"
