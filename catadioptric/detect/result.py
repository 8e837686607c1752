"""What :func:`catadioptric.detect.detect_lines` returns, and its conversions (the estimator's
:class:`catadioptric.pose.ViewLines`, JSON)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._checks import CatadioptricError

__all__ = ["DetectedLines"]


@dataclass
class DetectedLines:
    """The lines detected in one image of the rig ``cam``.

    Per line ``i``: ``uv[i] (M_i, 2)`` its pixels (sub-pixel, ordered along the curve),
    ``normal[i]`` the unit normal of the plane that holds its rays (``n . d = 0`` for the rays
    ``d`` of its pixels; docs/detect.md) with ``normal_cov[i] (3, 3)``, ``rms[i]`` the pixels'
    distance to that plane's curve (pixels), ``polarity[i]`` (+1 a light band, -1 a dark band,
    0 a step edge), ``width[i]`` the band's median width (pixels, 0 for a step edge) and
    ``family[i]``: an index into ``families`` or -1 (unassigned).

    ``families``: a list of :class:`catadioptric.detect.families.Family` (``direction``, ``cov``,
    ``lines``, ``pixels``; direction signs arbitrary, keys meaningful in this view only).
    ``noise``: the image's noise (grey levels) before and after denoising, ``denoise``: the mode
    applied; ``chains``: the linked chains (``uv`` each); ``seconds``: time per stage;
    ``options``: the options used; ``annulus``: for a camera model, the mirror's disc found in the
    photograph ``(u0, v0, r_in, r_out)`` (docs/detect.md); ``appearance``: the colours either side of
    each line (:class:`catadioptric.appearance.LineAppearance`), or None.
    """

    cam: object
    uv: list
    normal: np.ndarray
    normal_cov: np.ndarray
    rms: np.ndarray
    polarity: np.ndarray
    width: np.ndarray
    family: np.ndarray
    families: list
    image_size: tuple
    noise: dict = field(default_factory=dict)
    denoise: str = "none"
    chains: list = field(default_factory=list)
    seconds: dict = field(default_factory=dict)
    options: dict = field(default_factory=dict)
    annulus: tuple | None = None  # (u0, v0, r_in, r_out) of a photograph's mirror disc (camera models)
    appearance: object = None  # LineAppearance of the lines, or None

    def __len__(self) -> int:
        return len(self.uv)

    @property
    def n_pixels(self) -> np.ndarray:
        return np.array([len(u) for u in self.uv], dtype=np.int64)

    def to_view_lines(self, *, min_pixels: int = 0, unassigned: bool = False):
        """The lines as the relative-pose estimator takes them: a
        :class:`catadioptric.pose.ViewLines` with one family key per detected family (``int``; keys
        of this view only, the estimator matches them across views) and no line ids. Lines with
        fewer than ``min_pixels`` pixels, and unassigned lines unless ``unassigned`` (then their
        family is None), are left out."""
        from ..viewlines import ViewLines

        if not (isinstance(min_pixels, (int, np.integer)) and min_pixels >= 0):
            raise CatadioptricError(f"min_pixels: expected an integer >= 0, got {min_pixels!r}")
        uv, fam, keep = [], [], []
        for i, u in enumerate(self.uv):
            f = int(self.family[i])
            if len(u) < min_pixels or (f < 0 and not unassigned):
                continue
            uv.append(u)
            fam.append(f if f >= 0 else None)
            keep.append(i)
        app = None if self.appearance is None else self.appearance.take(keep)
        return ViewLines(self.cam, uv, fam, appearance=app)

    def to_dict(self) -> dict:
        """A JSON-ready summary: per line its pixels, plane and family; per family its direction."""
        return {
            "format": "catadioptric-detected-lines/1",
            "image_size": list(self.image_size),
            "camera": self.cam.to_dict() if hasattr(self.cam, "to_dict") else None,
            "denoise": self.denoise,
            "noise": self.noise,
            "options": self.options,
            "annulus": None if self.annulus is None else list(self.annulus),
            "seconds": self.seconds,
            "families": [{"index": k, "direction": f.direction, "cov": f.cov, "std_deg": f.std_deg,
                          "lines": f.lines, "pixels": f.pixels} for k, f in enumerate(self.families)],
            "lines": [{"index": i, "family": int(self.family[i]), "uv": self.uv[i], "normal": self.normal[i],
                       "normal_cov": self.normal_cov[i], "rms": float(self.rms[i]),
                       "polarity": int(self.polarity[i]), "width": float(self.width[i]),
                       **({} if self.appearance is None else {"sides": self.appearance.to_dict(i)})}
                      for i in range(len(self.uv))],
        }
