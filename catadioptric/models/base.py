"""What every camera model of :mod:`catadioptric.models` is: a central camera (one viewpoint, the
origin of its own frame) that maps pixels to unit rays and points to pixels by one tool's formula.

A model subclasses :class:`CentralCamera` and defines two methods, nothing else:

* ``lift(uv) -> (X, valid)``: unit directions ``X (..., 3)`` (the model's camera frame) of
  pixels ``uv (..., 2)``; ``valid`` False where the formula gives no ray (NaN there);
* ``project_unit(X) -> (uv, valid)``: pixels of unit directions ``X (..., 3)``; ``valid``
  False where the formula gives no pixel (NaN there).

Everything the detector, the families, the vanishing points and the relative pose ask of a
camera is built from these two here, with the results the exact rigs return
(:class:`catadioptric.projection.Rays`, :class:`~catadioptric.projection.Projections`,
:class:`~catadioptric.vanishing.VanishingPoints`), so that code written for a central
:class:`~catadioptric.CatadioptricCamera` takes a model unchanged. The model's camera frame
plays the part of the rig's mirror frame M: directions and poses are in the tool's own frame.

The image region (:meth:`CentralCamera.region`): the pixels whose ray the model gives and whose
ray projects back onto the same pixel (a distortion polynomial folds over beyond its
calibrated range: such pixels are left out), inside ``roi`` when the model has one.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .._checks import CatadioptricError, as_float_array
from ..curves import image_size  # defined with the curves, which need it; re-exported here

__all__ = ["CentralCamera", "ROUND_TRIP_PX", "check_size", "image_size", "nonzero_focal"]

#: a pixel belongs to the model's image region when its ray projects back within this many pixels
ROUND_TRIP_PX = 1e-3


def check_size(width, height, where: str) -> tuple[int, int]:
    """``(width, height)`` as positive ints, or an error naming ``where``."""
    out = []
    for name, v in (("width", width), ("height", height)):
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) or v <= 0:
            try:
                f = float(v)
            except (TypeError, ValueError):
                f = None
            if f is None or not f.is_integer() or f <= 0:
                raise CatadioptricError(f"{where}{name}: expected a positive number of pixels, got {v!r}")
            v = int(f)
        out.append(int(v))
    return out[0], out[1]


def nonzero_focal(v, name: str) -> float:
    """A focal length as a float: a real number other than zero (a negative one mirrors the image,
    which a tool's formula allows)."""
    from .._checks import as_scalar

    v = as_scalar(v, name)
    if v == 0:
        raise CatadioptricError(f"{name}: expected a non-zero focal length, got {v!r}")
    return v


@dataclass(frozen=True, eq=False)
class CentralCamera:
    """Base of the central camera models (module docstring). ``width``, ``height``: the image
    size in pixels (pixel centres at integers, OpenCV's convention). Subclasses are frozen
    dataclasses that add their parameters and define :meth:`lift` and :meth:`project_unit`."""

    width: int
    height: int

    #: the model's name in :data:`catadioptric.models.MODELS` (and in ``to_dict()["model"]``)
    model: ClassVar[str] = ""
    #: every ray passes through the origin of the model's frame
    is_central: ClassVar[bool] = True

    def __post_init__(self):
        w, h = check_size(self.width, self.height, "")
        object.__setattr__(self, "width", w)
        object.__setattr__(self, "height", h)

    # ------------------------------------------------------------------ what a model defines
    def lift(self, uv: np.ndarray):  # pragma: no cover - abstract
        raise NotImplementedError

    def project_unit(self, X: np.ndarray):  # pragma: no cover - abstract
        raise NotImplementedError

    def params(self) -> dict:
        """The model's parameters, JSON-ready (``to_dict`` adds the model's name and image size)."""
        raise NotImplementedError  # pragma: no cover - abstract

    #: the image annulus a calibration declares, ``(u0, v0, r_min, r_max)`` in pixels, or None
    #: (a subclass with one makes it a field)
    roi = None

    #: how far (pixels) a pixel's ray may project back from it and still count as the model's
    #: (:meth:`region`): a model whose projection is a fitted approximation of its lift's inverse
    #: (OCamCalib's ``invpol``) sets its tool's own tolerance
    round_trip_px = ROUND_TRIP_PX

    #: the direction of the optical axis in the model's frame (the mirror's axis of a catadioptric
    #: camera; its image is the centre of the mirror's disc)
    axis = (0.0, 0.0, 1.0)

    # ------------------------------------------------------------------ what every model has
    def axis_pixel(self) -> np.ndarray:
        """The pixel of :attr:`axis` (NaN when the model does not image it)."""
        uv, ok = self._project_directions(np.asarray(self.axis, float))
        return uv if ok else np.full(2, np.nan)

    @property
    def viewpoint(self) -> np.ndarray:
        """The single viewpoint: the origin of the model's frame."""
        return np.zeros(3)

    @property
    def size(self) -> tuple[int, int]:
        return self.width, self.height

    def in_image(self, uv) -> np.ndarray:
        """True where pixels fall on the image (-0.5 <= u < W - 0.5, same for v)."""
        uv = np.asarray(uv, dtype=float)
        with np.errstate(invalid="ignore"):
            return ((uv[..., 0] >= -0.5) & (uv[..., 0] < self.width - 0.5) & (uv[..., 1] >= -0.5)
                    & (uv[..., 1] < self.height - 0.5))

    def pixel_grid(self, step: int = 1) -> np.ndarray:
        """Pixel centres ``(H', W', 2)`` every ``step`` pixels."""
        u, v = np.meshgrid(np.arange(0, self.width, step, dtype=float), np.arange(0, self.height, step, dtype=float))
        return np.stack([u, v], axis=-1)

    def backproject(self, uv):
        """Pixels ``(..., 2)`` -> rays (:class:`catadioptric.projection.Rays`): origins at the
        viewpoint, unit directions in the model's frame, ``valid`` where the model gives a ray."""
        from ..projection import Rays

        uv = as_float_array(uv, "uv", 2, finite=False)
        with np.errstate(all="ignore"):
            X, valid = self.lift(uv)
        valid = np.asarray(valid, bool) & np.all(np.isfinite(X), axis=-1)
        d = np.where(valid[..., None], X, np.nan)
        o = np.where(valid[..., None], 0.0, np.nan)
        return Rays(o, d, valid, valid.copy())

    def project(self, points):
        """Points ``(..., 3)`` -> their image (:class:`catadioptric.projection.Projections`,
        one slot: ``uv (..., 1, 2)``, ``valid (..., 1)``); the viewpoint itself has none."""
        P = as_float_array(points, "points", 3)
        pr = self._project_directions(P)
        return self._projections(pr)

    def _project_directions(self, D):
        from .._numeric import unit

        with np.errstate(all="ignore"):
            X = unit(D)
            uv, valid = self.project_unit(X)
        valid = np.asarray(valid, bool) & np.all(np.isfinite(uv), axis=-1)
        return np.where(valid[..., None], uv, np.nan), valid

    def _projections(self, pr):
        from ..projection import Projections

        uv, valid = pr
        return Projections(uv[..., None, :], np.full(uv.shape[:-1] + (1, 3), np.nan), valid[..., None],
                           (valid & self.in_image(uv))[..., None])

    def vanishing_points(self, directions, *, which: str = "+s"):
        """Vanishing points of directions ``(..., 3)`` (:class:`catadioptric.vanishing.VanishingPoints`):
        the image of the point at infinity of ``+s`` (slot 0) and, with ``which="both"``, of ``-s``
        (slot 1, ``sign`` -1). ``valid``: the ``+s`` point exists."""
        from ..vanishing import VanishingPoints

        if which not in ("+s", "both"):
            raise CatadioptricError(f"which: expected '+s' or 'both', got {which!r}")
        s = as_float_array(directions, "directions", 3)
        if np.any(~np.any(s != 0, axis=-1)):
            raise CatadioptricError("directions: expected non-zero vectors, got a zero one")
        signs = (1.0, -1.0) if which == "both" else (1.0,)
        uv, vis, sg = [], [], []
        for g in signs:
            u, v = self._project_directions(g * s)
            uv.append(u)
            vis.append(v)
            sg.append(np.where(v, g, 0.0) if g < 0 else np.full(v.shape, g))
        uv = np.stack(uv, axis=-2)
        vis = np.stack(vis, axis=-1)
        sign = np.stack(sg, axis=-1).astype(np.int8)
        valid = vis & (sign > 0)
        mp = np.full(uv.shape[:-1] + (3,), np.nan)
        return VanishingPoints(uv, mp, valid, sign, vis, vis & self.in_image(uv))

    def vanishing_curve(self, normal, **kwargs):
        """The vanishing curve of the plane with ``normal``: a list of polylines
        (:func:`catadioptric.vanishing.vanishing_curve`)."""
        from ..vanishing import vanishing_curve

        return vanishing_curve(self, normal, **kwargs)

    def directions_from_vanishing_points(self, uv) -> np.ndarray:
        """Unit oriented directions ``(..., 3)`` whose vanishing point is pixel ``uv``: the pixel's ray."""
        r = self.backproject(uv)
        return np.where(r.valid[..., None], r.directions, np.nan)

    def region(self) -> np.ndarray:
        """Boolean ``(H, W)``: the pixels whose ray the model gives and projects back onto the
        pixel within :attr:`round_trip_px` (:data:`ROUND_TRIP_PX` unless the model sets its own),
        inside :attr:`roi` when there is one."""
        uv = self.pixel_grid()
        ok = np.zeros((self.height, self.width), bool)
        rows = max(1, 2_000_000 // max(self.width, 1))  # bounded memory on big images
        for r0 in range(0, self.height, rows):
            g = uv[r0:r0 + rows]
            with np.errstate(all="ignore"):
                X, valid = self.lift(g)
                back, vb = self.project_unit(X)
                err = np.linalg.norm(back - g, axis=-1)
            ok[r0:r0 + rows] = np.asarray(valid, bool) & np.asarray(vb, bool) & (err <= self.round_trip_px)
        if self.roi is not None:
            u0, v0, rmin, rmax = self.roi
            r = np.hypot(uv[..., 0] - u0, uv[..., 1] - v0)
            ok &= (r >= rmin) & (r <= rmax)
        return ok

    # ------------------------------------------------------------------ serialisation
    def to_dict(self) -> dict:
        return {"model": self.model, "width": self.width, "height": self.height, **self.params()}

    def __repr__(self) -> str:
        p = ", ".join(f"{k}={v!r}" for k, v in self.params().items())
        return f"{type(self).__name__}({self.width}x{self.height}, {p})"
