"""Central camera models of the tools users calibrate with, one file per model, all with the
same small protocol (:class:`~catadioptric.models.base.CentralCamera`: ``lift`` and
``project_unit``; back-projection, projection, vanishing points and the image region built on
them), so that the detector and the pose take any of them as they take a central rig.

| model | file | tools |
|---|---|---|
| ``mei`` | ``mei.py`` | OpenCV ``cv2.omnidir``; Kalibr ``omni`` + ``radtan`` / ``none`` |
| ``eucm`` | ``eucm.py`` | Kalibr ``eucm`` (extended unified model) + ``none`` |
| ``ds`` | ``double_sphere.py`` | Kalibr ``ds`` (double sphere) + ``none`` |
| ``pinhole`` | ``pinhole.py`` | Kalibr ``pinhole`` + ``radtan`` / ``equidistant`` / ``none`` |
| ``ocamcalib`` | ``scaramuzza.py`` | OCamCalib (Scaramuzza's polynomial model, ``calib_results.txt``) |

:data:`MODELS` maps each name to its class; :func:`model_from_dict` reads ``to_dict()`` back.
Reading the tools' calibration files: :func:`catadioptric.formats.load_camera`.
"""
from __future__ import annotations

from .._checks import CatadioptricError
from .base import CentralCamera, image_size
from .double_sphere import DoubleSphereCamera
from .eucm import EUCMCamera
from .mei import MeiCamera
from .pinhole import KalibrPinholeCamera
from .scaramuzza import ScaramuzzaCamera

__all__ = ["CentralCamera", "MeiCamera", "EUCMCamera", "DoubleSphereCamera", "KalibrPinholeCamera",
           "ScaramuzzaCamera", "MODELS", "model_from_dict", "is_model"]

#: every model by its name (``to_dict()["model"]``)
MODELS = {cls.model: cls for cls in (MeiCamera, EUCMCamera, DoubleSphereCamera, KalibrPinholeCamera,
                                     ScaramuzzaCamera)}


def is_model(cam) -> bool:
    """True for a camera of :mod:`catadioptric.models`."""
    return isinstance(cam, CentralCamera)


def model_from_dict(d: dict) -> CentralCamera:
    """The camera of a ``to_dict()`` dictionary."""
    if not isinstance(d, dict) or d.get("model") not in MODELS:
        got = d.get("model") if isinstance(d, dict) else type(d).__name__
        raise CatadioptricError(f"model: expected one of {sorted(MODELS)}, got {got!r}")
    args = {k: v for k, v in d.items() if k != "model"}
    try:
        return MODELS[d["model"]](**args)
    except TypeError as exc:
        raise CatadioptricError(f"{d['model']}: {exc}") from None
