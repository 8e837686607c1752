"""``catadioptric validate real``: the project on real catadioptric photographs, with numbers.

The folder given (``../shared/real`` in CI and for the committed report, ``validate/real/``) holds
``mei/`` (a paracatadioptric camera calibrated with ``cv2.omnidir``: ``mei_omnidir.yaml``,
images of a fixed camera and a moving chessboard (every image file of the folder,
:data:`IMAGE_SUFFIXES`), ``board_extrinsics.json`` with OpenCV's pose of the board for some of
them (and optionally its ``pattern`` of inner corners and ``square`` in metres; else the board of
``../shared/real``; and the calibration's reprojection ``rms`` in pixels, given to every pose as
``calibration_rms_px`` when the calibration file keeps none), ``masks/`` of the board, made from the extrinsics for an image without one)
and ``ocamcalib/`` (photographs of a room and their OCamCalib ``calib_results.txt``). An image
the detector cannot read is reported, not fatal. The report measures:

* **board axes**: per image with extrinsics, the angle between each of the board's axes
  (``R[:, 0]``, ``R[:, 1]``, OpenCV's extrinsics) and the nearest family direction the detector
  finds with the board's mask (the paper's vanishing points turned into directions, on a real
  camera);
* **static pairs**: every pair of images, no mask: the camera did not move, so the truth is the
  identity (a person and the board move: they are the scene's outliers);
* **board pairs**: pairs of images with extrinsics, with the board's masks: the board's motion
  ``R_j R_i^T`` up to the board's line symmetries (a half-turn about any of its axes maps its
  lines onto themselves: such answers tie, and must come out ``ambiguous`` with each listed);
* **absolute pose** of the board (:func:`catadioptric.pose.chessboard.chessboard_pose`) against
  OpenCV's extrinsics, when that module is present;
* **the OCamCalib room**, per photograph: its three dominant families (most lines) and their pairwise angles (a
  Manhattan room: 90 degrees).

The Mei images' terms are unknown: the overlays written for them draw the detected curves on a
plain background, never the photograph's pixels.
"""
from __future__ import annotations

import json
import os
import time
from itertools import combinations

import numpy as np

from .._checks import CatadioptricError
from ..detect.detector import PRESETS

__all__ = ["run_real", "real_markdown", "board_symmetries", "angle_to_nearest", "register_real", "BOARD_OPTIONS"]

#: the prior of the static pairs' second run: a camera on a tripod turns by at most this (degrees)
STATIC_PRIOR_DEG = 30.0

#: the detector's options for a chessboard (its mask given): the preset ``chessboard``
#: (catadioptric.detect.PRESETS; the report shows the defaults beside them)
BOARD_OPTIONS = PRESETS["chessboard"]

#: the board of ../shared/real/mei (inner corners, square in metres): used when
#: ``board_extrinsics.json`` names no ``pattern`` and ``square`` of its own
BOARD_PATTERN, BOARD_SQUARE = (8, 6), 0.042

#: the image files the report reads from ``mei/`` and ``ocamcalib/`` (by suffix, any case)
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".pgm", ".ppm", ".bmp", ".tif", ".tiff")

#: the board's line symmetries in its own frame: identity and the half-turns about its axes
BOARD_SYMMETRIES = (np.eye(3), np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]), np.diag([-1.0, -1.0, 1.0]))


def _angle_deg(R) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0))))


def board_symmetries(R_i, R_j) -> list[np.ndarray]:
    """The camera-frame motions ``R_j S R_i^T`` of a board between two images, one per line
    symmetry ``S`` of the board (:data:`BOARD_SYMMETRIES`): each maps its lines as the truth does."""
    return [R_j @ S @ R_i.T for S in BOARD_SYMMETRIES]


def angle_to_nearest(R, truths) -> tuple[float, int]:
    """The smallest rotation angle (degrees) from ``R`` to one of ``truths``, and its index."""
    a = [_angle_deg(R @ T.T) for T in truths]
    k = int(np.argmin(a))
    return a[k], k


def _rodrigues(rvec) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_rotvec(np.asarray(rvec, float)).as_matrix()


def _read(path, grey=False):
    import cv2

    img = cv2.imread(path, cv2.IMREAD_GRAYSCALE if grey else cv2.IMREAD_UNCHANGED)
    if img is None:
        raise CatadioptricError(f"--data: {path!r} is not an image OpenCV can read")
    if img.ndim == 3:
        img = np.ascontiguousarray(img[..., [2, 1, 0]])
    return img


def _image_names(folder) -> list[str]:
    """The images of ``folder`` (by suffix, :data:`IMAGE_SUFFIXES`), sorted by name."""
    return sorted(f for f in os.listdir(folder)
                  if f.lower().endswith(IMAGE_SUFFIXES) and os.path.isfile(os.path.join(folder, f)))


def _stem(name: str) -> str:
    return os.path.splitext(name)[0]


def _board_masks(mei, images, views, cam, pattern, square):
    """Each image's board mask: ``masks/<image>`` when given (non-zero: the board; its size must
    be the image's), else for an image with extrinsics the board's outline projected at OpenCV's
    pose (:func:`catadioptric.pose.chessboard.board_mask`, as ``../shared/real``'s masks are
    made). Returns ``(masks, made)``: the masks by image, and the images whose mask was made."""
    from ..pose.chessboard import board_mask

    masks, made = {}, []
    for n, img in images.items():
        mp = os.path.join(mei, "masks", n)
        if os.path.isfile(mp):
            m = _read(mp, grey=True)
            if m.shape != img.shape[:2]:
                raise CatadioptricError(f"--data: mask {mp!r} is {m.shape[1]}x{m.shape[0]}, its image "
                                        f"{img.shape[1]}x{img.shape[0]}")
            masks[n] = m > 0
        elif n in views:
            v = views[n]
            masks[n] = board_mask(cam, _rodrigues(v["rvec"]), v["tvec"], img.shape[:2], pattern, square)
            made.append(n)
    return masks, made


def _curves_only(det, shape, scale: int = 1) -> np.ndarray:
    """The detection drawn on a plain grey background (no pixel of the photograph), with the
    mirror's annulus."""
    import cv2

    from ..detect.overlay import overlay_image

    plain = np.full(shape[:2], 96, np.uint8)
    out = overlay_image(plain, det, scale=scale)
    if det.annulus is not None:
        u0, v0, ri, ro = det.annulus
        for r in (ri, ro):
            if np.isfinite(r):
                cv2.circle(out, (int(round((u0 + 0.5) * scale - 0.5)), int(round((v0 + 0.5) * scale - 0.5))),
                           int(round(r * scale)), (255, 255, 255), 1, cv2.LINE_AA)
    return out


def _pose_row(res, truths, label):
    from ..pose import rotation_angle_deg

    p = res.pose
    err, k = angle_to_nearest(p.R, truths)
    cands = []
    for c in p.candidates[:8]:
        e, kk = angle_to_nearest(np.asarray(c.R, float), truths)
        cands.append({"turn_deg": rotation_angle_deg(np.asarray(c.R, float)), "error_deg": e, "symmetry": kk,
                      "cost": float(c.cost)})
    return {"pair": label, "turn_deg": rotation_angle_deg(p.R), "error_deg": err, "symmetry": k,
            "ambiguous": bool(p.ambiguous), "margin": float(p.margin), "rotation_std_deg": float(p.rotation_std_deg),
            "families": len(res.family_map), "lines_matched": int(p.lines_matched),
            "t": None if p.t is None else np.asarray(p.t, float).tolist(),
            "translation_observable": bool(getattr(p, "translation_observable", True)),
            "lines_seen_again": None if p.turned_in_place is None else len(p.turned_in_place.twins),
            "rival_most": None if p.turned_in_place is None else p.turned_in_place.rival_twins,
            "ambiguous_by": list((p.evidence or {}).get("ambiguous_by", [])),
            "twins": [t["candidate"] for t in (p.evidence or {}).get("twins", [])],
            "candidates": cands, "notes": list(p.notes)}


def run_real(data: str, out: str, *, max_rotation_deg: float | None = None, progress: bool = True) -> dict:
    """Run every measurement of the module docstring on the folder ``data`` and write the
    overlays into ``out``; returns the results (JSON-ready)."""
    from ..detect import detect_lines
    from ..detect.report import write_png
    from ..formats import calibration_rms, load_camera
    from ..pose.twins import flag_twins
    from ..look import settle_by_look
    from ..twoview import pair_overlay, pose_from_detections

    def say(msg):
        if progress:
            print(msg, flush=True)

    mei = os.path.join(data, "mei")
    calib = os.path.join(mei, "mei_omnidir.yaml")
    for p in (calib, os.path.join(mei, "board_extrinsics.json")):
        if not os.path.isfile(p):
            raise CatadioptricError(f"--data: expected {p!r} (a folder laid out as ../shared/real), it is missing")
    cam = load_camera(calib)
    ext = json.load(open(os.path.join(mei, "board_extrinsics.json")))
    views = ext["views"]
    pattern, square = tuple(ext.get("pattern", BOARD_PATTERN)), float(ext.get("square", BOARD_SQUARE))
    # the calibration's reprojection rms (px): the one its file keeps, else board_extrinsics.json's, else 0
    rms = calibration_rms(calib)
    rms = float(ext.get("rms", 0.0)) if rms is None else rms
    names = _image_names(mei)
    if not names:
        raise CatadioptricError(f"--data: expected images ({', '.join(IMAGE_SUFFIXES)}) in {mei!r}, found none")
    os.makedirs(out, exist_ok=True)
    t0 = time.perf_counter()
    images = {n: _read(os.path.join(mei, n), grey=True) for n in names}
    masks, mask_made = _board_masks(mei, images, views, cam, pattern, square)
    dets, dets_board, dets_default, failed = {}, {}, {}, {}
    for n in names:
        say(f"detect {n}")
        try:
            dets[n] = detect_lines(images[n], cam)
            if n in masks:
                dets_default[n] = detect_lines(images[n], cam, mask=masks[n])
                dets_board[n] = detect_lines(images[n], cam, mask=masks[n], **BOARD_OPTIONS)
        except CatadioptricError as exc:  # one image the detector cannot read does not stop the report
            failed[n] = str(exc)
            for d in (dets, dets_default, dets_board):
                d.pop(n, None)
            continue
        write_png(os.path.join(out, f"mei_{_stem(n)}_lines.png"), _curves_only(dets[n], images[n].shape))
        if n in dets_board:
            write_png(os.path.join(out, f"mei_{_stem(n)}_board.png"), _curves_only(dets_board[n], images[n].shape))
    names = [n for n in names if n in dets]
    # 1. the board's axes against the families found with its mask (default options, and the board's)
    axes = []
    for n in names:
        if n not in views or n not in dets_board:
            continue
        R = _rodrigues(views[n]["rvec"])
        for k, axis in ((0, "x (rows)"), (1, "y (columns)")):
            row = {"image": n, "axis": axis}
            for key, det in (("", dets_board[n]), ("default_", dets_default[n])):
                S = np.array([f.direction for f in det.families]).reshape(-1, 3)
                a = np.degrees(np.arccos(np.clip(np.abs(S @ R[:, k]), 0.0, 1.0))) if len(S) else np.array([np.inf])
                j = int(np.argmin(a))
                row |= {f"{key}angle_deg": float(a[j]), f"{key}family": j if len(S) else None,
                        f"{key}family_lines": len(det.families[j].lines) if len(S) else 0, f"{key}families": len(S)}
            axes.append(row)
    # 2. the static camera: every pair, no mask; without a prior and with the prior of a tripod
    static = []
    for a, b in combinations(names, 2):
        for prior in (max_rotation_deg, STATIC_PRIOR_DEG):
            say(f"static pair {a} {b} (prior {prior})")
            try:
                res = pose_from_detections(dets[a], dets[b], max_rotation_deg=prior, calibration_rms_px=rms)
                settle_by_look(res, (images[a], images[b]), (cam, cam))
            except CatadioptricError as exc:
                static.append({"pair": f"{a} {b}", "prior_deg": prior, "failed": str(exc)})
                continue
            static.append(_pose_row(res, [np.eye(3)], f"{a} {b}") | {"prior_deg": prior})
            if prior == max_rotation_deg:
                ov = pair_overlay(np.full_like(images[a], 96), np.full_like(images[b], 96), res)
                static[-1]["overlay"] = f"mei_static_{_stem(a)}_{_stem(b)}.png"
                write_png(os.path.join(out, static[-1]["overlay"]), ov[::2, ::2])
    # 3. the board's motion, with its masks
    board = []
    with_ext = [n for n in names if n in views and n in dets_board]
    for a, b in combinations(with_ext, 2):
        say(f"board pair {a} {b}")
        truths = board_symmetries(_rodrigues(views[a]["rvec"]), _rodrigues(views[b]["rvec"]))
        try:
            res = pose_from_detections(dets_board[a], dets_board[b], max_rotation_deg=max_rotation_deg,
                                       calibration_rms_px=rms)
            flag_twins(res.pose)  # a board's half-turn twins are ties (relative-pose --preset chessboard)
            settle_by_look(res, (images[a], images[b]), (cam, cam), (masks[a], masks[b]))
        except CatadioptricError as exc:
            board.append({"pair": f"{a} {b}", "failed": str(exc)})
            continue
        board.append(_pose_row(res, truths, f"{a} {b}"))
    # 4. the board's absolute pose
    absolute = _absolute(images, masks, views, cam, (pattern, square), say)
    # 5. the OCamCalib room(s)
    rooms = _rooms(os.path.join(data, "ocamcalib"), out, say)
    return {"format": "catadioptric-real-report/1", "data": data, "camera": cam.to_dict(), "calibration_rms_px": rms,
            "max_rotation_deg": max_rotation_deg, "board_axes": axes, "static_pairs": static, "board_pairs": board,
            "absolute_pose": absolute, "ocamcalib_rooms": rooms, "board": {"pattern": list(pattern), "square": square},
            "masks_made": mask_made, "failed_detections": failed,
            "detections": {n: {"lines": len(d), "families": len(d.families), "annulus": list(d.annulus or []),
                               "seconds": d.seconds.get("total")} for n, d in dets.items()},
            "seconds": time.perf_counter() - t0}


def _absolute(images, masks, views, cam, board, say) -> list:
    """The board's pose by each corner detector, refined and as the paper computes it (rotation
    from the two families' directions, translation from the lines), against OpenCV's extrinsics.
    OpenCV's SB corners are the ones its calibration used: through the same model, the refined pose
    reproduces its extrinsics (a check of the model, frame and board conventions, not of accuracy);
    the other detectors' corners and the paper's pose are independent of it."""
    try:
        from ..pose.chessboard import chessboard_pose, compare_board_poses
    except ImportError:
        return []
    rows = []
    for n in sorted(views):
        if n not in images:
            continue
        R_cv = _rodrigues(views[n]["rvec"])
        t_cv = np.asarray(views[n]["tvec"], float)
        for method in ("sb", "classic", "rectified"):
            say(f"absolute pose {n} ({method} corners)")
            try:
                bp = chessboard_pose(images[n], cam, pattern=board[0], square=board[1], mask=masks.get(n),
                                     method=method)
            except CatadioptricError as exc:
                rows.append({"image": n, "corners": method, "failed": str(exc)})
                continue
            row = {"image": n, "corners": method}
            for what, R, t in (("refined", bp.R, bp.t), ("lines", bp.R_lines, bp.t_lines)):
                c = compare_board_poses(R, t, R_cv, t_cv, *board)
                row[what] = {"rotation_error_deg": c["rotation_error_deg"], "symmetry": c["symmetry"],
                             "centre_error_m": c["centre_error_m"], "distance_m": c["centre_distance_m"],
                             "centre_error_rel": c["centre_error_relative"]}
            rows.append(row)
    return rows


def _rooms(folder, out, say) -> list:
    """Each photograph of the OCamCalib folder (its ``calib_results.txt``): its three dominant
    families and their pairwise angles; an overlay per photograph."""
    from ..detect import detect_lines
    from ..detect.overlay import overlay_image
    from ..detect.report import write_png
    from ..formats import load_camera

    calib = os.path.join(folder, "calib_results.txt")
    if not os.path.isfile(calib):
        return []
    cam = load_camera(calib)
    rows = []
    for n in _image_names(folder):
        say(f"detect the OCamCalib photograph {n}")
        img = _read(os.path.join(folder, n))
        try:
            det = detect_lines(img, cam)
        except CatadioptricError as exc:
            rows.append({"image": n, "failed": str(exc)})
            continue
        overlay = f"ocamcalib_{_stem(n)}.png"
        write_png(os.path.join(out, overlay), overlay_image(img, det, scale=1))
        fams = sorted(range(len(det.families)), key=lambda f: -len(det.families[f].lines))[:3]
        S = np.array([det.families[f].direction for f in fams]).reshape(-1, 3)
        pairs = []
        for i, j in combinations(range(len(fams)), 2):
            a = float(np.degrees(np.arccos(np.clip(abs(S[i] @ S[j]), 0.0, 1.0))))
            pairs.append({"families": [fams[i], fams[j]], "angle_deg": a, "off_orthogonal_deg": 90.0 - a})
        rows.append({"image": n, "overlay": overlay,
                     "families": [{"family": f, "lines": len(det.families[f].lines),
                                   "direction": det.families[f].direction.tolist()} for f in fams],
                     "pairs": pairs, "lines": len(det), "all_families": len(det.families),
                     "annulus": list(det.annulus or []), "seconds": det.seconds.get("total")})
    return rows


def _f(x, nd=3):
    return "-" if x is None else (f"{x:.{nd}f}" if isinstance(x, float) and np.isfinite(x) else str(x))


def real_markdown(res: dict, command: str) -> str:
    """The report's Markdown: one table per measurement, the overlays."""
    L = ["# Real catadioptric photographs", "", f"Command: `{command}` ({res['seconds']:.0f} s)", "",
         "Camera: OpenCV omnidir calibration of `mei/` (Mei's model, read by `catadioptric.formats.load_camera`); "
         "directions in omnidir's camera frame. The Mei images are not committed (terms unknown): their overlays "
         "show the detected curves on a plain background, coloured by family, with the mirror's annulus found in "
         "the photograph (white circles).", ""]
    if res.get("calibration_rms_px"):
        L += [f"Every relative pose is given the calibration's reprojection rms, {res['calibration_rms_px']:.3f} px "
              "(the calibration file's `rms`, else `board_extrinsics.json`'s; `relative-pose --calibration-rms`), as "
              "an error each family's direction carries.", ""]
    if res["max_rotation_deg"] is not None:
        L += [f"Prior: the views turn by at most {res['max_rotation_deg']} degrees.", ""]
    if res.get("masks_made"):
        L += [f"Board masks made from OpenCV's extrinsics (no `masks/` file): {', '.join(res['masks_made'])}.", ""]
    for n, why in res.get("failed_detections", {}).items():
        L += [f"Detection failed on {n}: {why}", ""]
    opts = ", ".join(f"{k} {v:g}" for k, v in BOARD_OPTIONS.items())
    L += ["## The board's axes against the families detected with its mask", "",
          f"The board's lines are detected with `{opts}` (`BOARD_OPTIONS`; the board pairs below use these "
          "detections); the detector's defaults beside them.", "",
          f"| image | board axis | angle to the nearest family (deg), {opts} | its lines | families found | "
          "with the defaults (deg) |", "|---|---|---|---|---|---|"]
    L += [f"| {r['image']} | {r['axis']} | {_f(r['angle_deg'])} | {r['family_lines']} | {r['families']} | "
          f"{_f(r.get('default_angle_deg'))} |" for r in res["board_axes"]]
    boards = sorted({r["image"] for r in res["board_axes"]})
    if boards:
        L += ["", "The board's lines, coloured by family, with its families' vanishing points (circles):", ""]
        L += [f"![{_stem(n)} board](mei_{_stem(n)}_board.png)" for n in boards]
    L += ["", "## The static camera (no mask; the truth is the identity)", "",
          "| pair | prior (deg) | turn (deg) | verdict (the matching's margin; what decided) | families / lines matched | "
          "translation | "
          "best candidates: turn (deg) |", "|---|---|---|---|---|---|---|"]
    for r in res["static_pairs"]:
        prior = "none" if r.get("prior_deg") is None else f"{r['prior_deg']:g}"
        if "failed" in r:
            L.append(f"| {r['pair']} | {prior} | failed: {r['failed']} | | | | |")
            continue
        tr = "not observable (no parallax)" if not r["translation_observable"] else (
            "none" if r["t"] is None else "direction " + str(np.round(r["t"], 3).tolist()))
        verdict = ("**ambiguous**" if r["ambiguous"] else "decisive") + f" ({r['margin']:.1f})"
        if r.get("lines_seen_again") is not None:
            verdict += f"; turned in place: {r['lines_seen_again']} lines seen again, rivals {r['rival_most']}"
        cands = ", ".join(f"{c['turn_deg']:.1f}" for c in r["candidates"][:4])
        L.append(f"| {r['pair']} | {prior} | {r['error_deg']:.3f} | {verdict} | {r['families']} / {r['lines_matched']} | "
                 f"{tr} | {cands} |")
    shown = [r for r in res["static_pairs"] if r.get("overlay")]
    if shown:
        L += ["", "Each pair as first in the table (no prior, or `--max-rotation`'s): each family matched across "
                  "the two images in one colour, its vanishing points as rings; lines of no matched family in grey:",
              ""]
        L += [f"![{r['pair']}]({r['overlay']})" for r in shown]
    L += ["", "## The board's motion (board masks; truth `R_j R_i^T` up to the board's line symmetries)", "",
          "A half-turn about any of the board's axes maps its lines onto themselves: an answer whose twin under "
          "such a turn is listed is reported ambiguous (`catadioptric.pose.twins`; `relative-pose --preset "
          "chessboard`), the twins named (candidates counted from 1). Symmetry: 0 identity, 1-3 the half-turns "
          "about the board's x, y, z.", "",
          "| pair | error to the nearest symmetric truth (deg) | which | verdict (margin) | candidates: error (deg) / "
          "symmetry |", "|---|---|---|---|---|"]
    sym = ["identity", "half-turn about x", "half-turn about y", "half-turn about z"]
    for r in res["board_pairs"]:
        if "failed" in r:
            L.append(f"| {r['pair']} | failed: {r['failed']} | | | |")
            continue
        verdict = ("**ambiguous**" if r["ambiguous"] else "decisive") + f" ({r['margin']:.1f})"
        if r.get("twins"):
            verdict += "; the board's twins: candidates " + ", ".join(str(k + 1) for k in r["twins"])
        cands = ", ".join(f"{c['error_deg']:.2f}/{c['symmetry']}" for c in r["candidates"][:4])
        L.append(f"| {r['pair']} | {r['error_deg']:.3f} | {sym[r['symmetry']]} | {verdict} | {cands} |")
    if res["absolute_pose"]:
        L += ["", "## The board's absolute pose against OpenCV's extrinsics", "",
              "OpenCV's SB corners are those its calibration used: refined through the same model, the pose "
              "reproduces its extrinsics (a check of the model and the conventions, not of accuracy). The classic "
              "and rectified detectors' corners, and the paper's pose (rotation from the two families' directions, "
              "translation from the lines, before refinement), are independent of it. Errors up to the board's "
              "symmetries (the symmetry used is named).", "",
              "| image | corners | refined: rotation (deg) | refined: centre | paper's pose: rotation (deg) | "
              "paper's pose: centre | symmetry |", "|---|---|---|---|---|---|---|"]
        for r in res["absolute_pose"]:
            if "failed" in r:
                L.append(f"| {r['image']} | {r['corners']} | failed: {r['failed']} | | | | |")
                continue
            f, g = r["refined"], r["lines"]
            L.append(f"| {r['image']} | {r['corners']} | {f['rotation_error_deg']:.3f} | {100 * f['centre_error_rel']:.2f} % "
                     f"| {g['rotation_error_deg']:.3f} | {100 * g['centre_error_rel']:.2f} % | {f['symmetry']} |")
    for room in res["ocamcalib_rooms"]:
        L += ["", f"## The OCamCalib room ({room['image']}): its three dominant families", ""]
        if "failed" in room:
            L += [f"failed: {room['failed']}"]
            continue
        L += [f"{room['lines']} lines, {room['all_families']} families; the three with most lines:", "",
              "| families | angle (deg) | off orthogonal (deg) |", "|---|---|---|"]
        L += [f"| {p['families'][0]} & {p['families'][1]} | {p['angle_deg']:.2f} | {p['off_orthogonal_deg']:.2f} |"
              for p in room["pairs"]]
        L += ["", f"![{_stem(room['image'])}]({room['overlay']})"]
    L += ["", "## Overlays", ""]
    for n in sorted(res["detections"]):
        L.append(f"![{_stem(n)}](mei_{_stem(n)}_lines.png)")
    return "\n".join(L) + "\n"


def _run(args) -> int:
    import shlex
    import sys

    from ..cliargs import check_out_dir
    from .report import write_report

    out = check_out_dir(args.out)
    if not os.path.isdir(args.data):
        raise CatadioptricError(f"--data: expected a folder of real images laid out as ../shared/real, got {args.data!r}")
    res = run_real(args.data, out, max_rotation_deg=args.max_rotation, progress=not args.no_progress)
    command = getattr(args, "command_line", None) or "catadioptric " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    from .._io import jsonable

    write_report(out, jsonable(res), real_markdown(res, command))
    print(f"wrote {os.path.join(out, 'report.md')}, report.json and the overlays")
    return 0


def register_real(vs) -> None:
    """Add ``validate real`` to the ``validate`` subparsers ``vs``."""
    from ..cliargs import positive_float

    p = vs.add_parser("real", help="vanishing points, families and pose on real catadioptric photographs",
                      description="Detection, the board's axes, the static camera's relative pose, the board's "
                                  "motion and absolute pose, and the OCamCalib room's families, on a folder laid out "
                                  "as ../shared/real (docs/cameras.md, \"How good it is\").")
    p.add_argument("--data", required=True, metavar="DIR", help="the folder of real images (e.g. ../shared/real)")
    p.add_argument("--out", required=True, metavar="DIR", help="report folder (e.g. validate/real)")
    p.add_argument("--max-rotation", type=positive_float, metavar="DEG", help="prior on the pairs' rotation")
    p.add_argument("--no-progress", action="store_true", help="no progress lines")
    p.set_defaults(func=_run, command_line=None)
