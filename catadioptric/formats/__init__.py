"""The calibration files of the tools people use, one module per tool, each with its reader and
its writer: OpenCV omnidir (:mod:`.opencv`), Kalibr (:mod:`.kalibr`), OCamCalib
(:mod:`.ocamcalib`), COLMAP (:mod:`.colmap`, writer only). :func:`load_camera` reads any of the
readable ones, recognised by content."""
from __future__ import annotations
