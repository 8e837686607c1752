"""The main jobs, one call each (also ``catadioptric.detect_lines``, ``catadioptric.relative_pose``,
``catadioptric.relative_pose_from_labels``):

- :func:`detect_lines`: the line curves and families of one image (docs/detect.md);
- :func:`relative_pose`: the relative pose of two images from the lines they show
  (docs/relative_pose.md, "From two images");
- :func:`relative_pose_from_labels`: the relative pose of two views of a rendered dataset from
  their labelled lines, with the truth beside it (docs/relative_pose.md).

Each takes a camera as an object (a :class:`~catadioptric.CatadioptricCamera` or a camera model
of :mod:`catadioptric.models`) or by name: a rig name or rig spec file, a calibration file of
OpenCV omnidir, Kalibr or OCamCalib (:func:`catadioptric.formats.load_camera`), or a dataset view
folder, exactly as the command line's ``--rig``. Images are arrays or image files. Each returns a
result object with ``to_dict()`` (JSON-ready, the same fields as the command's output file)."""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ._checks import CatadioptricError

__all__ = ["detect_lines", "relative_pose", "relative_pose_from_labels", "camera_from", "LabelPose"]


def _image(image, name: str) -> np.ndarray:
    if isinstance(image, (str, os.PathLike)):
        from .detect.cli import read_image

        return read_image(os.fspath(image))
    if not isinstance(image, np.ndarray):
        raise CatadioptricError(f"{name}: expected an image array or an image file, got {type(image).__name__}")
    return image


def camera_from(camera, *, image=None, kalibr_camera: str | None = None):
    """A camera object as given, or the camera named by ``camera`` (module docstring; a rig takes
    the size of ``image`` when given, a calibration must match it)."""
    if not isinstance(camera, (str, os.PathLike)):
        if not (hasattr(camera, "backproject") and hasattr(camera, "project")):
            raise CatadioptricError(f"camera: expected a camera object, a rig name or a file, got "
                                    f"{type(camera).__name__}")
        return camera
    from .cliargs import resolve_rig
    from .detect.cli import camera_from_folder

    value = os.fspath(camera)
    if os.path.isdir(value):
        return camera_from_folder(value, "camera")
    h, w = (None, None) if image is None else np.asarray(image).shape[:2]
    return resolve_rig(value, width=w, height=h, flag="camera", camera=kalibr_camera, calibrations=True)[0]


def detect_lines(image, camera, *, mask=None, **options):
    """The lines and families of ``image`` (array or file) seen by ``camera``: a
    :class:`catadioptric.detect.DetectedLines` (``families[k].direction``: unit vectors in the
    camera's frame; ``to_dict()``). ``mask``: non-zero where a pixel may be used. ``options``: those
    of :func:`catadioptric.detect.detect_lines`."""
    from .detect import detect_lines as detect

    img = _image(image, "image")
    return detect(img, camera_from(camera, image=img), mask=None if mask is None else _image(mask, "mask"), **options)


def relative_pose(image_a, image_b, camera, camera_b=None, *, max_rotation_deg: float | None = None, masks=(None, None),
                  **options):
    """The relative pose ``x_B = R x_A + t`` of two images (arrays or files) from their lines alone: a
    :class:`catadioptric.twoview.ImagePairPose` (``.pose.R``, ``.pose.t``, ``.pose.ambiguous``,
    ``.pose.candidates``; ``to_dict()``: the fields of ``pose.json``). ``max_rotation_deg``: a prior
    on the turn between the views (without one a symmetric scene is often ``ambiguous``);
    ``masks``: per image, non-zero where a pixel may be used; ``options``: those of
    :func:`catadioptric.twoview.relative_pose_from_images`."""
    from .twoview import relative_pose_from_images

    a, b = _image(image_a, "image_a"), _image(image_b, "image_b")
    cam_a = camera_from(camera, image=a)
    cam_b = cam_a if camera_b is None else camera_from(camera_b, image=b)
    m = tuple(None if x is None else _image(x, "mask") for x in masks)
    return relative_pose_from_images(a, b, cam_a, cam_b, max_rotation_deg=max_rotation_deg, masks=m, **options)


@dataclass
class LabelPose:
    """What :func:`relative_pose_from_labels` returns: ``pose`` (a :class:`catadioptric.pose.RelativePose`,
    ``x_B = R x_A + t`` between the views' mirror frames), the truth ``R_gt``, ``t_gt`` from the
    dataset's poses, and the errors: ``rotation_error_deg``, ``translation_error`` (metres when the
    answer is metric, else degrees between the directions; None without a translation)."""

    views: tuple
    pose: object
    R_gt: np.ndarray
    t_gt: np.ndarray
    rotation_error_deg: float
    translation_error: float | None

    def to_dict(self) -> dict:
        p = self.pose
        return {"format": "catadioptric-label-pose/1", "views": list(self.views), "R": p.R, "t": p.t,
                "metric": p.metric, "model": p.model, "cov": p.cov, "translation_observable": p.translation_observable,
                "ambiguous": p.ambiguous, "margin": p.margin, "lines_matched": p.lines_matched,
                "candidates": [c.summary() for c in p.candidates], "notes": p.notes, "R_gt": self.R_gt,
                "t_gt": self.t_gt, "rotation_error_deg": self.rotation_error_deg,
                "translation_error": self.translation_error}


def relative_pose_from_labels(dataset, view_a: str, view_b: str, *, noise_px: float = 0.0, seed: int = 0,
                              min_pixels: int = 30, **options) -> LabelPose:
    """The relative pose of views ``view_a``, ``view_b`` of a rendered ``dataset`` (a folder or a
    :class:`catadioptric.Dataset`) from the pixels of their labelled lines (the labels say which
    line of A is which of B, and its family), with Gaussian noise of
    ``noise_px`` pixels drawn from ``seed``; ``options``: those of :func:`catadioptric.pose.relative_pose`."""
    from .dataset import Dataset
    from .pose import ViewLines, rotation_angle_deg
    from .pose import relative_pose as from_lines
    from .observations import line_pixels

    ds = dataset if isinstance(dataset, Dataset) else Dataset(dataset)
    va, vb = ds.view_pair((view_a, view_b))
    rng = np.random.default_rng(seed)
    lines = [line_pixels(v, noise_px=noise_px, rng=rng, min_pixels=min_pixels) for v in (va, vb)]
    views = [ViewLines(v["camera"], b.uv, b.family, b.segment) for v, b in zip((va, vb), lines)]
    pose = from_lines(views[0], views[1], seed=seed, **options)
    pa, pb = va["pose"], vb["pose"]
    R_gt = pb.R @ pa.R.T
    t_gt = pb.t - R_gt @ pa.t
    t_err = None
    if pose.t is not None:
        if pose.metric:
            t_err = float(np.linalg.norm(pose.t - t_gt))
        elif np.linalg.norm(pose.t) > 0:
            c = pose.t @ t_gt / (np.linalg.norm(pose.t) * np.linalg.norm(t_gt))
            t_err = float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
    return LabelPose((view_a, view_b), pose, R_gt, t_gt, rotation_angle_deg(pose.R @ R_gt.T), t_err)
