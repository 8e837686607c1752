"""``catadioptric detect``: the lines and families of one image (or of every view of a rendered
dataset, scored against its labels)."""
from __future__ import annotations

import os

import numpy as np

from .._checks import CatadioptricError
from .detector import PRESETS
from ..cliargs import CALIBRATION_RIG_HELP, check_out_dir, nonnegative_float, positive_float, positive_int, resolve_rig

__all__ = ["register", "read_image", "read_mask", "camera_from_folder"]


def read_image(path: str) -> np.ndarray:
    """An image file (anything OpenCV reads: PNG 8/16-bit, JPEG, TIFF...) as RGB, or a ``.npy`` array."""
    import cv2

    if not os.path.isfile(path):
        if os.path.isdir(path):
            raise CatadioptricError(f"IMAGE: expected an image file, got the folder {path!r}")
        if os.path.exists(path):
            raise CatadioptricError(f"IMAGE: expected an image file, got {path!r}, which is not a regular file (a "
                                    f"device, a pipe or a socket)")
        raise CatadioptricError(f"IMAGE: expected an image file, a dataset view folder or a dataset folder, got "
                                f"{path!r}, which does not exist")
    if os.path.getsize(path) == 0:
        raise CatadioptricError(f"IMAGE: expected an image file, got {path!r}, an empty file")
    if path.lower().endswith(".npy"):
        try:
            img = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise CatadioptricError(f"IMAGE: {path!r} is not a readable .npy array ({exc})") from None
        if not isinstance(img, np.ndarray) or img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] not in (1, 3, 4)):
            raise CatadioptricError(f"IMAGE: expected an image array of shape (H, W) or (H, W, 3), got {path!r}, an "
                                    f"array of shape {getattr(img, 'shape', ())}, which is not an image")
        return img
    img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if img is None:
        raise CatadioptricError(f"IMAGE: {path!r} is not an image OpenCV can read")
    if img.ndim == 3:
        img = img[..., [2, 1, 0]] if img.shape[2] == 3 else img[..., [2, 1, 0, 3]][..., :3]
    return np.ascontiguousarray(img)


def read_mask(path: str, shape, flag: str = "--mask") -> np.ndarray:
    """A mask image (non-zero: use the pixel) as a boolean ``(H, W)`` array; its size must be
    ``shape`` (the image's)."""
    import cv2

    from .region import check_mask

    if not os.path.isfile(path):
        raise CatadioptricError(f"{flag}: expected a mask image file, got {path!r}, which is not a file")
    m = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if m is None:
        raise CatadioptricError(f"{flag}: {path!r} is not an image OpenCV can read")
    try:
        return check_mask(m, shape, flag)
    except CatadioptricError as exc:
        raise CatadioptricError(f"{exc} ({path})") from None


def _dataset_of(folder: str):
    """``(Dataset, view name or None)`` for a dataset folder or one of its view folders, else None."""
    from ..dataset import Dataset

    folder = os.path.abspath(folder)
    if os.path.isfile(os.path.join(folder, "manifest.json")):
        return Dataset(folder), None
    parent = os.path.dirname(folder)
    if os.path.isfile(os.path.join(parent, "manifest.json")):
        ds = Dataset(parent)
        name = os.path.basename(folder)
        for n in ds.names:
            if n == name or os.path.basename(ds[n]["folder"]) == name:
                return ds, n
    return None


def camera_from_folder(folder: str, flag: str = "--rig"):
    """The camera stored with a dataset (its manifest) or one of its views."""
    found = _dataset_of(folder)
    if found is None:
        raise CatadioptricError(f"{flag}: expected a rig name, a rig spec file, a dataset folder or a dataset view "
                                f"folder, got the folder {folder!r}")
    ds, name = found
    return ds.camera if name is None else ds[name]["camera"]


def _options(args) -> dict:
    from .detector import preset_options

    o = {}
    for k in ("denoise", "sigma", "threshold", "max_width", "min_pixels", "min_family_lines"):
        v = getattr(args, k)
        if v is not None:
            o[k] = v
    return preset_options(args.preset, o)


def _run(args) -> int:
    from .._io import atomic_write_json
    from .detector import check_options, detect_lines
    from .image import check_image_size
    from .overlay import overlay_image
    from .report import evaluate_dataset, markdown_table, write_png

    check_out_dir(args.out)
    options = _options(args)
    for k, v in options.items():  # the options' own checks, addressed to their flags
        try:
            check_options({k: v})
        except CatadioptricError as exc:
            raise CatadioptricError(f"--{k.replace('_', '-')}: {str(exc).split(': ', 1)[-1]}") from None
    target = args.input
    if os.path.isdir(target):
        found = _dataset_of(target)
        if found is None:
            raise CatadioptricError(f"IMAGE: expected an image file, a dataset view folder or a dataset folder, got "
                                    f"the folder {target!r} (no manifest.json in it or its parent)")
        ds, name = found
        if args.rig is not None:
            raise CatadioptricError("--rig: a dataset's views are detected with their stored camera; leave --rig out")
        views = [name] if name is not None else args.views
        scoring = {"tolerance": args.tolerance}
        res = evaluate_dataset(ds.path, args.out, views=views, options=options, scoring=scoring,
                               progress=not args.no_progress)
        print(markdown_table([{"view": "mean", **res["summary"]}]))
        print(f"wrote {os.path.join(args.out, 'report.json')}, report.md and one folder per view")
        return 0
    if args.views:
        raise CatadioptricError("--views: only for a dataset folder, got an image file")
    image = read_image(target)
    if args.rig is None:
        raise CatadioptricError("--rig: expected the rig of the image (a rig name, a rig spec file, or a dataset "
                                "(view) folder whose stored camera took it)")
    h, w = image.shape[:2]
    check_image_size(w, h, "IMAGE")
    if os.path.isdir(args.rig):
        cam = camera_from_folder(args.rig)
    else:
        cam, _ = resolve_rig(args.rig, width=w, height=h, camera=args.camera, calibrations=True)
    mask = read_mask(args.mask, (h, w)) if args.mask else None
    det = detect_lines(image, cam, mask=mask, **options)
    os.makedirs(args.out, exist_ok=True)
    out = {"image": os.path.abspath(target), "rig": args.rig, "mask": os.path.abspath(args.mask) if args.mask else None,
           **det.to_dict()}
    atomic_write_json(os.path.join(args.out, "lines.json"), out)
    write_png(os.path.join(args.out, "overlay.png"), overlay_image(image, det))
    n_ass = int(np.sum(det.family >= 0))
    print(f"{len(det)} lines ({n_ass} in {len(det.families)} families), denoise {det.denoise}, "
          f"{det.seconds['total']:.2f} s; wrote {os.path.join(args.out, 'lines.json')} and overlay.png")
    return 0


def register(sub) -> None:
    p = sub.add_parser("detect", help="lines and families of one image (or a dataset's views, scored)",
                       description="Detect the line curves of an image of a catadioptric rig and group them into "
                                   "families of parallel lines, from the image alone (docs/detect.md). IMAGE may "
                                   "also be a dataset (view) folder: its views are detected with their stored "
                                   "camera and scored against their labels.")
    p.add_argument("input", metavar="IMAGE", help="an image file (PNG, JPEG, TIFF, .npy), a dataset view folder or a "
                                                  "dataset folder")
    p.add_argument("--rig", metavar="RIG", help=CALIBRATION_RIG_HELP + ", or a dataset (view) folder whose stored camera to use")
    p.add_argument("--camera", metavar="camN", help="the camera of a Kalibr camchain given as --rig (cam0, cam1, ...)")
    p.add_argument("--mask", metavar="PNG", help="a mask of the image's size: non-zero where a pixel may be used "
                                                 "(zero on what moves or does not belong to the scene)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--views", nargs="+", metavar="VIEW", help="dataset views to detect (default: all)")
    p.add_argument("--denoise", choices=["auto", "nlmeans", "bilateral", "none"],
                   help="denoising before the edges (default auto: non-local means when the image is noisy)")
    presets = "; ".join(f"{n} = " + " ".join(f"--{k.replace('_', '-')} {v:g}" for k, v in o.items())
                        for n, o in PRESETS.items())
    p.add_argument("--preset", choices=sorted(PRESETS),
                   help="options for a kind of scene (catadioptric.detect.PRESETS; the flags below override them): "
                        f"{presets} (docs/detect.md, \"Presets\")")
    p.add_argument("--sigma", type=positive_float, help="Gaussian of the gradients, pixels (default 1)")
    p.add_argument("--threshold", type=positive_float, help="pixel distance of a line's pixels to its curve "
                                                            "(default 1)")
    p.add_argument("--max-width", type=positive_float, metavar="PX",
                   help="widest band whose two edges are paired into its centre line, pixels (default 6)")
    p.add_argument("--min-pixels", type=positive_int, help="shortest line kept, pixels (default 20)")
    p.add_argument("--min-family-lines", type=positive_int, help="fewest lines of a family (default 3)")
    p.add_argument("--tolerance", type=nonnegative_float, default=1.5,
                   help="datasets: distance (pixels) within which a detected pixel recovers a labelled one "
                        "(default 1.5)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_run)
