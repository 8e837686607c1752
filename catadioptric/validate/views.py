"""Reading the views of a rendered dataset (docs/formats.md, "Datasets") for the experiments."""
from __future__ import annotations

import json
import os
from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError
from ..cameras import CatadioptricCamera
from ..frames import RigPose


@dataclass
class View:
    """One view of a dataset: the rig, its pose, the label image, the beauty image and the
    ground-truth tables (lines with their labels and families; families with their directions)."""

    name: str
    folder: str
    cam: CatadioptricCamera
    pose: RigPose
    labels: np.ndarray
    beauty: np.ndarray
    lines: list
    families: list


def load_view(folder: str) -> View:
    import cv2

    from ..render.common import decode_labels_png

    gt_path = os.path.join(folder, "groundtruth.json")
    if not os.path.exists(gt_path):
        raise CatadioptricError(f"folder: expected a dataset view with groundtruth.json, got {folder!r}")
    with open(gt_path) as f:
        gt = json.load(f)
    cam = CatadioptricCamera.from_dict(gt["camera"])
    pose = RigPose(np.array(gt["pose"]["R"]), np.array(gt["pose"]["t"]))
    lab = cv2.imread(os.path.join(folder, gt["labels"]["file"]), cv2.IMREAD_UNCHANGED)
    labels = decode_labels_png(lab)
    beauty = cv2.imread(os.path.join(folder, "beauty.png"), cv2.IMREAD_COLOR)
    beauty = beauty[..., ::-1].copy() if beauty is not None else None
    return View(gt["view"], folder, cam, pose, labels, beauty, gt["lines"], gt["families"])


def load_dataset(folder: str) -> list[View]:
    """Every view of a dataset, in the manifest's order."""
    man = os.path.join(folder, "manifest.json")
    if not os.path.exists(man):
        raise CatadioptricError(f"dataset: expected a folder with manifest.json, got {folder!r}")
    with open(man) as f:
        m = json.load(f)
    names = [v.get("folder", v.get("name")) if isinstance(v, dict) else v for v in m.get("views", [])]
    if not names:
        names = sorted(d for d in os.listdir(folder) if os.path.isdir(os.path.join(folder, d)))
    return [load_view(os.path.join(folder, n)) for n in names]


def line_pixels(view: View, label: int, *, ridge: bool = True) -> np.ndarray:
    """Pixel centres ``(M, 2)`` (u, v) carrying ``label`` in the view's label image.

    A line is drawn as a tube whose image is a band several pixels wide near the camera;
    with ``ridge`` only the band's centre pixels are kept: those whose distance to the band's
    edge is a local maximum across the band (a one-pixel ridge of the distance transform).
    """
    mask = view.labels == label
    if not ridge:
        rows, cols = np.nonzero(mask)
        return np.stack([cols, rows], axis=1).astype(float)
    import cv2

    d = cv2.distanceTransform(np.pad(mask, 1).astype(np.uint8), cv2.DIST_L2, 5)
    core = d[1:-1, 1:-1]
    ridge_px = np.zeros_like(mask)
    # a ridge pixel is a strict local maximum of the distance across the band: along one of the
    # four directions it is at least both neighbours and above one of them
    for dy, dx in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = d[1 + dy: d.shape[0] - 1 + dy, 1 + dx: d.shape[1] - 1 + dx]
        b = d[1 - dy: d.shape[0] - 1 - dy, 1 - dx: d.shape[1] - 1 - dx]
        ridge_px |= (core >= a) & (core >= b) & ((core > a) | (core > b))
    keep = mask & ridge_px
    rows, cols = np.nonzero(keep)
    return np.stack([cols, rows], axis=1).astype(float)
