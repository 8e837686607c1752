"""The label-to-pixels step lives in :mod:`catadioptric.observations` (below both ``detect`` and
``validate``); this name re-exports it for the modules of ``validate`` that still import it here."""
from ..observations import PIXEL_MODES, LinePixels, curve_pixels, label_near, line_pixels, ridge_pixels

__all__ = ["LinePixels", "line_pixels", "ridge_pixels", "curve_pixels", "label_near", "PIXEL_MODES"]
