"""Absolute pose of a chessboard seen by a central catadioptric camera: the paper's real
experiment (Sec. 5.3), with a number instead of a drawn cube.

The corners come from OpenCV's chessboard detector. Each row and each column of inner corners
is a 3-D line; through a central camera the rays of its corners lie in one plane through the
viewpoint (its interpretation plane). The planes of one family share the family's direction
(their common null direction: the paper's vanishing point turned into a direction). The board's
rotation follows from the two directions (x: the rows, y: the columns, signs from the corner
order), its translation from the lines of known position on the board (linear in ``t`` given
``R``, the paper's Pluecker constraint: :func:`catadioptric.pose.translation_from_lines`);
``R, t`` are then refined together on the corners' pixel residuals, and their covariance comes
from the Jacobian and the residuals' variance.

Conventions: ``X_cam = R X_board + t`` in the camera model's frame (for an OpenCV omnidir
calibration, the frame of ``cv2.omnidir``'s ``rvec``/``tvec``); the board frame is OpenCV's:
origin at the first inner corner, x along a row of ``cols`` corners, y along a column of
``rows`` corners, z = x cross y, the given square size. ``cov`` (6x6): the left rotation vector
``w`` (``R = exp([w]_x) R_hat``, camera frame, radians), then ``t`` (metres).

Any camera with ``backproject``, ``project``, ``vanishing_points``, ``width``, ``height`` and
a single viewpoint (``is_central``) works: the models of :mod:`catadioptric.models` (OpenCV,
Kalibr, OCamCalib calibrations) and the central rigs.

The command, its overlay and report: :mod:`catadioptric.cli_chessboard` (``catadioptric absolute-pose
IMAGE --rig CALIB --chessboard COLSxROWS --square M --out DIR``; docs/absolute_pose.md).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from .._checks import CatadioptricError
from .._numeric import LUMA

__all__ = ["ChessboardPose", "chessboard_pose", "find_chessboard_corners", "parse_pattern", "compare_board_poses",
           "board_mask",
           "board_symmetries", "board_points", "board_centre", "grey8", "project_points", "mirror_disc", "in_disc"]


# =========================================================================== result
@dataclass
class ChessboardPose:
    """The board's pose and what it was computed from (module docstring for the conventions).

    ``R (3, 3)``, ``t (3,)``: ``X_cam = R X_board + t`` after the joint refinement; ``cov (6, 6)``
    of ``(w, t)``; ``R_lines``, ``t_lines``, ``cov_rotation_lines (3, 3)``: the paper's pose
    (rotation from the two family directions, translation from the lines), before refinement.
    ``corners (N, 2)``: the detected corners in the board's order (``k = row * cols + col``),
    ``board_points (N, 3)`` their board coordinates; ``residuals_px (N,)`` their reprojection
    error, ``rms_px`` its rms, ``sigma_px`` the noise estimated from it (2N - 6 degrees of
    freedom). ``directions (2, 3)``: the fitted directions of the x (rows) and y (columns)
    families, oriented as the board's axes, ``direction_covs (2, 3, 3)``; ``line_rms_px``:
    the rms distance of the corners to their lines' fitted curves (first order), per family;
    ``vanishing_uv (2, 2, 2)``: the vanishing points of ``+s`` and ``-s`` of each family
    (NaN where none), ``vanishing_in_image (2, 2)``; ``axis_family_deg (2,)``: the angle of
    ``R[:, 0]``, ``R[:, 1]`` to their family's direction; ``detector``: how the corners were found.
    """

    R: np.ndarray
    t: np.ndarray
    cov: np.ndarray
    R_lines: np.ndarray
    t_lines: np.ndarray
    cov_rotation_lines: np.ndarray
    corners: np.ndarray
    board_points: np.ndarray
    residuals_px: np.ndarray
    rms_px: float
    sigma_px: float
    directions: np.ndarray
    direction_covs: np.ndarray
    line_rms_px: np.ndarray
    vanishing_uv: np.ndarray
    vanishing_in_image: np.ndarray
    axis_family_deg: np.ndarray
    pattern: tuple
    square: float
    detector: str
    iterations: int = 0
    extra: dict = field(default_factory=dict)

    @property
    def centre(self) -> np.ndarray:
        """The board's centre (the middle of its inner corners) in the camera frame."""
        return self.R @ board_centre(self.pattern, self.square) + self.t

    @property
    def rotation_std_deg(self) -> np.ndarray:
        """Standard deviations of the rotation vector's components (camera frame), degrees."""
        return np.degrees(np.sqrt(np.maximum(np.diag(self.cov)[:3], 0.0)))

    @property
    def translation_std_m(self) -> np.ndarray:
        """Standard deviations of ``t``'s components, metres."""
        return np.sqrt(np.maximum(np.diag(self.cov)[3:], 0.0))

    def to_dict(self) -> dict:
        from .rotation import rotation_angle_deg

        vp = []
        for k, name in enumerate(("x", "y")):
            for j, sign in enumerate(("+", "-")):
                uv = self.vanishing_uv[k, j]
                vp.append({"family": name, "sign": sign, "uv": None if not np.all(np.isfinite(uv)) else uv.tolist(),
                           "in_image": bool(self.vanishing_in_image[k, j])})
        return {
            "R": self.R.tolist(), "t": self.t.tolist(), "cov": self.cov.tolist(),
            "rotation_std_deg": self.rotation_std_deg.tolist(), "translation_std_m": self.translation_std_m.tolist(),
            "centre": self.centre.tolist(), "distance_m": float(np.linalg.norm(self.centre)),
            "pattern": list(self.pattern), "square": self.square, "detector": self.detector,
            "corners_found": int(len(self.corners)), "corners": self.corners.tolist(),
            "rms_px": self.rms_px, "sigma_px": self.sigma_px, "residuals_px": self.residuals_px.tolist(),
            "families": [
                {"name": name, "axis": f"R[:, {k}]", "direction": self.directions[k].tolist(),
                 "direction_cov": self.direction_covs[k].tolist(), "line_rms_px": float(self.line_rms_px[k]),
                 "axis_angle_deg": float(self.axis_family_deg[k]),
                 "lines": int(self.pattern[1] if k == 0 else self.pattern[0])}
                for k, name in enumerate(("x (rows)", "y (columns)"))],
            "vanishing_points": vp,
            "lines_pose": {"R": self.R_lines.tolist(), "t": self.t_lines.tolist(),
                           "cov_rotation": self.cov_rotation_lines.tolist(),
                           "rotation_to_refined_deg": rotation_angle_deg(self.R @ self.R_lines.T),
                           "translation_to_refined_m": float(np.linalg.norm(self.t - self.t_lines))},
            "iterations": self.iterations,
            **self.extra,
        }


# =========================================================================== the board
def parse_pattern(value) -> tuple[int, int]:
    """``"8x6"`` (or ``(8, 6)``) -> ``(cols, rows)`` of inner corners, at least 3 along each side (a
    line's plane needs 3 corners to have a residual)."""
    if isinstance(value, str):
        m = re.fullmatch(r"\s*(\d+)\s*[xX*,]\s*(\d+)\s*", value)
        if m is None:
            raise CatadioptricError(f"pattern: expected COLSxROWS (inner corners, e.g. 8x6), got {value!r}")
        cols, rows = int(m.group(1)), int(m.group(2))
    else:
        try:
            cols, rows = (int(v) for v in value)
        except (TypeError, ValueError):
            raise CatadioptricError(f"pattern: expected (cols, rows) of inner corners, got {value!r}") from None
    if cols < 3 or rows < 3:
        raise CatadioptricError(f"pattern: expected at least 3 inner corners along each side (COLSxROWS), got "
                                f"{cols}x{rows}")
    return cols, rows


def board_points(pattern, square: float) -> np.ndarray:
    """Board coordinates ``(cols * rows, 3)`` of the inner corners in OpenCV's order."""
    cols, rows = pattern
    c, r = np.meshgrid(np.arange(cols, dtype=float), np.arange(rows, dtype=float))
    return np.stack([c.ravel() * square, r.ravel() * square, np.zeros(cols * rows)], axis=-1)


def board_centre(pattern, square: float) -> np.ndarray:
    cols, rows = pattern
    return np.array([(cols - 1) * square / 2, (rows - 1) * square / 2, 0.0])


def board_mask(cam, R, t, shape, pattern, square: float, *, margin_px: int = 12, samples: int = 64) -> np.ndarray:
    """The board's image as a mask ``(H, W)`` bool (``shape``: the image's ``(H, W)``): the outline of
    its squares (one square beyond the inner corners on every side, ``pattern + 1`` squares) at the
    pose ``X_cam = R X_board + t``, each side sampled at ``samples`` points (a side's image is a
    curve), projected through ``cam``, filled and dilated by ``margin_px`` pixels (a square of side
    ``2 margin_px + 1``, as OpenCV's dilation repeated with its 3x3 kernel). The board masks of
    ``../shared/real/mei`` are made so (tests/test_chessboard_mask.py)."""
    import cv2

    cols, rows = pattern
    x0, x1, y0, y1 = -square, cols * square, -square, rows * square
    s = np.linspace(0.0, 1.0, samples, endpoint=False)
    outline = np.concatenate([np.stack([x0 + (x1 - x0) * s, np.full_like(s, y0)], 1),
                              np.stack([np.full_like(s, x1), y0 + (y1 - y0) * s], 1),
                              np.stack([x1 - (x1 - x0) * s, np.full_like(s, y1)], 1),
                              np.stack([np.full_like(s, x0), y1 - (y1 - y0) * s], 1)])
    X = np.concatenate([outline, np.zeros((len(outline), 1))], 1) @ np.asarray(R, float).T + np.asarray(t, float)
    uv, ok = project_points(cam, X)
    if not ok.all():
        raise CatadioptricError(f"board_mask: {int(np.sum(~ok))} of the board outline's {len(ok)} points do not "
                                "project into the image at this pose")
    m = np.zeros(tuple(shape)[:2], np.uint8)
    cv2.fillPoly(m, [np.round(uv * 16).astype(np.int32)], 255, lineType=cv2.LINE_8, shift=4)
    if margin_px > 0:
        k = cv2.getStructuringElement(cv2.MORPH_RECT, (2 * margin_px + 1, 2 * margin_px + 1))
        m = cv2.dilate(m, k)
    return m > 0


def board_symmetries(pattern) -> list[tuple[str, np.ndarray]]:
    """The turns about the board's centre that map its grid of inner corners onto itself (the
    orderings a detector may pick): the identity and the 180-degree turns about z, x and y (the
    last two show the board from behind: a detector that only sees the front picks the first
    two); for a square grid also the 90-degree turns about z (and their flips)."""
    out = [("identity", np.eye(3)), ("180 about z", np.diag([-1.0, -1.0, 1.0])),
           ("180 about x", np.diag([1.0, -1.0, -1.0])), ("180 about y", np.diag([-1.0, 1.0, -1.0]))]
    if pattern[0] == pattern[1]:
        Rz = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
        more = []
        for name, S in out:
            more.append((f"90 about z then {name}", S @ Rz))
            more.append((f"-90 about z then {name}", S @ Rz.T))
        out += more
    return out


def compare_board_poses(R, t, R_ref, t_ref, pattern, square: float) -> dict:
    """A board pose against a reference, up to the board's symmetries (:func:`board_symmetries`):
    the symmetry that brings the rotations closest, the rotation error (degrees), the error of
    the board centre's position (metres, and relative to its distance), and the angle of each
    of the board's axes ``R[:, k]`` to the reference's nearest axis (sign-free)."""
    from .rotation import rotation_angle_deg

    R, t, R_ref, t_ref = (np.asarray(v, float) for v in (R, t, R_ref, t_ref))
    c0 = board_centre(pattern, square)
    best = None
    for name, S in board_symmetries(pattern):
        Rs = R_ref @ S
        err = rotation_angle_deg(R @ Rs.T)
        if best is None or err < best[1]:
            best = (name, err, Rs, t_ref + R_ref @ c0 - Rs @ c0)
    name, err, Rs, ts = best
    centre, centre_ref = R @ c0 + t, R_ref @ c0 + t_ref
    dist = float(np.linalg.norm(centre_ref))
    cerr = float(np.linalg.norm(centre - centre_ref))
    axes = [float(np.degrees(np.arccos(min(1.0, abs(float(R[:, k] @ Rs[:, k])))))) for k in range(3)]
    return {"symmetry": name, "rotation_error_deg": err, "centre_error_m": cerr, "centre_distance_m": dist,
            "centre_error_relative": cerr / dist if dist > 0 else float("nan"),
            "origin_error_m": float(np.linalg.norm(t - ts)), "axis_angles_deg": axes,
            "R_reference": Rs.tolist(), "t_reference": ts.tolist()}


# =========================================================================== corners
def grey8(image) -> np.ndarray:
    """The image as 8-bit grey, as OpenCV's chessboard detectors take it (luminance of a colour image;
    other depths stretched to 0-255)."""
    img = np.asarray(image)
    if img.ndim == 3 and img.shape[2] in (3, 4):
        img = img[..., :3].astype(np.float64) @ LUMA
    elif img.ndim != 2:
        raise CatadioptricError(f"image: expected a grey (H, W) or colour (H, W, 3|4) image, got shape {img.shape}")
    if img.dtype == np.uint8:
        return np.ascontiguousarray(img)
    img = np.asarray(img, dtype=np.float64)
    finite = np.isfinite(img)
    if not finite.any():
        raise CatadioptricError("image: expected finite pixel values, got none")
    lo, hi = float(img[finite].min()), float(img[finite].max())
    if np.issubdtype(np.asarray(image).dtype, np.integer) and lo >= 0 and hi <= 255:
        lo, hi = 0.0, 255.0
    scale = 255.0 / (hi - lo) if hi > lo else 0.0
    return np.clip(np.where(finite, (img - lo) * scale, 0.0), 0, 255).round().astype(np.uint8)


def _check_mask(mask, shape) -> np.ndarray | None:
    if mask is None:
        return None
    m = np.asarray(mask)
    if m.ndim == 3:
        m = m.max(axis=2)
    if m.shape != tuple(shape):
        raise CatadioptricError(f"mask: expected the image's size {shape[1]}x{shape[0]}, got {m.shape[1]}x{m.shape[0]}"
                                if m.ndim == 2 else f"mask: expected a (H, W) array, got shape {m.shape}")
    m = m != 0
    if not m.any():
        raise CatadioptricError("mask: expected some non-zero pixels (those used), got none")
    return m


_SB_FLAGS = ("CALIB_CB_EXHAUSTIVE", "CALIB_CB_ACCURACY")


def _sb(grey, pattern):
    import cv2

    flags = 0
    for f in _SB_FLAGS:
        flags |= getattr(cv2, f, 0)
    ok, c = cv2.findChessboardCornersSB(grey, tuple(pattern), flags=flags)
    return c.reshape(-1, 2).astype(float) if ok and c is not None else None


def _classic(grey, pattern):
    import cv2

    ok, c = cv2.findChessboardCorners(grey, tuple(pattern),
                                      flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
    if not ok or c is None:
        return None
    c = cv2.cornerSubPix(grey, c.astype(np.float32), (5, 5), (-1, -1),
                         (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-3))
    return c.reshape(-1, 2).astype(float)


def _look_rotation(z) -> np.ndarray:
    """A rotation whose third column is the unit ``z`` (the virtual camera's axis, in the model's frame)."""
    z = np.asarray(z, float) / np.linalg.norm(z)
    a = np.array([0.0, 0.0, 1.0]) if abs(z[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(a, z)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], axis=1)


def _pixels_per_radian(cam, d) -> float:
    """The image's scale (pixels per radian) around the direction ``d``."""
    R = _look_rotation(d)
    h = 1e-3
    ds = np.stack([R[:, 2], R[:, 2] + h * R[:, 0], R[:, 2] + h * R[:, 1]])
    uv = cam.project(ds).uv[:, 0, :]
    if not np.all(np.isfinite(uv)):
        return float("nan")
    return float(max(np.linalg.norm(uv[1] - uv[0]), np.linalg.norm(uv[2] - uv[0])) / h)


def _rectified_view(grey, cam, d, half_fov_deg: float = 50.0, max_size: int = 1600):
    """A perspective view of ``grey`` looking along ``d``: ``(view, R, f, c)`` (pixel ``p`` of the
    view has the ray ``R @ [(p - c) / f, 1]``), or None where the image does not see ``d``."""
    import cv2

    ppr = _pixels_per_radian(cam, d)
    if not np.isfinite(ppr) or ppr <= 0:
        return None
    f = ppr
    n = int(min(max_size, 2 * math.ceil(f * math.tan(math.radians(half_fov_deg)))))
    f = min(f, (n / 2) / math.tan(math.radians(half_fov_deg)))
    c = (n - 1) / 2.0
    R = _look_rotation(d)
    u, v = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float))
    rays = np.stack([(u - c) / f, (v - c) / f, np.ones_like(u)], axis=-1) @ R.T
    pr = cam.project(rays)
    uv = np.where(pr.valid[..., 0, None], pr.uv[..., 0, :], -1.0).astype(np.float32)
    view = cv2.remap(grey, uv[..., 0], uv[..., 1], cv2.INTER_CUBIC, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    return view, R, f, c


def _fibonacci_directions(n: int) -> np.ndarray:
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = np.pi * (1 + 5 ** 0.5) * k
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def _from_view(corners_v, cam, R, f, c):
    rays = np.concatenate([(corners_v - c) / f, np.ones((len(corners_v), 1))], axis=1) @ R.T
    pr = cam.project(rays)
    if not np.all(pr.valid[:, 0]):
        return None
    return pr.uv[:, 0, :]


def _rectified(grey, cam, pattern, directions):
    for d in directions:
        got = _rectified_view(grey, cam, d)
        if got is None:
            continue
        view, R, f, c = got
        cv = _sb(view, pattern)
        if cv is None:
            continue
        uv = _from_view(cv, cam, R, f, c)
        if uv is not None:
            return uv
    return None


def _inside(uv, m) -> bool:
    iu = np.clip(np.round(uv).astype(int), 0, [m.shape[1] - 1, m.shape[0] - 1])
    return bool(np.all(m[iu[:, 1], iu[:, 0]]))


def find_chessboard_corners(image, cam, pattern, *, mask=None, method: str = "auto"):
    """The inner corners ``(cols * rows, 2)`` of a chessboard in OpenCV's order and how they were
    found (``"sb"``, ``"classic"``, ``"rectified"``), or a one-line error when the board is not found.

    ``method``: ``"sb"`` (``cv2.findChessboardCornersSB`` with ``CALIB_CB_EXHAUSTIVE`` and
    ``CALIB_CB_ACCURACY``, on the image itself), ``"classic"`` (``cv2.findChessboardCorners`` and
    ``cornerSubPix``), ``"rectified"`` (the SB detector on perspective views rendered through the
    model: towards the mask's centre when there is a mask, else on a set of directions covering
    the sphere, inside the mirror's disc when the image shows one; the corners mapped back through the model),
    ``"auto"``: these in turn until one
    finds the board. ``mask``: non-zero where the board may be (the rest is filled with the masked
    part's median grey before detection; if that fails, the image itself; corners outside the mask
    are refused)."""
    if method not in ("auto", "sb", "classic", "rectified"):
        raise CatadioptricError(f"method: expected 'auto', 'sb', 'classic' or 'rectified', got {method!r}")
    pattern = parse_pattern(pattern)
    grey = grey8(image)
    m = _check_mask(mask, grey.shape)
    raw = grey
    if m is not None:
        grey = np.where(m, grey, np.uint8(np.median(grey[m])))
    tries = ["sb", "classic", "rectified"] if method == "auto" else [method]
    for how in tries:
        if how in ("sb", "classic"):
            # with a mask: the masked image, then (the classic detector trips over the fill's edges) the
            # image itself, the corners then kept only inside the mask
            uv = None
            for g in ([grey, raw] if m is not None else [grey]):
                uv = _sb(g, pattern) if how == "sb" else _classic(g, pattern)
                if uv is not None and (m is None or _inside(uv, m)):
                    break
                uv = None
        else:
            if m is not None:
                vv, uu = np.nonzero(m)
                r = cam.backproject(np.array([[uu.mean(), vv.mean()]])).directions[0]
                dirs = [r] if np.all(np.isfinite(r)) else []
            else:  # views 50 degrees wide about directions some 40 degrees apart, inside the mirror's disc
                disc = mirror_disc(grey, cam)
                fib = _fibonacci_directions(24)
                uvf, okf = project_points(cam, fib)
                okf = okf & np.all(np.isfinite(uvf), axis=1)
                okf[okf] &= in_disc(uvf[okf], disc) & (cam.in_image(uvf[okf]) if hasattr(cam, "in_image") else True)
                dirs = list(fib[okf])
            uv = _rectified(grey, cam, pattern, dirs)
        if uv is None or (m is not None and not _inside(uv, m)):
            continue
        return uv, how
    raise CatadioptricError(f"image: no {pattern[0]}x{pattern[1]} chessboard found (inner corners; tried "
                            f"{', '.join(tries)})")


# =========================================================================== refinement
def project_points(cam, X):
    """Pixels ``(..., 2)`` and validity ``(...)`` of points ``X (..., 3)`` (the first image of each)."""
    pr = cam.project(X)
    return pr.uv[..., 0, :], pr.valid[..., 0]


def _refine(cam, R, t, P, uv, iters: int = 30):
    """Gauss-Newton (Levenberg damping) on ``(w, t)`` for the pixel residuals of ``R P + t``;
    returns ``R, t, cov (6, 6), residuals (N, 2), sigma2, iterations``."""
    from .rotation import exp_rotation

    scale = max(float(np.linalg.norm(t)), 1e-3)

    def resid(R_, t_):
        p, ok = project_points(cam, P @ R_.T + t_)
        if not np.all(ok):
            return None
        return (p - uv).ravel()

    def jac(R_, t_, r0):
        J = np.empty((len(r0), 6))
        for k in range(6):
            e = np.zeros(6)
            h = 1e-6 if k < 3 else 1e-6 * scale
            e[k] = h
            rp = resid(exp_rotation(e[:3]) @ R_, t_ + e[3:])
            rm = resid(exp_rotation(-e[:3]) @ R_, t_ - e[3:])
            if rp is None or rm is None:
                raise CatadioptricError("pose: a corner leaves the camera's field of view during the refinement")
            J[:, k] = (rp - rm) / (2 * h)
        return J

    r = resid(R, t)
    if r is None:
        raise CatadioptricError("pose: the board's corners do not all project through the camera model at the "
                                "initial pose")
    cost = float(r @ r)
    lam = 1e-3
    it = 0
    for it in range(1, iters + 1):
        J = jac(R, t, r)
        H, g = J.T @ J, J.T @ r
        improved, small = False, False
        for _ in range(10):
            step = -np.linalg.solve(H + lam * np.diag(np.diag(H)), g)
            R2, t2 = exp_rotation(step[:3]) @ R, t + step[3:]
            r2 = resid(R2, t2)
            if r2 is not None and float(r2 @ r2) <= cost:
                improved = True
                small = np.linalg.norm(step[:3]) < 1e-12 and np.linalg.norm(step[3:]) < 1e-12 * scale
                R, t, r, cost = R2, t2, r2, float(r2 @ r2)
                lam = max(lam / 10, 1e-9)
                break
            lam *= 10
        if not improved or small:
            break
    J = jac(R, t, r)
    dof = max(len(r) - 6, 1)
    sigma2 = cost / dof
    cov = sigma2 * np.linalg.pinv(J.T @ J)
    return R, t, cov, r.reshape(-1, 2), sigma2, it


# =========================================================================== the pose
def _check_camera(cam):
    for a in ("backproject", "project", "vanishing_points", "width", "height"):
        if not hasattr(cam, a):
            raise CatadioptricError(f"cam: expected a camera with backproject, project, vanishing_points, width and "
                                    f"height, got {type(cam).__name__} (no {a})")
    if not getattr(cam, "is_central", True):
        raise CatadioptricError("cam: expected a central camera (one viewpoint: a line's rays lie in a plane), got a "
                                "non-central one")


def chessboard_pose(image, cam, pattern=(8, 6), square: float = 1.0, mask=None, *, corners=None,
                    method: str = "auto") -> ChessboardPose:
    """The pose of a chessboard (``pattern = (cols, rows)`` inner corners, ``square`` metres)
    in ``image`` seen by the central camera ``cam`` (module docstring). ``mask``: non-zero where
    the board may be, of the image's size. ``corners (cols * rows, 2)``: the corners already found
    (in OpenCV's order; ``image`` is then only checked for its size and may be None)."""
    from ..linefit.central import direction_from_planes
    from ..linefit.planes import pixel_rays_with_jacobian, plane_covariance, plane_distances, refine_plane
    from .rotation import refine_rotation, rotation_from_directions
    from .translation import translation_from_lines

    _check_camera(cam)
    pattern = parse_pattern(pattern)
    cols, rows = pattern
    try:
        square = float(square)
    except (TypeError, ValueError):
        raise CatadioptricError(f"square: expected a positive number (metres), got {square!r}") from None
    if not (math.isfinite(square) and square > 0):
        raise CatadioptricError(f"square: expected a positive number (metres), got {square!r}")
    if image is not None:
        shape = np.asarray(image).shape[:2]
        if shape != (cam.height, cam.width):
            raise CatadioptricError(f"image: expected the camera's size {cam.width}x{cam.height}, got "
                                    f"{shape[1]}x{shape[0]}")
    if corners is None:
        if image is None:
            raise CatadioptricError("image: expected an image (or the corners), got None")
        uv, how = find_chessboard_corners(image, cam, pattern, mask=mask, method=method)
    else:
        uv = np.asarray(corners, float).reshape(-1, 2)
        if len(uv) != cols * rows or not np.all(np.isfinite(uv)):
            raise CatadioptricError(f"corners: expected {cols * rows} finite pixels (cols * rows), got {len(uv)}")
        how = "given"
    P = board_points(pattern, square)
    # each row and column of corners through the model: its interpretation plane (the first-order
    # pixel distances of its corners' rays, linefit.planes)
    rays = pixel_rays_with_jacobian(cam, uv)
    if not np.all(rays.ok):
        raise CatadioptricError("corners: a corner (or its neighbourhood) has no ray in the camera model")
    d = rays.d

    def fit(i):
        n = refine_plane(rays.take(i), iters=50, tol=1e-15)
        return n, plane_distances(n, rays.take(i))

    # the two families: rows (x) and columns (y)
    idx = np.arange(cols * rows).reshape(rows, cols)
    fams = [[idx[r] for r in range(rows)], [idx[:, c] for c in range(cols)]]
    fits = [[fit(i) for i in lines] for lines in fams]
    res = np.concatenate([f[1] for fam in fits for f in fam])
    dof = sum(len(i) - 2 for lines in fams for i in lines)
    sigma2_lines = float(res @ res / dof)
    line_rms = np.array([math.sqrt(np.mean(np.concatenate([f[1] for f in fam]) ** 2)) for fam in fits])
    dirs, dcovs = [], []
    for k in range(2):
        normals = np.array([f[0] for f in fits[k]])
        covs = np.array([plane_covariance(f[0], rays.take(i), math.sqrt(sigma2_lines))
                         for i, f in zip(fams[k], fits[k])])
        s, C = direction_from_planes(normals, covs)
        # orient along the board's axis: along a line, the rays turn towards its direction
        first = np.array([i[0] for i in fams[k]])
        last = np.array([i[-1] for i in fams[k]])
        if float(np.sum((d[last] - d[first]) @ s)) < 0:
            s = -s
        dirs.append(s)
        dcovs.append(C)
    dirs, dcovs = np.array(dirs), np.array(dcovs)

    # the paper's pose: rotation from the directions, translation from the lines of known position
    E = np.eye(3)[:2]
    R0 = rotation_from_directions(E, dirs)
    rot = refine_rotation(E, dirs, np.zeros((2, 3, 3)), dcovs, R0=R0, robust=False)
    R_lines = rot.R
    world = []
    for r in range(rows):  # row r: through (0, r sq, 0) along x
        q, s = np.array([0.0, r * square, 0.0]), np.array([1.0, 0.0, 0.0])
        world.append(np.r_[s, np.cross(q, s)])
    for c in range(cols):  # column c: through (c sq, 0, 0) along y
        q, s = np.array([c * square, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
        world.append(np.r_[s, np.cross(q, s)])
    o = np.asarray(getattr(cam, "viewpoint", np.zeros(3)), float)
    ray_lines = np.concatenate([d, np.cross(o, d)], axis=1)
    k_all = np.arange(cols * rows)
    line_index = np.r_[k_all // cols, rows + k_all % cols]
    t_lines = translation_from_lines(R_lines, np.array(world), np.r_[ray_lines, ray_lines], line_index)

    # joint refinement on the corners' pixels
    R, t, cov, r2, sigma2, its = _refine(cam, R_lines, t_lines, P, uv)
    resid = np.linalg.norm(r2, axis=1)
    vp = cam.vanishing_points(dirs, which="both")
    vuv = np.full((2, 2, 2), np.nan)
    vin = np.zeros((2, 2), bool)
    for k in range(2):
        for j in range(vp.uv.shape[1]):
            sg = int(vp.sign[k, j])
            if sg == 0 or not vp.visible[k, j]:
                continue
            slot = 0 if sg > 0 else 1
            vuv[k, slot] = vp.uv[k, j]
            vin[k, slot] = bool(vp.in_image[k, j])
    ax = np.array([math.degrees(math.acos(min(1.0, float(R[:, k] @ dirs[k])))) for k in range(2)])
    return ChessboardPose(R=R, t=t, cov=cov, R_lines=R_lines, t_lines=t_lines, cov_rotation_lines=rot.cov,
                          corners=uv, board_points=P, residuals_px=resid,
                          rms_px=float(math.sqrt(np.mean(resid ** 2))), sigma_px=float(math.sqrt(sigma2)),
                          directions=dirs, direction_covs=dcovs, line_rms_px=line_rms, vanishing_uv=vuv,
                          vanishing_in_image=vin, axis_family_deg=ax, pattern=pattern, square=square, detector=how,
                          iterations=its, extra={"line_sigma_px": math.sqrt(sigma2_lines)})


# =========================================================================== the mirror's disc
def mirror_disc(image, cam):
    """``(u0, v0, r_in, r_out)``: the mirror's bright annulus in the photograph around the pixel of
    the camera's axis (:func:`catadioptric.detect.region.scene_annulus`), or None (no dark ring
    seen). A calibration's formula holds beyond the mirror's rim; this says where the mirror ends."""
    try:
        from ..detect.region import scene_annulus
    except ImportError:  # pragma: no cover - the detector is part of the package
        return None
    g = grey8(image)
    if hasattr(cam, "axis_pixel"):
        c = np.asarray(cam.axis_pixel(), float)
    else:
        c = project_points(cam, np.array([[0.0, 0.0, 1.0]]))[0][0]
    if not np.all(np.isfinite(c)):
        return None
    try:
        a = scene_annulus(g, np.ones(g.shape, bool), c)
    except Exception:  # noqa: BLE001 - an overlay's nicety, never a failure
        return None
    return None if a is None or not np.isfinite(a[3]) else tuple(float(v) for v in a)


def in_disc(uv, disc):
    """Whether pixels ``uv (N, 2)`` lie inside the mirror's disc ``disc`` (:func:`mirror_disc`; all, when None)."""
    if disc is None:
        return np.ones(len(uv), bool)
    with np.errstate(invalid="ignore"):
        return np.hypot(uv[:, 0] - disc[0], uv[:, 1] - disc[1]) <= disc[3]
