"""Lines and families from one image of a catadioptric rig, with no labels.

``detect_lines(image, cam, **options) -> DetectedLines``: sub-pixel edges in the mirror's image
region, the two edges of each line tube paired into its centre line, chains, line curves (the
plane holding each line's rays, robust along chains, pieces of one line merged) and families of
parallel lines; ``DetectedLines.to_view_lines()`` gives the relative-pose estimator's input.
``evaluate_view`` scores a detection against a rendered view's labels, ``evaluate_dataset`` every
view of a dataset (with a report). See docs/detect.md.

| stage | module |
|---|---|
| grey levels, noise, denoising | `image.py` |
| the mirror's image region | `region.py` |
| sub-pixel edges (Canny + parabola across the edge) | `edges.py` |
| band centres (tube edges paired) and step edges | `centres.py` |
| chains (linking, resampling) | `chains.py` |
| the plane model of a line's rays, distances, covariance | `catadioptric/linefit/planes.py` (shared with `fit_interpretation_plane`) |
| line curves (MSAC along chains, merging) | `curves.py` |
| lines grown along their curves over every edge point (option `grow_gap_px`, off) | `grow.py` |
| families (voting over directions) | `families.py` |
| families of two views at once, under their rotation (the small ones one image cannot single out) | `joint_families.py` |
| the orchestration, options and presets | `detector.py` |
| the result and its conversions | `result.py` |
| scores against the labels | `evaluate.py` |
| datasets scored, reports | `report.py` |
| the overlay image | `overlay.py` |
| `catadioptric detect` | `cli.py` |
"""
from __future__ import annotations

from .detector import DEFAULTS, PRESETS, detect_lines, preset_options
from .evaluate import evaluate_view, label_curves
from .families import Family
from .report import evaluate_dataset
from .result import DetectedLines

__all__ = ["detect_lines", "DetectedLines", "Family", "DEFAULTS", "PRESETS", "preset_options", "evaluate_view",
           "label_curves", "evaluate_dataset"]
