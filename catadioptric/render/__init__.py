"""Rendering of scenes through exact quadric mirrors (POV-Ray, Mitsuba 3), our float64 label
tracer, per-view ground truth and datasets on disk.

    from catadioptric.render import render, trace_labels, ground_truth, render_dataset

Heavy dependencies (mitsuba, OpenCV, dask, tqdm) load only in the modules that need them;
the names below are imported on first use.
"""
from __future__ import annotations

import importlib

__all__ = ["render", "render_mitsuba", "render_povray", "trace_labels", "trace_rays", "ground_truth",
           "render_dataset", "RenderResult", "RenderError", "LABEL_SKY", "LABEL_NO_MIRROR", "LABEL_MIRROR_AGAIN"]

_WHERE = {
    "render_mitsuba": "mitsuba", "render_povray": "povray", "trace_labels": "tracer", "trace_rays": "tracer",
    "ground_truth": "groundtruth", "render_dataset": "dataset", "RenderResult": "common", "RenderError": "common",
    "LABEL_SKY": "tracer", "LABEL_NO_MIRROR": "tracer", "LABEL_MIRROR_AGAIN": "tracer",
}


def render(scene, cam, pose, renderer: str = "mitsuba", quality="standard", **kwargs):
    """Render one view with ``renderer`` (``"mitsuba"`` or ``"povray"``): a :class:`RenderResult`
    with ``beauty (H, W, 3)`` uint8 and ``labels (H, W)`` int32."""
    from .._checks import CatadioptricError

    if renderer == "mitsuba":
        from .mitsuba import render_mitsuba as fn
    elif renderer == "povray":
        from .povray import render_povray as fn
    else:
        raise CatadioptricError(f"renderer: expected 'mitsuba' or 'povray', got {renderer!r}")
    return fn(scene, cam, pose, quality, **kwargs)


def __getattr__(name):
    if name in _WHERE:
        return getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
