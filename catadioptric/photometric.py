"""How two images of one scene agree under a candidate rotation (:func:`rotation_agreement`).

Image B's pixels (every ``step``-th row and column, inside the mirror's region and the mask) are
back-projected to their rays' directions ``d_B``; a candidate ``R`` of ``x_B = R x_A + t`` turns
each into A's frame, ``d_A = R^T d_B``, whose vanishing point in image A is where A sees that
direction. The agreement of the candidate is the correlation (Pearson's) of B's luminance at its
pixels with A's at those vanishing points, both blurred (a Gaussian of ``blur_px``).

This compares the views as if the scene were at infinity: it leaves out the translation, so a
point at distance ``D`` from a baseline ``b`` is seen up to ``b / D`` radians apart in the two
images. Blurred and averaged over the whole image, the sky above, the ground below and the
facades' layout and colours around still agree far better under the right rotation than under
the rotations that a Manhattan scene's directions allow as well (a street's half-turn puts one
side's facades onto the other's). :func:`catadioptric.twoview.relative_pose_from_images` uses it
to choose among those answers (docs/relative_pose.md, "From two images").
"""
from __future__ import annotations

import math

import numpy as np

from ._checks import CatadioptricError, as_count, as_scalar

__all__ = ["rotation_agreement", "turned_image", "RotationAgreement", "BLUR_PX", "STEP", "MIN_SAMPLES",
           "NEAR_START_DEG", "NEAR_EVALS", "BLOCKS", "PARALLAX_DIRECTIONS", "PARALLAX_SCALES", "PARALLAX_EVALS"]

#: the Gaussian blur of both images' luminance (pixels) before they are compared
BLUR_PX = 3.0
#: every ``STEP``-th row and column of image B is compared
STEP = 4
#: fewer pixels of B seen in A than this: the agreement is not measured (NaN)
MIN_SAMPLES = 200
#: :meth:`RotationAgreement.best_near`: the search's first simplex (degrees) and its most agreements
NEAR_START_DEG = 3.0
NEAR_EVALS = 150
#: :meth:`RotationAgreement.margin`'s blocks of B's rays: sectors of azimuth, bands of elevation
BLOCKS = (8, 2)
#: :meth:`RotationAgreement.parallax`: the translation's directions tried (a Fibonacci sphere), the
#: parallax's lengths (the baseline over the scene's distance) and the most agreements of the search
#: from the best of those
PARALLAX_DIRECTIONS = 48
PARALLAX_SCALES = (0.1, 0.2, 0.35, 0.5, 0.75)
PARALLAX_EVALS = 150


def rotation_agreement(image_a, image_b, cam_a, cam_b, rotations, *, masks=(None, None), step: int = STEP,
                       blur_px: float = BLUR_PX, min_samples: int = MIN_SAMPLES) -> np.ndarray:
    """The correlation ``(K,)`` of image B with image A turned by each of ``rotations (K, 3, 3)``
    (``x_B = R x_A + t``, the cameras' frames; module docstring), in [-1, 1]; NaN for a rotation
    under which fewer than ``min_samples`` of B's sampled pixels are seen in A.

    ``image_a``, ``image_b``: as :func:`catadioptric.detect.detect_lines` takes them; ``cam_a``,
    ``cam_b``: cameras with ``backproject`` and ``vanishing_points`` (an exact rig or a camera
    model); ``masks``: each image's mask (non-zero: use the pixel; None: all), of the image's size.
    :class:`RotationAgreement` keeps the images' preparation for more rotations."""
    return RotationAgreement(image_a, image_b, cam_a, cam_b, masks=masks, step=step, blur_px=blur_px,
                             min_samples=min_samples)(rotations)


def turned_image(image_a, cam_a, cam_b, R, *, step: int = 1) -> np.ndarray:
    """Image A as camera B would see it were the scene at infinity and ``x_B = R x_A + t``: each
    pixel of B (every ``step``-th row and column, each a ``step`` x ``step`` block) that sees the world
    takes A's colour, interpolated, at the vanishing point of its ray's direction turned into A's frame
    (``R^T d_B``), as :func:`rotation_agreement` compares them, unblurred. ``(H_b, W_b, C)`` float
    levels on the 8-bit scale (C as the image has, :func:`catadioptric.detect.image.to_channels`), NaN
    where B sees nothing or A does not see that direction: what image B should look like under ``R``,
    for a reader to set beside it (``catadioptric relative-pose`` writes ``look.png``)."""
    from scipy.ndimage import map_coordinates

    from .detect.image import to_channels
    from .detect.region import mirror_region

    step = as_count(step, "step")
    a = to_channels(image_a)
    R = _rotation(R, "R")
    seen_a = mirror_region(cam_a, erode_px=0)
    if seen_a.shape != a.shape[:2]:
        raise CatadioptricError(f"image_a: expected the camera's size {seen_a.shape[1]}x{seen_a.shape[0]}, got "
                                f"{a.shape[1]}x{a.shape[0]}")
    region = mirror_region(cam_b, erode_px=0)
    H, W = region.shape
    v, u = np.mgrid[0:H:step, 0:W:step]
    keep = region[v, u]
    uv_b = np.stack([u[keep], v[keep]], axis=-1).astype(float)
    out = np.full((len(v), v.shape[1], a.shape[2]), np.nan)
    rays = cam_b.backproject(uv_b)
    ok = np.asarray(rays.valid, bool) & np.all(np.isfinite(rays.directions), axis=-1)
    uv_a, hit = _where_a_sees(cam_a, seen_a, np.where(ok[:, None], rays.directions, [0.0, 0.0, 1.0]) @ R)
    hit &= ok
    sub = np.full((len(uv_b), a.shape[2]), np.nan)
    for c in range(a.shape[2]):
        sub[hit, c] = map_coordinates(a[..., c], [uv_a[hit, 1], uv_a[hit, 0]], order=1, mode="nearest")
    out[keep] = sub
    if step > 1:
        out = np.repeat(np.repeat(out, step, axis=0), step, axis=1)[:H, :W]
    return out


def _where_a_sees(cam_a, usable_a, d_a):
    """Where image A shows each direction ``d_a (N, 3)`` of A's frame: ``(uv (N, 2), hit (N,))``, the
    first of its vanishing points that A sees inside its image (zero where none), and whether there
    is one and its nearest pixel is in ``usable_a`` (A's ``(H, W)`` mask of usable pixels)."""
    vp = cam_a.vanishing_points(d_a)
    seen = vp.valid & vp.in_image
    hit = seen.any(axis=-1)
    uv = np.where(hit[:, None], vp.uv[np.arange(len(d_a)), np.argmax(seen, axis=-1)], 0.0)
    H, W = usable_a.shape
    col = np.clip(np.rint(uv[:, 0]), 0, W - 1).astype(int)
    row = np.clip(np.rint(uv[:, 1]), 0, H - 1).astype(int)
    return uv, hit & usable_a[row, col]


def _rotations(rotations) -> np.ndarray:
    R = np.asarray(rotations, dtype=float)
    if R.ndim != 3 or R.shape[1:] != (3, 3) or not np.all(np.isfinite(R)):
        raise CatadioptricError(f"rotations: expected finite (K, 3, 3) rotation matrices, got shape {R.shape}")
    return R


def _rotation(R, name: str) -> np.ndarray:
    R = np.asarray(R, dtype=float)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise CatadioptricError(f"{name}: expected a finite (3, 3) rotation matrix, got shape {R.shape}")
    return R


def _correlation(a, b) -> float:
    """Pearson's correlation of two samples (0 when either is constant; NaN when empty)."""
    if len(a) == 0:
        return float("nan")
    a, b = a - a.mean(), b - b.mean()
    den = math.sqrt(float(a @ a) * float(b @ b))
    return float(a @ b) / den if den > 0 else 0.0


def _blocks(d) -> np.ndarray:
    az = np.arctan2(d[:, 1], d[:, 0])
    sector = np.minimum((az + np.pi) / (2 * np.pi) * BLOCKS[0], BLOCKS[0] - 1).astype(int)
    band = np.searchsorted(np.quantile(d[:, 2], np.linspace(0, 1, BLOCKS[1] + 1)[1:-1]), d[:, 2], side="right") \
        if len(d) else np.zeros(0, int)
    return sector * BLOCKS[1] + band


class RotationAgreement:
    """:func:`rotation_agreement` of two images, prepared once (their blurred luminance, usable
    pixels and B's rays) for any number of rotations: call it with ``rotations (K, 3, 3)``;
    :meth:`best_near` looks for the rotation near one where the images agree best; :meth:`at` and
    :meth:`parallax` let the translation in (the scene at one distance from B)."""

    def __init__(self, image_a, image_b, cam_a, cam_b, *, masks=(None, None), step: int = STEP,
                 blur_px: float = BLUR_PX, min_samples: int = MIN_SAMPLES):
        import cv2

        from .detect.image import to_grey
        from .detect.region import mirror_region

        step = as_count(step, "step")
        blur_px = as_scalar(blur_px, "blur_px", positive=True)
        self.min_samples = as_count(min_samples, "min_samples")
        erode = int(math.ceil(2.0 * blur_px))  # the blur does not mix the mirror's rim into what is compared
        grey, usable = [], []
        for name, img, cam, mask in (("image_a", image_a, cam_a, masks[0]), ("image_b", image_b, cam_b, masks[1])):
            g = to_grey(img).astype(np.float32)
            ok = mirror_region(cam, erode_px=erode)
            if ok.shape != g.shape:
                raise CatadioptricError(f"{name}: expected the camera's size {ok.shape[1]}x{ok.shape[0]}, got "
                                        f"{g.shape[1]}x{g.shape[0]}")
            if mask is not None:
                m = np.asarray(mask)
                if m.shape[:2] != g.shape:
                    raise CatadioptricError(f"{name}'s mask: expected the image's size {g.shape[1]}x{g.shape[0]}, "
                                            f"got {m.shape[1]}x{m.shape[0]}")
                ok = ok & (m.reshape(m.shape[:2] + (-1,)).max(axis=-1) > 0)
            grey.append(cv2.GaussianBlur(g, (0, 0), blur_px).astype(float))
            usable.append(ok)
        H, W = grey[1].shape
        v, u = np.mgrid[0:H:step, 0:W:step]
        keep = usable[1][v, u]
        uv_b = np.stack([u[keep], v[keep]], axis=-1).astype(float)
        rays = cam_b.backproject(uv_b)
        ok = np.asarray(rays.valid, bool) & np.all(np.isfinite(rays.directions), axis=-1)
        #: B's sampled pixels (u, v) and their rays' directions, ``(N, 2)`` and ``(N, 3)``
        self.uv_b, self.d_b = uv_b[ok], rays.directions[ok]
        self.lum_b = grey[1][uv_b[ok, 1].astype(int), uv_b[ok, 0].astype(int)]
        #: each sampled ray's block for :meth:`margin`'s jackknife, ``(N,)``: ``BLOCKS[0]`` sectors of
        #: azimuth about the z axis of B's frame times ``BLOCKS[1]`` bands of elevation split at its quantiles
        self.blocks = _blocks(self.d_b)
        self.grey_a, self.usable_a, self.cam_a = grey[0], usable[0], cam_a

    def __call__(self, rotations) -> np.ndarray:
        R = _rotations(rotations)
        out = np.full(len(R), np.nan)
        for k, Rk in enumerate(R):
            lum_a, hit = self._seen(Rk)
            if hit is not None:
                out[k] = _correlation(lum_a, self.lum_b[hit])
        return out

    def _seen(self, R, parallax=None):
        """A's blurred luminance at the vanishing points of B's sampled rays turned by ``R`` (each
        ray's direction ``d`` moved to ``d - parallax`` and normalised first, :meth:`at`) and which of
        B's rays A sees (``(lum_a, hit)``); ``(None, None)`` below ``min_samples``."""
        from scipy.ndimage import map_coordinates

        d_b = self.d_b
        if parallax is not None:
            d_b = d_b - parallax
            d_b = d_b / np.linalg.norm(d_b, axis=-1, keepdims=True)
        if len(d_b) < self.min_samples:
            return None, None
        uv_a, hit = _where_a_sees(self.cam_a, self.usable_a, d_b @ R)  # R^T d for each row d
        if hit.sum() < self.min_samples:
            return None, None
        return map_coordinates(self.grey_a, [uv_a[hit, 1], uv_a[hit, 0]], order=1, mode="nearest"), hit

    def margin(self, R_first, R_other) -> tuple[float, float]:
        """``(margin, standard error)``: the agreement under ``R_first`` minus that under ``R_other``
        (each (3, 3)) and the margin's jackknife standard error over :data:`BLOCKS` blocks of B's
        sampled rays (sectors of azimuth about the z axis of B's frame, above and below their median
        elevation, :attr:`blocks`; each block that either rotation sees left out in turn, both
        correlations computed again): how much the margin owes to one part of the image. NaN (both)
        when either rotation leaves too little of B seen in A (the error alone with fewer than two blocks)."""
        la, ha = self._seen(_rotation(R_first, "R_first"))
        lo, ho = self._seen(_rotation(R_other, "R_other"))
        if ha is None or ho is None:
            return float("nan"), float("nan")
        full_a, full_o = np.full(len(self.d_b), np.nan), np.full(len(self.d_b), np.nan)
        full_a[ha], full_o[ho] = la, lo

        def diff(keep):
            a, o = ha & keep, ho & keep
            return _correlation(full_a[a], self.lum_b[a]) - _correlation(full_o[o], self.lum_b[o])

        return self._jackknife(diff, ha | ho)

    def agreement(self, R) -> tuple[float, float]:
        """``(agreement, standard error)``: the agreement under ``R`` (3, 3), as a call gives it, and
        its jackknife standard error over the blocks :meth:`margin` uses: whether image B agrees
        with A turned by ``R`` at all, beyond what one part of the image makes of it. NaN (both) when
        ``R`` leaves too little of B seen in A."""
        la, ha = self._seen(_rotation(R, "R"))
        if ha is None:
            return float("nan"), float("nan")
        full = np.full(len(self.d_b), np.nan)
        full[ha] = la
        return self._jackknife(lambda keep: _correlation(full[ha & keep], self.lum_b[ha & keep]), ha)

    def _jackknife(self, stat, seen) -> tuple[float, float]:
        """``stat`` (of a mask over B's sampled rays) on every ray and its jackknife standard error
        over the :attr:`blocks` among ``seen``."""
        whole = stat(np.ones(len(self.blocks), bool))
        theta = np.array([stat(self.blocks != b) for b in np.unique(self.blocks[seen])])
        theta = theta[np.isfinite(theta)]
        if len(theta) < 2:
            return whole, float("nan")
        k = len(theta)
        return whole, float(math.sqrt((k - 1) / k * float(np.sum((theta - theta.mean()) ** 2))))

    def at(self, R, parallax=None) -> float:
        """The agreement under ``R`` (3, 3) with the scene at one distance ``D`` from B rather than at
        infinity: ``parallax`` ``(3,)`` is ``t / D`` (B's frame, ``x_B = R x_A + t``; None: at
        infinity, as a call), each of B's rays ``d`` seen by A along ``R^T (d - t / D)`` (a point
        ``D d`` of B's frame is ``R^T (D d - t)`` in A's). NaN when too little of B is seen in A."""
        if parallax is not None:
            parallax = np.asarray(parallax, dtype=float)
            if parallax.shape != (3,) or not np.all(np.isfinite(parallax)):
                raise CatadioptricError(f"parallax: expected a finite (3,) vector, got shape {parallax.shape}")
        lum_a, hit = self._seen(_rotation(R, "R"), parallax)
        return float("nan") if hit is None else _correlation(lum_a, self.lum_b[hit])

    def parallax(self, R, *, max_evals: int = PARALLAX_EVALS) -> tuple[float, np.ndarray]:
        """``(agreement, parallax)``: the best agreement under ``R`` (3, 3) over the parallaxes
        ``t / D`` (:meth:`at`) and the parallax that gives it: how well the images agree under ``R``
        with the translation let in (one distance ``D`` for the whole scene), and the direction of
        the translation ``t`` that agrees best (zero: no parallax does better than the scene at
        infinity). The best of the scene at infinity and ``u s`` (``s`` each of
        :data:`PARALLAX_DIRECTIONS` unit directions of a Fibonacci sphere, ``u`` each of
        :data:`PARALLAX_SCALES`), then Nelder-Mead's search over the parallax from it (a simplex of
        0.05, at most ``max_evals`` agreements; deterministic). NaN and zero when ``R`` leaves too
        little of B seen in A."""
        from scipy.optimize import minimize

        R = _rotation(R, "R")
        best, where = self.at(R), np.zeros(3)
        for s in _fibonacci(PARALLAX_DIRECTIONS):
            for u in PARALLAX_SCALES:
                a = self.at(R, u * s)
                if np.isfinite(a) and not a <= best:
                    best, where = a, u * s
        if not np.isfinite(best) or not where.any():
            return best, where

        def cost(x):
            a = self.at(R, where + x)
            return -a if np.isfinite(a) else 1.0

        res = minimize(cost, np.zeros(3), method="Nelder-Mead",
                       options={"initial_simplex": np.vstack([np.zeros(3), 0.05 * np.eye(3)]), "xatol": 1e-3,
                                "fatol": 1e-4, "maxfev": as_count(max_evals, "max_evals"), "adaptive": True})
        if -res.fun > best:
            best, where = float(-res.fun), where + res.x
        return best, where

    def best_near(self, R, *, start_deg: float = NEAR_START_DEG, max_evals: int = NEAR_EVALS):
        """``(R_best, agreement)``: the rotation near ``R`` (3, 3) where the images agree best, by
        Nelder-Mead's search over a rotation ``exp(w) R`` from a simplex of ``start_deg`` degrees, at
        most ``max_evals`` agreements (deterministic). The translation the agreement leaves out moves
        the best rotation a few degrees from the true one (3-7 degrees on rendered street pairs of
        2-8 m), and the agreement there is a few hundredths higher: a rotation that agrees much better
        nearby says that ``R`` is not where the images agree."""
        from scipy.optimize import minimize
        from scipy.spatial.transform import Rotation

        R = np.asarray(R, dtype=float)

        def cost(w):
            a = self(Rotation.from_rotvec(w).as_matrix()[None] @ R)[0]
            return -a if np.isfinite(a) else 1.0

        s = math.radians(as_scalar(start_deg, "start_deg", positive=True))
        res = minimize(cost, np.zeros(3), method="Nelder-Mead",
                       options={"initial_simplex": np.vstack([np.zeros(3), s * np.eye(3)]),
                                "xatol": math.radians(0.2), "fatol": 1e-4, "maxfev": as_count(max_evals, "max_evals")})
        w = res.x if res.fun <= cost(np.zeros(3)) else np.zeros(3)
        Rb = Rotation.from_rotvec(w).as_matrix() @ R
        return Rb, float(self(Rb[None])[0])


def _fibonacci(n: int) -> np.ndarray:
    """``n`` unit vectors ``(n, 3)`` spread evenly over the sphere (a Fibonacci lattice)."""
    i = np.arange(n) + 0.5
    polar, azimuth = np.arccos(1.0 - 2.0 * i / n), math.pi * (1.0 + math.sqrt(5.0)) * i
    return np.stack([np.cos(azimuth) * np.sin(polar), np.sin(azimuth) * np.sin(polar), np.cos(polar)], axis=-1)
