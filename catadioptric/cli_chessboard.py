"""The ``catadioptric absolute-pose`` command: a chessboard's pose in one image, its overlay (the
board's axes, a cube, the vanishing points) and its report; the measurement itself is
:mod:`catadioptric.pose.chessboard` (docs/absolute_pose.md)."""
from __future__ import annotations

import os

import numpy as np

from ._checks import CatadioptricError
from .pose.chessboard import (ChessboardPose, chessboard_pose, compare_board_poses, grey8, in_disc, mirror_disc,
                              parse_pattern, project_points)

__all__ = ["register", "overlay", "markdown"]


# =========================================================================== overlay
_COL = {"x": (255, 80, 40), "y": (40, 200, 255), "z": (80, 255, 80), "cube": (255, 230, 0), "corner": (255, 0, 255)}


def _polyline(img, cam, X, colour, thickness=1, disc=None):
    """Draw the image of the 3-D polyline ``X (K, 3)`` (split where a point has no pixel, or
    falls outside the image or the mirror's disc)."""
    import cv2

    uv, ok = project_points(cam, X)
    ok = ok & np.all(np.isfinite(uv), axis=1) & in_disc(uv, disc)
    if hasattr(cam, "in_image"):
        ok &= cam.in_image(uv)
    run = []
    for p, good in zip(uv, ok):
        if good:
            run.append(p)
            continue
        if len(run) > 1:
            cv2.polylines(img, [np.round(np.array(run) * 4).astype(np.int32)], False, colour, thickness,
                          cv2.LINE_AA, shift=2)
        run = []
    if len(run) > 1:
        cv2.polylines(img, [np.round(np.array(run) * 4).astype(np.int32)], False, colour, thickness, cv2.LINE_AA,
                      shift=2)


def _full_line(q, s, n: int = 721):
    """Points whose directions sweep the whole line ``q + tau s`` (tau from -inf to +inf): for a
    central camera at the origin, ``cos(a) q + sin(a) s`` is seen where the line's point is."""
    a = np.linspace(-np.pi / 2, np.pi / 2, n)[1:-1]
    return np.cos(a)[:, None] * q + np.sin(a)[:, None] * s


def overlay(image, cam, pose: ChessboardPose, disc="auto") -> np.ndarray:
    """An RGB picture: the fitted line curves of both families over their whole length (to their
    vanishing points), the vanishing points, the detected corners, the board's axes and a cube
    standing on the board (on the camera's side), all drawn from the pose through the model;
    curves and points are left out beyond the mirror's disc (``disc``: :func:`mirror_disc`'s,
    found in the image with ``"auto"``, or None: the whole image)."""
    import cv2

    if isinstance(disc, str):
        disc = mirror_disc(image, cam)
    g = grey8(image)
    img = np.ascontiguousarray(np.stack([g, g, g], axis=-1))
    R, t = pose.R, pose.t
    cols, rows = pose.pattern
    sq = pose.square
    o = np.asarray(getattr(cam, "viewpoint", np.zeros(3)), float)
    for r in range(rows):
        q = R @ np.array([0.0, r * sq, 0.0]) + t - o
        _polyline(img, cam, _full_line(q, R[:, 0]) + o, _COL["x"], disc=disc)
    for c in range(cols):
        q = R @ np.array([c * sq, 0.0, 0.0]) + t - o
        _polyline(img, cam, _full_line(q, R[:, 1]) + o, _COL["y"], disc=disc)
    # a cube on the board, towards the camera
    side = max(1, (min(cols, rows) - 1) * 3 // 5) * sq
    cam_in_board = R.T @ (o - t)
    zs = 1.0 if cam_in_board[2] > 0 else -1.0
    base = np.array([[0, 0, 0], [side, 0, 0], [side, side, 0], [0, side, 0]], float)
    top = base + [0, 0, zs * side]
    edges = [(base[i], base[(i + 1) % 4]) for i in range(4)] + [(top[i], top[(i + 1) % 4]) for i in range(4)] + \
            [(base[i], top[i]) for i in range(4)]
    for a, b in edges:
        seg = np.linspace(0, 1, 40)[:, None] * (b - a) + a
        _polyline(img, cam, seg @ R.T + t, _COL["cube"], 2)
    for k, name in enumerate("xyz"):
        L = (cols - 1 if k == 0 else rows - 1 if k == 1 else zs * 2) * sq
        seg = np.linspace(0, 1, 40)[:, None] * (np.eye(3)[k] * L)
        _polyline(img, cam, seg @ R.T + t, _COL[name], 3)
    for k, p in enumerate(pose.corners):
        cv2.circle(img, (int(round(p[0] * 4)), int(round(p[1] * 4))), 12 if k else 20, _COL["corner"], 1,
                   cv2.LINE_AA, shift=2)
    for k, name in enumerate("xy"):
        for j, sign in enumerate("+-"):
            p = pose.vanishing_uv[k, j]
            if not (np.all(np.isfinite(p)) and pose.vanishing_in_image[k, j] and in_disc(p[None], disc)[0]):
                continue
            ip = (int(round(p[0])), int(round(p[1])))
            cv2.circle(img, ip, 7, _COL[name], -1, cv2.LINE_AA)
            cv2.circle(img, ip, 7, (0, 0, 0), 1, cv2.LINE_AA)
            cv2.putText(img, f"{sign}{name}", (ip[0] + 9, ip[1] - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.6, _COL[name], 2,
                        cv2.LINE_AA)
    return img


# =========================================================================== report
def _fmt(v, p=4):
    return "[" + ", ".join(f"{x:.{p}f}" for x in np.ravel(v)) + "]"


def markdown(summary: dict, command: str) -> str:
    s = summary
    lines = ["# Absolute pose of a chessboard", "", f"Command: `{command}`", "",
             f"- image: `{s['image']}`, rig: `{s['rig']}`",
             f"- board: {s['pattern'][0]}x{s['pattern'][1]} inner corners, {s['square']} m squares; corners found: "
             f"{s['corners_found']} ({s['detector']})",
             f"- reprojection rms {s['rms_px']:.3f} px (noise estimate {s['sigma_px']:.3f} px)",
             f"- `X_cam = R X_board + t`: t = {_fmt(s['t'])} m, board centre at {np.linalg.norm(s['centre']):.4f} m",
             f"- R = {_fmt(s['R'][0])}, {_fmt(s['R'][1])}, {_fmt(s['R'][2])}",
             f"- standard deviations: rotation {_fmt(s['rotation_std_deg'], 3)} deg (rotation vector, camera frame),"
             f" translation {_fmt(np.array(s['translation_std_m']) * 1000, 2)} mm",
             f"- the paper's pose (rotation from the two families' directions, translation from the lines) is "
             f"{s['lines_pose']['rotation_to_refined_deg']:.3f} deg and "
             f"{s['lines_pose']['translation_to_refined_m'] * 1000:.2f} mm from the refined one", "",
             "| family | lines | direction (camera frame) | line rms (px) | board axis to family (deg) |",
             "|---|---|---|---|---|"]
    for f in s["families"]:
        lines.append(f"| {f['name']} | {f['lines']} | {_fmt(f['direction'])} | {f['line_rms_px']:.3f} | "
                     f"{f['axis_angle_deg']:.3f} |")
    disc = s.get("mirror_disc")
    lines += ["", "| vanishing point | pixel | in image | inside the mirror's disc |", "|---|---|---|---|"]
    for v in s["vanishing_points"]:
        uv = "none" if v["uv"] is None else _fmt(v["uv"], 1)
        inside = {None: "?", True: "yes", False: "no"}[v.get("in_mirror")]
        lines.append(f"| {v['sign']}{v['family'][0]} | {uv} | {'yes' if v['in_image'] else 'no'} | {inside} |")
    lines.append("")
    lines.append("The calibration's formula holds beyond the mirror's rim: " + (
        f"the mirror's disc seen in the image is centred at ({disc['centre'][0]:.1f}, {disc['centre'][1]:.1f}) "
        f"with radius {disc['radius']:.1f} px (the overlay draws inside it)." if disc is not None else
        "no mirror rim was found in the image (the overlay draws over the whole image)."))
    ref = s.get("reference")
    if ref:
        lines += ["", f"Against the reference `{ref['file']}` ({ref['view']}), up to the board's symmetries:", "",
                  "| pose | symmetry | rotation error (deg) | centre error (mm) | centre error / distance |",
                  "|---|---|---|---|---|"]
        for name, c in (("refined", ref["refined"]), ("lines (paper)", ref["lines"])):
            lines.append(f"| {name} | {c['symmetry']} | {c['rotation_error_deg']:.3f} | "
                         f"{c['centre_error_m'] * 1000:.2f} | {100 * c['centre_error_relative']:.3f} % |")
    lines += ["", "![overlay](overlay.png)", ""]
    return "\n".join(lines)


def _reference(path: str, image_path: str):
    """``(R, t, view name)`` from a reference file: ``{"views": {name: {"rvec", "tvec"} | {"R", "t"}}}`` (the
    image's file name picks the view) or one ``{"rvec", "tvec"}`` / ``{"R", "t"}``."""
    import json

    try:
        with open(path) as f:
            data = json.load(f)
    except (OSError, ValueError) as exc:
        raise CatadioptricError(f"--reference: {path!r} is not a readable JSON file ({exc})") from None
    name = None
    if isinstance(data, dict) and isinstance(data.get("views"), dict):
        name = os.path.basename(image_path)
        if name not in data["views"]:
            raise CatadioptricError(f"--reference: {path!r} has no view {name!r} (it has "
                                    f"{', '.join(sorted(data['views']))})")
        data = data["views"][name]
    try:
        if "R" in data:
            R, t = np.asarray(data["R"], float).reshape(3, 3), np.asarray(data["t"], float).reshape(3)
        else:
            from scipy.spatial.transform import Rotation

            R = Rotation.from_rotvec(np.asarray(data["rvec"], float).reshape(3)).as_matrix()
            t = np.asarray(data["tvec"], float).reshape(3)
    except (KeyError, TypeError, ValueError) as exc:
        raise CatadioptricError(f"--reference: {path!r}: expected rvec and tvec (or R and t), got none ({exc})") \
            from None
    return R, t, name or "the file's pose"


# =========================================================================== command
def _camera(value: str, image):
    """The camera of ``--rig`` (a rig name or spec, or a calibration file of OpenCV omnidir, Kalibr or
    OCamCalib: :func:`catadioptric.cliargs.resolve_rig`), of the image's size."""
    from .cliargs import resolve_rig

    h, w = image.shape[:2]
    cam, _ = resolve_rig(value, width=w, height=h, flag="--rig", calibrations=True)
    if (cam.width, cam.height) != (w, h):
        raise CatadioptricError(f"--rig: the camera is of {cam.width}x{cam.height} images, got an image of {w}x{h}")
    return cam


def _run(args) -> int:
    import shlex
    import sys

    from ._io import atomic_write_bytes, atomic_write_json, jsonable
    from .cliargs import check_out_dir
    from .detect.cli import read_image
    from .detect.report import write_png

    check_out_dir(args.out)
    try:
        pattern = parse_pattern(args.chessboard)
    except CatadioptricError as exc:
        raise CatadioptricError(f"--chessboard: {str(exc).split(': ', 1)[1]}") from None
    image = read_image(args.image)
    cam = _camera(args.rig, image)
    mask = None
    if args.mask is not None:
        if not os.path.isfile(args.mask):
            raise CatadioptricError(f"--mask: expected a mask image, got {args.mask!r}, which does not exist")
        mask = read_image(args.mask)
        if mask.shape[:2] != image.shape[:2]:
            raise CatadioptricError(f"--mask: expected the image's size {image.shape[1]}x{image.shape[0]}, got "
                                    f"{mask.shape[1]}x{mask.shape[0]}")
    try:
        pose = chessboard_pose(image, cam, pattern, args.square, mask=mask, method=args.detector)
    except CatadioptricError as exc:
        msg = str(exc)
        raise CatadioptricError(msg if msg.startswith(("--", "image:")) else f"pose: {msg}") from None
    summary = {"image": os.path.abspath(args.image), "rig": args.rig, "mask": args.mask, **pose.to_dict()}
    if args.reference is not None:
        Rr, tr, view = _reference(args.reference, args.image)
        summary["reference"] = {
            "file": args.reference, "view": view,
            "refined": compare_board_poses(pose.R, pose.t, Rr, tr, pattern, pose.square),
            "lines": compare_board_poses(pose.R_lines, pose.t_lines, Rr, tr, pattern, pose.square)}
    disc = mirror_disc(image, cam)
    summary["mirror_disc"] = None if disc is None else {"centre": [disc[0], disc[1]], "radius": disc[3]}
    for v in summary["vanishing_points"]:
        v["in_mirror"] = None if disc is None or v["uv"] is None else bool(in_disc(np.array([v["uv"]]), disc)[0])
    os.makedirs(args.out, exist_ok=True)
    atomic_write_json(os.path.join(args.out, "pose.json"), jsonable(summary))
    write_png(os.path.join(args.out, "overlay.png"), overlay(image, cam, pose, disc=disc))
    command = getattr(args, "command_line", None) or "catadioptric " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    atomic_write_bytes(os.path.join(args.out, "report.md"), markdown(summary, command).encode())
    ref = summary.get("reference")
    cmp = "" if not ref else (f"; against the reference: {ref['refined']['rotation_error_deg']:.3f} deg "
                              f"({ref['refined']['symmetry']}), centre {100 * ref['refined']['centre_error_relative']:.2f} "
                              f"% of its distance")
    print(f"{len(pose.corners)} corners ({pose.detector}), rms {pose.rms_px:.3f} px; board centre at "
          f"{np.linalg.norm(pose.centre):.3f} m, rotation std {np.max(pose.rotation_std_deg):.3f} deg{cmp}; "
          f"wrote {os.path.join(args.out, 'pose.json')}, overlay.png, report.md")
    return 0


def register(sub) -> None:
    from .cliargs import CALIBRATION_RIG_HELP, positive_float

    p = sub.add_parser("absolute-pose", help="the pose of a chessboard in one image (the paper's Sec. 5.3)",
                       description="Find a chessboard's inner corners, fit its two families of lines through the "
                                   "camera model (their vanishing points and directions) and compute the board's "
                                   "pose X_cam = R X_board + t (board frame: OpenCV's), refined on the corners, "
                                   "with its covariance. Writes pose.json, overlay.png and report.md into --out "
                                   "(docs/absolute_pose.md).")
    p.add_argument("image", metavar="IMAGE", help="the image (PNG, JPEG, TIFF, .npy)")
    p.add_argument("--rig", required=True, metavar="CALIB", help=CALIBRATION_RIG_HELP)
    p.add_argument("--chessboard", required=True, metavar="COLSxROWS",
                   help="inner corners along a row and along a column, e.g. 8x6")
    p.add_argument("--square", required=True, type=positive_float, metavar="METRES", help="the squares' side")
    p.add_argument("--mask", metavar="PNG", help="non-zero where the board may be (the image's size)")
    p.add_argument("--detector", choices=["auto", "sb", "classic", "rectified"], default="auto",
                   help="how to find the corners (default auto: OpenCV's SB detector, then the classic one, then "
                        "the SB detector on perspective views rendered through the model)")
    p.add_argument("--reference", metavar="JSON",
                   help="a pose to compare with: {'rvec', 'tvec'} or {'R', 't'}, or {'views': {IMAGE_NAME: ...}} as "
                        "board_extrinsics.json (rotation error up to the board's symmetries, centre error)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.set_defaults(func=_run, command_line=None)
