"""OpenCV's omnidir (Mei's unified model, ``cv2.omnidir``) calibration files, both directions:
:func:`opencv_yaml` writes a rig's central model as ``cv2.FileStorage`` YAML,
:func:`read_opencv` reads a file that ``cv2.FileStorage`` wrote (YAML or XML) as a
:class:`catadioptric.models.MeiCamera` in omnidir's camera frame."""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError
from .rigmodel import as_export_model, float_text, header_lines

__all__ = ["opencv_yaml"]


# ------------------------------------------------------------------ writer
def _cv_matrix(name: str, a) -> list[str]:
    a = np.atleast_2d(np.asarray(a, dtype=float))
    return [f"{name}: !!opencv-matrix", f"   rows: {a.shape[0]}", f"   cols: {a.shape[1]}", "   dt: d",
            "   data: [ " + ", ".join(float_text(x) for x in a.reshape(-1)) + " ]"]


def opencv_yaml(model_or_cam, *, rig: str = "rig") -> str:
    """OpenCV FileStorage YAML that ``cv2.FileStorage`` reads straight into ``cv2.omnidir``:
    ``camera_matrix`` (3x3, with skew), ``distortion_coefficients`` (1x4, zero), ``xi`` (1x1),
    ``rvec``/``tvec`` (3x1: ``X_c = R(rvec) X_M + tvec``), ``image_width``, ``image_height``."""
    m = as_export_model(model_or_cam, rig)
    om = m.camera.to_omnidir()
    lines = ["%YAML:1.0", "---"] + header_lines(m, "#", "OpenCV omnidir, Mei's model; pixels: OpenCV's")
    lines += [f"image_width: {m.width}", f"image_height: {m.height}"]
    lines += _cv_matrix("camera_matrix", om["K"])
    lines += _cv_matrix("distortion_coefficients", [om["D"]])
    lines += _cv_matrix("xi", [[om["xi"]]])
    lines += _cv_matrix("rvec", np.reshape(om["rvec"], (3, 1)))
    lines += _cv_matrix("tvec", np.reshape(om["tvec"], (3, 1)))
    return "\n".join(lines) + "\n"
