"""The step bound of traced curves (catadioptric.curves.trace), checked independently."""
import numpy as np


def max_step_excess(uv, width, height, step=1.0, off_image=0.5):
    """How far consecutive vertices of a polyline ``uv (M, 2)`` exceed their allowed distance:
    ``step`` on the image and within one image size around it, plus ``off_image`` times the
    distance from that margin beyond. <= 0 everywhere when the bound holds."""
    if len(uv) < 2:
        return 0.0
    m = max(width, height)
    du = np.maximum(np.maximum(-0.5 - m - uv[:, 0], uv[:, 0] - (width - 0.5 + m)), 0.0)
    dv = np.maximum(np.maximum(-0.5 - m - uv[:, 1], uv[:, 1] - (height - 0.5 + m)), 0.0)
    out = np.hypot(du, dv)
    allow = step + off_image * np.maximum(out[:-1], out[1:])
    return float(np.max(np.linalg.norm(np.diff(uv, axis=0), axis=1) - allow))
