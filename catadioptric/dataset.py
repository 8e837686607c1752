"""Reading a rendered dataset (``catadioptric render``; format: docs/formats.md, "Datasets").

    ds = catadioptric.Dataset("render/out/urban")   # reads manifest.json only
    len(ds), ds.names                                # the views, in the manifest's order
    v = ds[0]                                        # or ds["A"]: one view, nothing read yet
    v["labels"], v["beauty"], v["curves"]            # each read on first use, then kept

A view is a read-only mapping of plain values (numpy arrays, lists, dicts) plus the view's
``camera`` (:class:`~catadioptric.CatadioptricCamera`) and ``pose`` (:class:`~catadioptric.RigPose`);
``dict(v)`` reads everything. Before the first file of a view is read, its ``done.json`` is
checked: the view must be finished and (``verify=True``, the default) every file must match
the SHA-256 the marker records; a view that is missing, unfinished or altered is an error
that says which and how to repair it (rerun the ``render`` command: it resumes).
"""
from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence

import numpy as np

from ._checks import CatadioptricError
from ._io import sha256_file

__all__ = ["Dataset", "DatasetView", "VIEW_KEYS"]

DATASET_FORMAT = "catadioptric-dataset/1"

#: The keys of a view (each read on first use). Optional files add ``depth``, ``ray_origins``,
#: ``ray_directions`` (``rays.npz``), ``beauty16`` (``beauty16.png``) and ``beauty_hdr`` (``beauty_hdr.npz``)
#: when the dataset has them.
VIEW_KEYS = ("name", "folder", "camera", "pose", "beauty", "labels", "label_ambiguous", "groundtruth", "arrays",
             "objects", "lines", "families", "curves", "vanishing_points", "ground_curve")


def _read_json(path: str, what: str) -> dict:
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
    except FileNotFoundError:
        raise CatadioptricError(f"{what}: no file {path!r}") from None
    except (OSError, ValueError) as exc:
        raise CatadioptricError(f"{what}: {path!r} is not readable JSON ({exc})") from None
    if not isinstance(data, dict):
        raise CatadioptricError(f"{what}: {path!r} must hold a JSON object, got {type(data).__name__}")
    return data


class Dataset(Sequence):
    """A dataset folder written by ``catadioptric render``: ``len()``, indexing by position or by
    view name, iteration; each item a lazy :class:`DatasetView`. ``verify``: check every file of a
    view against the SHA-256 in its ``done.json`` before reading it (default True).

    Attributes: ``path``, ``manifest`` (the parsed ``manifest.json``), ``names`` (view names),
    ``camera`` (the rig as rendered, a ``CatadioptricCamera``), ``mesh_path`` (the scene mesh
    file, or None when the dataset has none).
    """

    def __init__(self, path, *, verify: bool = True):
        self.path = os.fspath(path)
        if not os.path.isdir(self.path):
            raise CatadioptricError(f"path: expected a dataset folder (written by `catadioptric render`), "
                                    f"got {self.path!r}, which is not a folder")
        man = os.path.join(self.path, "manifest.json")
        if os.path.isdir(man):
            raise CatadioptricError(f"path: expected a dataset folder with a manifest.json file, got {self.path!r}, "
                                    f"whose manifest.json is a folder")
        if not os.path.isfile(man):
            raise CatadioptricError(f"path: expected a dataset folder with manifest.json, got {self.path!r} (no "
                                    f"manifest: not a dataset, or its render never finished a run)")
        self.manifest = _read_json(man, "manifest")
        fmt = self.manifest.get("format")
        if fmt != DATASET_FORMAT:
            raise CatadioptricError(f"manifest: expected format {DATASET_FORMAT!r}, got {fmt!r} in {man!r}")
        views = self.manifest.get("views")
        if not isinstance(views, list) or not all(isinstance(v, dict) and "name" in v for v in views):
            raise CatadioptricError(f"manifest: expected a list of views with names in {man!r}")
        self._views = [(v["name"], v.get("folder", v["name"])) for v in views]
        self.names = [n for n, _ in self._views]
        self.verify = bool(verify)

    def __len__(self) -> int:
        return len(self._views)

    def __getitem__(self, key) -> "DatasetView":
        if isinstance(key, slice):
            return [self[i] for i in range(*key.indices(len(self)))]
        if isinstance(key, str):
            if key not in self.names:
                raise KeyError(f"view: expected one of {self.names}, got {key!r}")
            key = self.names.index(key)
        if not isinstance(key, (int, np.integer)) or isinstance(key, bool):
            raise TypeError(f"index: expected a position or a view name, got {type(key).__name__}")
        i = int(key)
        if not -len(self) <= i < len(self):
            raise IndexError(f"index: expected a position in [{-len(self)}, {len(self)}), got {i}")
        name, folder = self._views[i]
        return DatasetView(self, name, os.path.join(self.path, folder))

    def view_pair(self, names) -> tuple:
        """The two views named ``names = (A, B)``, checked: two names, both in the dataset, different
        (a one-line :class:`CatadioptricError` otherwise)."""
        names = list(names)
        if len(names) != 2:
            raise CatadioptricError(f"views: expected two view names, got {names}")
        missing = [n for n in names if n not in self.names]
        if missing:
            raise CatadioptricError(f"views: expected names among {self.names}, got unknown {missing}")
        if names[0] == names[1]:
            raise CatadioptricError(f"views: expected two different views, got {names[0]!r} twice (a view's pose "
                                    f"relative to itself has no baseline to find)")
        return self[names[0]], self[names[1]]

    @property
    def camera(self):
        from .cameras import CatadioptricCamera

        return CatadioptricCamera.from_dict(self.manifest["rig"]["camera"])

    @property
    def mesh_path(self) -> str | None:
        name = (self.manifest.get("scene") or {}).get("mesh")
        p = os.path.join(self.path, name) if name else None
        return p if p and os.path.isfile(p) else None

    def __repr__(self) -> str:
        return f"Dataset({self.path!r}, {len(self)} views: {self.names})"


class DatasetView(Mapping):
    """One view of a :class:`Dataset`: a read-only mapping whose values are read on first use
    (see :data:`VIEW_KEYS` and docs/formats.md, "Reading a dataset")."""

    def __init__(self, dataset: Dataset, name: str, folder: str):
        self.dataset, self.name, self.folder = dataset, name, folder
        self._cache: dict = {"name": name, "folder": folder}
        self._checked = False
        self._keys = list(VIEW_KEYS)
        if os.path.isfile(os.path.join(folder, "rays.npz")):
            self._keys += ["depth", "ray_origins", "ray_directions"]
        if os.path.isfile(os.path.join(folder, "beauty16.png")):
            self._keys.append("beauty16")
        if os.path.isfile(os.path.join(folder, "beauty_hdr.npz")):
            self._keys.append("beauty_hdr")

    # ---------------------------------------------------------------- checks
    def _check(self) -> None:
        if self._checked:
            return
        where = f"view {self.name!r} of {self.dataset.path!r}"
        rerun = "rerun the `catadioptric render` command that wrote it (it resumes and redoes this view)"
        if not os.path.isdir(self.folder):
            raise CatadioptricError(f"dataset: {where} has no folder {self.folder!r}; {rerun}")
        marker = os.path.join(self.folder, "done.json")
        if not os.path.isfile(marker):
            raise CatadioptricError(f"dataset: {where} is unfinished (no done.json: the render stopped before "
                                    f"this view was complete); {rerun}")
        try:
            files = _read_json(marker, "done.json").get("files")
        except CatadioptricError as exc:
            raise CatadioptricError(f"dataset: {where}: {exc}; {rerun}") from None
        if not isinstance(files, dict) or not files:
            raise CatadioptricError(f"dataset: {where}: done.json lists no files; {rerun}")
        for fname, digest in files.items():
            p = os.path.join(self.folder, fname)
            if not os.path.isfile(p):
                raise CatadioptricError(f"dataset: {where}: {fname} is missing; {rerun}")
            if self.dataset.verify and sha256_file(p) != digest:
                raise CatadioptricError(f"dataset: {where}: {fname} differs from the file the render wrote "
                                        f"(SHA-256 mismatch: altered or corrupted); {rerun}")
        self._checked = True

    # ---------------------------------------------------------------- mapping
    def __getitem__(self, key):
        if key in self._cache:
            return self._cache[key]
        if key not in self._keys:
            raise KeyError(f"key: expected one of {self._keys}, got {key!r}")
        self._check()
        self._load(key)
        return self._cache[key]

    def __iter__(self):
        return iter(self._keys)

    def __len__(self) -> int:
        return len(self._keys)

    def __repr__(self) -> str:
        return f"DatasetView({self.name!r}, loaded {sorted(self._cache)})"

    # ---------------------------------------------------------------- loaders
    def _image(self, fname: str, flags):
        from ._extras import require

        cv2 = require("cv2", "catadioptric.Dataset (reading the PNG images)")
        img = cv2.imread(os.path.join(self.folder, fname), flags)
        if img is None:
            raise CatadioptricError(f"dataset: view {self.name!r}: cannot decode {fname}")
        return img

    def _npz(self, fname: str, keys=None) -> dict:
        """The arrays ``keys`` (default: all) of the view's archive ``fname``; a truncated or corrupted
        archive (read with ``verify=False``, or altered after its check) is an error naming it."""
        import zipfile
        import zlib

        path = os.path.join(self.folder, fname)
        try:
            with np.load(path, allow_pickle=False) as z:
                return {k: z[k] for k in (z.files if keys is None else keys)}
        except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
            raise CatadioptricError(f"dataset: view {self.name!r}: {fname} is not a readable .npz archive "
                                    f"({type(exc).__name__}: {exc}; truncated or corrupted); rerun the "
                                    f"`catadioptric render` command that wrote it") from None

    def _load(self, key: str) -> None:
        c = self._cache
        if key in ("groundtruth", "camera", "pose", "objects", "lines", "families"):
            gt = c.get("groundtruth") or _read_json(os.path.join(self.folder, "groundtruth.json"), "groundtruth")
            c["groundtruth"] = gt
            if key == "camera":
                from .cameras import CatadioptricCamera

                c["camera"] = CatadioptricCamera.from_dict(gt["camera"])
            elif key == "pose":
                from .frames import RigPose

                c["pose"] = RigPose(np.array(gt["pose"]["R"], dtype=float), np.array(gt["pose"]["t"], dtype=float))
            elif key != "groundtruth":
                c[key] = gt[key]
        elif key in ("arrays", "label_ambiguous", "curves", "vanishing_points", "ground_curve"):
            if "arrays" not in c:
                c["arrays"] = self._npz("groundtruth.npz")
            a = c["arrays"]
            if key == "label_ambiguous":
                c[key] = a["label_ambiguous"]
            elif key == "curves":
                c[key] = _split(a, "line_curve_offsets", {"uv": "line_uv", "t": "line_t",
                                                           "mirror_points": "line_mirror_points",
                                                           "visible": "line_visible", "in_image": "line_in_image"},
                                segment=a["line_curve_segment"])
            elif key == "ground_curve":
                c[key] = _split(a, "ground_curve_offsets", {"uv": "ground_curve_uv",
                                                             "mirror_points": "ground_curve_mirror_points",
                                                             "directions_W": "ground_curve_directions_W"},
                                closed=a["ground_curve_closed"])
            elif key == "vanishing_points":
                c[key] = {k[3:]: a[k] for k in ("vp_uv", "vp_mirror_points", "vp_sign", "vp_visible", "vp_in_image")}
        elif key == "beauty":
            import cv2

            c[key] = np.ascontiguousarray(self._image("beauty.png", cv2.IMREAD_COLOR)[..., ::-1])
        elif key == "beauty16":
            import cv2

            c[key] = np.ascontiguousarray(self._image("beauty16.png", cv2.IMREAD_UNCHANGED)[..., ::-1])
        elif key == "labels":
            import cv2

            from .render.common import decode_labels_png

            c[key] = decode_labels_png(self._image("labels.png", cv2.IMREAD_UNCHANGED))
        elif key == "beauty_hdr":
            c[key] = self._npz("beauty_hdr.npz", ("linear_rgb",))["linear_rgb"]
        elif key in ("depth", "ray_origins", "ray_directions"):
            c.update(self._npz("rays.npz", ("depth", "ray_origins", "ray_directions")))


def _split(a: dict, offsets: str, fields: dict, **per_piece) -> list[dict]:
    """Pieces of concatenated vertex arrays: one dict per piece ``offsets[i]:offsets[i + 1]``."""
    off = a[offsets]
    out = []
    for i in range(len(off) - 1):
        s = slice(int(off[i]), int(off[i + 1]))
        d = {name: a[src][s] for name, src in fields.items()}
        for k, v in per_piece.items():
            d[k] = v[i].item()
        out.append(d)
    return out
