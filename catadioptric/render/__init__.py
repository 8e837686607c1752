"""Rendering of scenes through exact quadric mirrors (POV-Ray, Mitsuba 3), our float64 label
tracer, per-view ground truth and datasets on disk.

Heavy dependencies (mitsuba, trimesh, OpenCV, matplotlib, dask) load only in the
modules that need them.
"""
