"""OpenCV's omnidir (Mei's unified model, ``cv2.omnidir``) calibration files, both directions:
:func:`opencv_yaml` writes a rig's central model as ``cv2.FileStorage`` YAML,
:func:`read_opencv` reads a file that ``cv2.FileStorage`` wrote (YAML or XML) as a
:class:`catadioptric.models.MeiCamera` in omnidir's camera frame."""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError
from .rigmodel import as_export_model, float_text, header_lines

__all__ = ["opencv_yaml", "read_opencv", "read_opencv_rms", "OPENCV_KEYS"]


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


# ------------------------------------------------------------------ reader
#: what a calibration of ``cv2.omnidir`` holds (``cv2.FileStorage`` keys)
OPENCV_KEYS = ("camera_matrix", "xi", "distortion_coefficients", "image_width", "image_height")


def _node_values(fs, key: str, path: str) -> np.ndarray:
    node = fs.getNode(key)
    if node.empty() or node.isNone():
        raise CatadioptricError(f"{path}: {key}: missing (an OpenCV omnidir calibration holds {', '.join(OPENCV_KEYS)})")
    if node.isReal() or node.isInt():
        return np.array([node.real()], float)
    m = node.mat()
    if m is None:
        raise CatadioptricError(f"{path}: {key}: expected a number or an opencv-matrix, got {node.type()!r}")
    return np.asarray(m, float).reshape(-1)


def read_opencv(path: str):
    """The :class:`catadioptric.models.MeiCamera` of an OpenCV omnidir calibration file as
    ``cv2.FileStorage`` writes it (YAML or XML): ``camera_matrix`` (3x3, skew kept), ``xi``,
    ``distortion_coefficients`` (k1, k2, p1, p2), ``image_width``, ``image_height``. Directions
    are in omnidir's camera frame (the frame of its ``rvec``/``tvec``). Other keys (the
    ``rvec``/``tvec`` of :func:`opencv_yaml`, a calibration's own extrinsics) are not the
    camera's and are left alone."""
    import cv2

    from ..models import MeiCamera

    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    try:
        if not fs.isOpened():
            raise CatadioptricError(f"{path}: not a file cv2.FileStorage can read")
        K = _node_values(fs, "camera_matrix", path)
        if K.size != 9:
            raise CatadioptricError(f"{path}: camera_matrix: expected 3x3 numbers, got {K.size}")
        xi = _node_values(fs, "xi", path)
        if xi.size != 1:
            raise CatadioptricError(f"{path}: xi: expected one number, got {xi.size}")
        D = _node_values(fs, "distortion_coefficients", path)
        if D.size != 4:
            raise CatadioptricError(f"{path}: distortion_coefficients: expected 4 numbers (k1, k2, p1, p2), "
                                    f"got {D.size}")
        size = [_node_values(fs, k, path) for k in ("image_width", "image_height")]
    finally:
        fs.release()
    try:
        return MeiCamera(size[0][0], size[1][0], float(xi[0]), K.reshape(3, 3), tuple(D))
    except CatadioptricError as exc:
        raise CatadioptricError(f"{path}: {exc}") from None


def read_opencv_rms(path: str) -> float | None:
    """The calibration's reprojection rms in pixels, when the file keeps it as a number ``rms``
    (OpenCV's own omnidir sample, ``omni_calibration``, writes the rms that ``cv2.omnidir.calibrate``
    returns under that key); None when it does not. A negative or non-finite ``rms`` is an error
    naming the file."""
    import cv2

    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    try:
        if not fs.isOpened():
            raise CatadioptricError(f"{path}: not a file cv2.FileStorage can read")
        node = fs.getNode("rms")
        if node.empty() or node.isNone():
            return None
        if not (node.isReal() or node.isInt()):
            raise CatadioptricError(f"{path}: rms: expected a number of pixels, got a node of type {node.type()}")
        rms = float(node.real())
    finally:
        fs.release()
    if not np.isfinite(rms) or rms < 0:
        raise CatadioptricError(f"{path}: rms: expected a non-negative number of pixels, got {rms}")
    return rms
