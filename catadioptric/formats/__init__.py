"""The calibration files of the tools people use, one module per tool, each with its reader and
its writer: OpenCV omnidir (:mod:`.opencv`), Kalibr (:mod:`.kalibr`), OCamCalib
(:mod:`.ocamcalib`), COLMAP (:mod:`.colmap`, writer only). :func:`load_camera` reads any of the
readable ones, recognised by content (not by name): each gives a central camera of
:mod:`catadioptric.models` in that tool's own camera frame."""
from __future__ import annotations

import os

from .._checks import CatadioptricError

__all__ = ["load_camera", "calibration_rms", "calibration_format", "CALIBRATION_FORMATS"]

#: the formats :func:`load_camera` reads
CALIBRATION_FORMATS = ("opencv", "kalibr", "ocamcalib")


def _head(path: str, n: int = 65536) -> str:
    with open(path, "rb") as f:
        raw = f.read(n)
    if b"\0" in raw:
        raise CatadioptricError(f"{path}: expected a calibration file (text), got a binary file")
    return raw.decode("utf-8", errors="replace")


def calibration_format(path) -> str | None:
    """``"opencv"``, ``"kalibr"`` or ``"ocamcalib"`` for a file that looks like one (by its
    content), else None."""
    path = os.fspath(path)
    text = _head(path)
    low = text.lower()
    if "<opencv_storage>" in low or text.lstrip().startswith("%YAML") and "camera_matrix" in text:
        return "opencv"
    if "camera_matrix" in text and "xi" in text and "opencv-matrix" in text:
        return "opencv"
    if "camera_model" in text or ("intrinsics" in text and "distortion_coeffs" in text):
        return "kalibr"  # a partial camchain too: its reader names the missing key
    if "cam2world" in low or "world2cam" in low or "polynomial coefficients for the direct mapping" in low:
        return "ocamcalib"
    return None


def load_camera(path, *, camera: str | None = None):
    """The central camera (:mod:`catadioptric.models`) of a calibration file of OpenCV omnidir,
    Kalibr or OCamCalib, recognised by its content. ``camera``: which camera of a Kalibr
    camchain (``"cam0"``, ``"cam1"``, ...; needed when it holds several). Errors name the file
    and what is missing or wrong."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        what = "a folder" if os.path.isdir(path) else "nothing"
        raise CatadioptricError(f"{path}: expected a calibration file, found {what} there")
    fmt = calibration_format(path)
    if fmt is None:
        raise CatadioptricError(f"{path}: not a calibration file of OpenCV omnidir (camera_matrix, xi, ...), Kalibr "
                                f"(cam0: camera_model, intrinsics, ...) or OCamCalib (calib_results.txt)")
    if camera is not None and fmt != "kalibr":
        raise CatadioptricError(f"camera: only a Kalibr camchain holds several cameras, got {camera!r} for the "
                                f"{fmt} file {path}")
    if fmt == "opencv":
        from .opencv import read_opencv

        return read_opencv(path)
    if fmt == "kalibr":
        from .kalibr import read_kalibr

        return read_kalibr(path, camera=camera)
    from .ocamcalib import read_ocamcalib

    return read_ocamcalib(path)


def calibration_rms(path) -> float | None:
    """The reprojection rms (pixels) a calibration file keeps, None when it keeps none: OpenCV's
    ``rms`` (:func:`.opencv.read_opencv_rms`); Kalibr's camchain and OCamCalib's
    ``calib_results.txt`` never hold it (the tools print it). For
    ``relative_pose(..., calibration_rms_px=)``."""
    path = os.fspath(path)
    if os.path.isfile(path) and calibration_format(path) == "opencv":
        from .opencv import read_opencv_rms

        return read_opencv_rms(path)
    return None
