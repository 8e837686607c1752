"""An overlay of detected lines on their image: each line's pixels drawn as a polyline coloured by
its family (unassigned lines grey), each family's vanishing points as rings of its colour."""
from __future__ import annotations

import numpy as np

__all__ = ["overlay_image", "FAMILY_COLOURS"]

#: RGB colours of families 0, 1, ... (then repeated)
FAMILY_COLOURS = [(230, 25, 75), (60, 180, 75), (255, 225, 25), (0, 130, 200), (245, 130, 48), (145, 30, 180),
                  (70, 240, 240), (240, 50, 230), (210, 245, 60), (250, 190, 212), (0, 128, 128), (220, 190, 255),
                  (170, 110, 40), (128, 0, 0), (170, 255, 195), (128, 128, 0)]
_UNASSIGNED = (160, 160, 160)


def overlay_image(image, det, *, scale: int = 2, truth: list | None = None, vanishing_points: bool = True,
                  colours: dict | None = None) -> np.ndarray:
    """RGB ``uint8`` image, ``scale`` times the size of ``image``: the image darkened, ``det``'s
    lines (a :class:`~catadioptric.detect.DetectedLines`) drawn by family, the families' vanishing
    points (when ``vanishing_points``) as rings; ``truth``: optional labelled curves (dicts with
    ``uv``) drawn thin in white underneath. ``colours``: ``{family index: colour index}`` (into
    ``FAMILY_COLOURS``) to colour families as another view's (families left out are drawn grey,
    without their vanishing points); default: each family its own index."""
    import cv2

    from .image import to_grey

    base = np.asarray(image)
    if base.ndim == 3 and base.shape[2] >= 3:
        rgb = np.stack([to_grey(base[..., k]) for k in range(3)], axis=2)
    else:
        rgb = np.repeat(to_grey(base)[..., None], 3, axis=2)
    out = (0.55 * np.clip(rgb, 0, 255)).astype(np.uint8)
    out = cv2.resize(out, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
    shift = 4  # cv2 fixed-point sub-pixel drawing

    def poly(uv, colour, thick):
        uv = np.asarray(uv)
        p = np.rint(((uv + 0.5) * scale - 0.5) * (1 << shift)).astype(np.int32)
        # one polyline per run of points less than 3 pixels apart
        cut = np.flatnonzero(np.linalg.norm(np.diff(uv, axis=0), axis=1) > 3.0) + 1
        for run in np.split(p, cut):
            if len(run) >= 2:
                cv2.polylines(out, [run.reshape(-1, 1, 2)], False, colour, thick, cv2.LINE_AA, shift)

    for t in truth or []:
        poly(t["uv"], (255, 255, 255), 1)
    colour_of = {f: f for f in range(len(det.families))} if colours is None else colours
    for i, uv in enumerate(det.uv):
        c = colour_of.get(int(det.family[i]))
        poly(uv, FAMILY_COLOURS[c % len(FAMILY_COLOURS)] if c is not None else _UNASSIGNED, 2 if c is not None else 1)
    if vanishing_points:
        for f, fam in enumerate(det.families):
            if colour_of.get(f) is None:
                continue
            col = FAMILY_COLOURS[colour_of[f] % len(FAMILY_COLOURS)]
            for s in (fam.direction, -fam.direction):
                try:
                    vp = det.cam.vanishing_points(s)
                except Exception:  # a direction the rig cannot image
                    continue
                for k in np.flatnonzero(np.asarray(vp.valid).reshape(-1)):
                    uv = np.asarray(vp.uv).reshape(-1, 2)[k]
                    if np.all(np.isfinite(uv)):
                        c = tuple(int(x) for x in np.rint((uv + 0.5) * scale - 0.5))
                        cv2.circle(out, c, 5 * scale, col, 2, cv2.LINE_AA)
    return out
