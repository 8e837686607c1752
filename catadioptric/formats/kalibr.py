"""Kalibr camchain YAML, both directions: :func:`kalibr_camchain` writes a rig's central model
(``omni`` + ``radtan``); :func:`read_kalibr` reads a camchain's ``omni`` (Mei's model, + ``radtan``
or ``none``), ``eucm`` and ``ds`` (+ ``none``) or ``pinhole`` (+ ``radtan``, ``equidistant`` or
``none``) camera as a central camera of :mod:`catadioptric.models`, in Kalibr's camera frame."""
from __future__ import annotations

import json
import os
import re

import numpy as np

from .._checks import CatadioptricError
from .rigmodel import FLIP_Y, as_export_model, float_text, header_lines, skew_cost_px

__all__ = ["kalibr_parameters", "kalibr_camchain", "read_kalibr", "KALIBR_INTRINSICS", "KALIBR_DISTORTIONS"]


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


# ------------------------------------------------------------------ reader
#: Kalibr's camera models this reader takes, with the names of their intrinsics
KALIBR_INTRINSICS = {"omni": ("xi", "fu", "fv", "pu", "pv"), "eucm": ("alpha", "beta", "fu", "fv", "pu", "pv"),
                     "ds": ("xi", "alpha", "fu", "fv", "pu", "pv"), "pinhole": ("fu", "fv", "pu", "pv")}
#: the distortions each takes (``omni`` + ``equidistant`` is refused: Mei's model here has radtan)
KALIBR_DISTORTIONS = {"omni": ("radtan", "none"), "eucm": ("none",), "ds": ("none",),
                      "pinhole": ("radtan", "equidistant", "none")}
_CAM_KEY = re.compile(r"^cam\d+$")


def _number(v) -> float | None:
    """``v`` as a finite float, or None. A string that reads as a number is one: PyYAML (YAML
    1.1) reads ``1e-05`` (no dot, as Python writes it) as a string."""
    if isinstance(v, bool):
        return None
    if isinstance(v, (int, float)):
        f = float(v)
    elif isinstance(v, str):
        try:
            f = float(v.strip())
        except ValueError:
            return None
    else:
        return None
    return f if np.isfinite(f) else None


def _numbers(block: dict, key: str, where: str, n: int | None, what: str) -> list[float]:
    if key not in block or block[key] is None:
        raise CatadioptricError(f"{where}{key}: missing ({what})")
    v = block[key]
    vals = [_number(x) for x in v] if isinstance(v, (list, tuple)) else None
    if vals is None or any(x is None for x in vals):
        raise CatadioptricError(f"{where}{key}: expected a list of numbers ({what}), got {v!r:.80}")
    if n is not None and len(vals) != n:
        raise CatadioptricError(f"{where}{key}: expected {n} numbers {what}, got {len(vals)}")
    return vals


def _kalibr_camera(path: str, block, prefix: str):
    """The camera of one camchain block (``prefix``: its key path, ``"cam0."`` or ``""``)."""
    from ..models import DoubleSphereCamera, EUCMCamera, KalibrPinholeCamera, MeiCamera

    where = f"{path}: {prefix}"
    if not isinstance(block, dict):
        raise CatadioptricError(f"{path}: {prefix.rstrip('.') or 'the file'}: expected a mapping of camera_model, "
                                f"intrinsics, distortion_model, distortion_coeffs, resolution, got "
                                f"{type(block).__name__}")
    model = block.get("camera_model")
    if model is None:
        raise CatadioptricError(f"{where}camera_model: missing (one of {', '.join(KALIBR_INTRINSICS)})")
    if model not in KALIBR_INTRINSICS:
        raise CatadioptricError(f"{where}camera_model: expected one of {', '.join(KALIBR_INTRINSICS)}, got {model!r}")
    names = KALIBR_INTRINSICS[model]
    intr = _numbers(block, "intrinsics", where, len(names), f"for camera_model {model} ([{', '.join(names)}])")
    dist = block.get("distortion_model")
    if dist is None:
        raise CatadioptricError(f"{where}distortion_model: missing (for camera_model {model}: "
                                f"{' or '.join(KALIBR_DISTORTIONS[model])})")
    if dist not in KALIBR_DISTORTIONS[model]:
        if model == "omni" and dist == "equidistant":
            raise CatadioptricError(f"{where}distortion_model: omni with equidistant is not a model this reader can "
                                    f"express (Mei's model here takes radtan or none)")
        raise CatadioptricError(f"{where}distortion_model: expected {' or '.join(KALIBR_DISTORTIONS[model])} for "
                                f"camera_model {model}, got {dist!r}")
    if dist == "none":
        coeffs = []
        if block.get("distortion_coeffs") is not None:
            coeffs = _numbers(block, "distortion_coeffs", where, None, "none for distortion_model none")
            if any(coeffs):
                raise CatadioptricError(f"{where}distortion_coeffs: expected none (or zeros) for distortion_model "
                                        f"none, got {coeffs}")
        coeffs = []
    else:
        label = "[k1, k2, r1, r2]" if dist == "radtan" else "[k1, k2, k3, k4]"
        coeffs = _numbers(block, "distortion_coeffs", where, 4, f"for distortion_model {dist} ({label})")
    res = block.get("resolution")
    if res is None:
        raise CatadioptricError(f"{where}resolution: missing ([width, height] in pixels)")
    if (not isinstance(res, (list, tuple)) or len(res) != 2
            or not all(isinstance(x, int) and not isinstance(x, bool) and x > 0 for x in res)):
        raise CatadioptricError(f"{where}resolution: expected [width, height], two positive whole numbers of pixels, "
                                f"got {res!r:.80}")
    w, h = res
    try:
        if model == "omni":
            xi, fu, fv, pu, pv = intr
            D = tuple(coeffs) if coeffs else (0.0, 0.0, 0.0, 0.0)
            return MeiCamera(w, h, xi, np.array([[fu, 0.0, pu], [0.0, fv, pv], [0.0, 0.0, 1.0]]), D)
        if model == "eucm":
            return EUCMCamera(w, h, *intr)
        if model == "ds":
            return DoubleSphereCamera(w, h, *intr)
        return KalibrPinholeCamera(w, h, *intr, distortion_model=dist, distortion_coeffs=tuple(coeffs))
    except CatadioptricError as exc:
        raise CatadioptricError(f"{where}intrinsics: {exc}") from None


def read_kalibr(path, camera: str | None = None):
    """The central camera (:mod:`catadioptric.models`) of a Kalibr camchain YAML: ``cam0``,
    ``cam1``, ... each with ``camera_model`` (``omni`` -> :class:`~catadioptric.models.MeiCamera`,
    ``eucm`` -> :class:`~catadioptric.models.EUCMCamera`, ``ds`` ->
    :class:`~catadioptric.models.DoubleSphereCamera`, ``pinhole`` ->
    :class:`~catadioptric.models.KalibrPinholeCamera`), ``intrinsics``, ``distortion_model``
    (``radtan``, ``equidistant`` or ``none``; see :data:`KALIBR_DISTORTIONS`),
    ``distortion_coeffs`` and ``resolution`` ``[width, height]``; or a file holding one camera's
    keys at the top level. ``camera``: which camera of a camchain holding several. Directions are
    in Kalibr's camera frame (x right, y down, z forward), pixels are Kalibr's (OpenCV's: the
    top-left pixel's centre at (0, 0)). Other keys (``T_cn_cnm1``, ``rostopic``, ...) are left
    alone. Errors name the file and the key."""
    import yaml

    path = os.fspath(path)
    try:
        with open(path, encoding="utf-8") as f:
            doc = yaml.safe_load(f)
    except yaml.YAMLError as exc:
        msg = " ".join(str(exc).split())
        raise CatadioptricError(f"{path}: not a YAML file ({msg})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CatadioptricError(f"{path}: cannot be read ({exc})") from None
    if not isinstance(doc, dict):
        raise CatadioptricError(f"{path}: expected a Kalibr camchain (cam0: camera_model, intrinsics, ...), got "
                                f"{type(doc).__name__}")
    if "camera_model" in doc:
        if camera not in (None, "cam0"):
            raise CatadioptricError(f"{path}: camera: the file holds one camera (its keys at the top level), got "
                                    f"{camera!r}")
        return _kalibr_camera(path, doc, "")
    cams = sorted((k for k in doc if isinstance(k, str) and _CAM_KEY.match(k)), key=lambda k: int(k[3:]))
    if not cams:
        raise CatadioptricError(f"{path}: cam0: missing (a Kalibr camchain holds cam0, cam1, ..., each with "
                                f"camera_model, intrinsics, distortion_model, distortion_coeffs, resolution)")
    if camera is None:
        if len(cams) > 1:
            raise CatadioptricError(f"{path}: holds {len(cams)} cameras ({', '.join(cams)}): choose one "
                                    f"(--camera camN, or camera='camN')")
        camera = cams[0]
    elif camera not in cams:
        raise CatadioptricError(f"{path}: {camera}: missing; the camchain holds {', '.join(cams)}")
    return _kalibr_camera(path, doc[camera], f"{camera}.")
