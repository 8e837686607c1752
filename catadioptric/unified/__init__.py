"""The unified central model of catadioptric cameras (Geyer and Daniilidis 2000; Barreto and
Araujo 2001; Mei and Rives 2007), its exact parameters for a central rig, and the best central
approximation of a non-central one.

* :mod:`catadioptric.unified.model`: the model (:class:`UnifiedCamera`: projection,
  back-projection, vanishing points, images of lines) and the image conic of a plane; its
  docstring states the model and its conventions.
* :mod:`catadioptric.unified.fit`: :func:`unified_from_central` (exact, central rigs) and
  :func:`fit_unified` (the best central approximation of any rig).

docs/unified.md states both in full, with the derivations.
"""
from __future__ import annotations

from . import fit as _fit, model as _model
from .fit import UnifiedFit, fit_unified, unified_from_central
from .model import (DEFAULT_DEPTHS, LineImageSamples, UnifiedCamera, UnifiedProjection, UnifiedRays,
                    UnifiedVanishingPoints, conic_from_plane_normal)

__all__ = [*_model.__all__, *_fit.__all__]
