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

from ._checks import CatadioptricError
from .formats.colmap import colmap_camera_line, colmap_parameters
from .formats.kalibr import kalibr_camchain, kalibr_parameters
from .formats.opencv import opencv_yaml
from .formats.rigmodel import FLIP_Y, CentralModel, as_export_model, central_model

__all__ = ["FORMATS", "CentralModel", "central_model", "opencv_yaml", "kalibr_parameters", "kalibr_camchain",
           "colmap_parameters", "colmap_camera_line", "export_json", "export_rig", "register", "FLIP_Y"]

FORMATS = ("opencv", "kalibr", "colmap", "json")
_ALIASES = {"opencv-yaml": "opencv"}


# ------------------------------------------------------------------ JSON and dispatch
def export_json(model_or_cam, *, rig: str = "rig") -> dict:
    """Everything at once: the model (``UnifiedCamera.to_dict``), whether it is exact, the
    centrality figures, and the parameters of each tool."""
    m = as_export_model(model_or_cam, rig)
    return {"format": "catadioptric-export/1", "rig": m.rig, "width": m.width, "height": m.height,
            "exact": m.exact, "fit": m.fit, "angular_error_deg": m.angular_error_deg,
            "unified": m.camera.to_dict(), "opencv": m.camera.to_omnidir(), "kalibr": kalibr_parameters(m),
            "colmap": colmap_parameters(m)}


def export_rig(model_or_cam, fmt: str, *, rig: str = "rig") -> str:
    """The text of one export format (``opencv``, ``kalibr``, ``colmap`` or ``json``)."""
    f = _ALIASES.get(fmt, fmt)
    if f not in FORMATS:
        raise CatadioptricError(f"format: expected one of {list(FORMATS)}, got {fmt!r}")
    m = as_export_model(model_or_cam, rig)
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

    from .detect.image import check_image_size

    if args.width is not None and args.height is not None:
        check_image_size(args.width, args.height, "--width/--height")
    cam, _ = resolve_rig(args.rig, width=args.width, height=args.height)
    check_image_size(cam.pinhole.width, cam.pinhole.height, "--width/--height")
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
    p.add_argument("--width", type=positive_int, help="image width in pixels (default: the rig's; width x height at "
                                                      "most 4096x4096 pixels in all, docs/detect.md)")
    p.add_argument("--height", type=positive_int, help="image height in pixels (default: the rig's)")
    p.add_argument("--step", type=positive_int, default=4,
                   help="pixel stride of the fit and of the error figures (default 4)")
    p.set_defaults(func=_run)
