"""COLMAP's camera line (``cameras.txt``, model ``EUCM``): :func:`colmap_camera_line` writes a
rig's central model (COLMAP writes no calibration a user would bring here, so no reader)."""
from __future__ import annotations

import json

import numpy as np

from .rigmodel import FLIP_Y, as_export_model, float_text, header_lines, skew_cost_px

__all__ = ["colmap_parameters", "colmap_camera_line"]


# ------------------------------------------------------------------ writer
def colmap_parameters(model_or_cam, *, rig: str = "rig") -> dict:
    """COLMAP's ``EUCM`` parameters ``fx, fy, cx, cy, alpha, beta`` of the model: ``alpha = xi /
    (1 + xi)``, ``beta = 1``, focal lengths divided by ``1 + xi`` (``fy`` sign-flipped: camera
    frame ``diag(1, -1, 1) S``), principal point shifted by +0.5 (COLMAP's pixel centres); the
    dropped skew's cost, and the field of view COLMAP loses (pixels whose ray has ``z <= 0`` in
    the camera frame: ``lost_pixels`` of ``pixels`` sampled, ``lost_fraction``)."""
    m = as_export_model(model_or_cam, rig)
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
            "skew": float(K[0, 1]), "skew_dropped_px": skew_cost_px(m), "pixels": n, "lost_pixels": lost,
            "lost_fraction": lost / n if n else 0.0}


def colmap_camera_line(model_or_cam, *, rig: str = "rig", camera_id: int = 1, comments: bool = True) -> str:
    """A line of COLMAP's ``cameras.txt`` (``CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]``), with comment
    lines stating the frame, the dropped skew and the field of view COLMAP loses."""
    m = as_export_model(model_or_cam, rig)
    c = colmap_parameters(m)
    line = f"{int(camera_id)} EUCM {m.width} {m.height} " + " ".join(float_text(x) for x in c["params"])
    if not comments:
        return line + "\n"
    sk = c["skew_dropped_px"]
    lines = header_lines(m, "#", "COLMAP cameras.txt, EUCM with beta = 1: the unified model")
    lines += ["# camera frame: the unified model's sphere frame with its y axis reversed (det -1 in M):",
              "# x_cam = R_cam_from_mirror (x_M - viewpoint_M), R_cam_from_mirror = " + json.dumps(c["R_cam_from_mirror"]),
              "# viewpoint_M = " + json.dumps(c["viewpoint_M"]),
              f"# skew {c['skew']!r} dropped (COLMAP has none): moves pixels by at most {sk['max_px']:.3g} px",
              f"# COLMAP images only points with z > 0 in this frame: {c['lost_pixels']} of {c['pixels']} sampled "
              f"pixels of the rig ({100 * c['lost_fraction']:.3g} %) see directions it cannot image",
              "# CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[] (fx, fy, cx, cy, alpha, beta)"]
    return "\n".join(lines) + "\n" + line + "\n"
