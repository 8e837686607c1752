"""Optional dataset outputs (``catadioptric render --rays --beauty16 --hdr --mesh``; docs/formats.md):
per-pixel depth and ray maps, the 16-bit and the linear (HDR) beauty images and the scene mesh file."""
from __future__ import annotations

import numpy as np

from .._checks import CatadioptricError

__all__ = ["EXTRAS", "EXTRA_FILES", "MESH_FILE", "check_extras", "ray_maps", "linear_to_srgb16", "scene_ply",
           "extra_blobs"]

#: The optional outputs and the file each adds to every view folder (``mesh``: one file per dataset).
EXTRAS = ("rays", "beauty16", "hdr", "mesh")
EXTRA_FILES = {"rays": "rays.npz", "beauty16": "beauty16.png", "hdr": "beauty_hdr.npz"}
_NEED_LINEAR = ("beauty16", "hdr")  # need the renderer's linear image (Mitsuba)
MESH_FILE = "scene.ply"


def check_extras(extras, renderer: str) -> tuple:
    """The extras as a sorted tuple, checked (``beauty16``, ``hdr`` need Mitsuba: POV-Ray's beauty is 8-bit)."""
    out = tuple(sorted(set(extras or ())))
    bad = [e for e in out if e not in EXTRAS]
    if bad:
        raise CatadioptricError(f"extras: expected some of {list(EXTRAS)}, got {bad}")
    for e in _NEED_LINEAR:
        if e in out and renderer != "mitsuba":
            raise CatadioptricError(f"extras: {e} needs the mitsuba renderer (the {renderer} beauty is 8-bit), "
                                    f"got renderer {renderer!r}")
    return out


def ray_maps(traced, pose) -> dict:
    """Per-pixel arrays of a traced view, in the rig's mirror frame M (the generalized-camera form):
    ``ray_origins (H, W, 3)`` the reflection point on the mirror, ``ray_directions (H, W, 3)`` the
    unit reflected direction, ``depth (H, W)`` the distance in metres along it to the first
    surface (``inf``: sky); NaN where the pixel has no reflected ray (misses the mirror, or the
    ray meets the mirror again), all float64."""
    from .tracer import LABEL_MIRROR_AGAIN, LABEL_NO_MIRROR

    R, t = np.asarray(pose.R, dtype=float), np.asarray(pose.t, dtype=float)
    none = (traced.labels == LABEL_NO_MIRROR) | (traced.labels == LABEL_MIRROR_AGAIN)
    o = np.where(none[..., None], np.nan, traced.origins_W @ R.T + t)
    d = np.where(none[..., None], np.nan, traced.directions_W @ R.T)
    depth = np.where(none, np.nan, traced.t)
    return {"ray_origins": o, "ray_directions": d, "depth": depth}


def linear_to_srgb16(rgb) -> np.ndarray:
    """Linear RGB floats -> sRGB uint16 (the 8-bit curve of ``linear_to_srgb8`` with 65535 levels)."""
    x = np.clip(np.nan_to_num(np.asarray(rgb, dtype=np.float64), nan=0.0), 0.0, 1.0)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return np.floor(s * 65535.0 + 0.5).astype(np.uint16)


def scene_ply(scene) -> bytes:
    """The scene's meshes in one binary PLY (written by trimesh): vertices in W (float32, as PLY
    stores them through trimesh), faces with a ``label`` property (the object's label, as in the
    label images) and the object's colour."""
    from .._extras import require

    trimesh = require("trimesh", "the scene mesh file (--mesh)")
    verts, faces, labels, colors, base = [], [], [], [], 0
    for obj in scene.objects:
        v = np.asarray(obj.vertices, dtype=np.float64)
        f = np.asarray(obj.faces, dtype=np.int64)
        verts.append(v)
        faces.append(f + base)
        labels.append(np.full(len(f), int(obj.label), dtype=np.int32))
        rgb = np.clip(np.round(np.asarray(obj.color, dtype=float) * 255), 0, 255).astype(np.uint8)
        colors.append(np.tile(np.append(rgb, 255), (len(f), 1)))
        base += len(v)
    m = trimesh.Trimesh(np.concatenate(verts), np.concatenate(faces), face_colors=np.concatenate(colors),
                        process=False)
    m.face_attributes["label"] = np.concatenate(labels)
    return m.export(file_type="ply", include_attributes=True)


def extra_blobs(extras, res, traced, pose) -> dict:
    """The optional files of one view: ``{file name: bytes}``."""
    out = {}
    if "rays" in extras:
        from .groundtruth import write_npz

        out[EXTRA_FILES["rays"]] = write_npz(ray_maps(traced, pose))
    if any(e in extras for e in _NEED_LINEAR) and res.linear is None:
        raise CatadioptricError("extras: beauty16 and hdr need the renderer's linear image; this renderer gave none")
    if "hdr" in extras:
        from .groundtruth import write_npz

        # Mitsuba renders in float32: nothing is lost
        out[EXTRA_FILES["hdr"]] = write_npz({"linear_rgb": np.asarray(res.linear, dtype=np.float32)})
    if "beauty16" in extras:
        import cv2

        ok, buf = cv2.imencode(".png", np.ascontiguousarray(linear_to_srgb16(res.linear)[..., ::-1]),
                               [cv2.IMWRITE_PNG_COMPRESSION, 6])
        if not ok:  # pragma: no cover - OpenCV encodes any uint16 image
            raise CatadioptricError("opencv: could not encode the 16-bit beauty PNG")
        out[EXTRA_FILES["beauty16"]] = buf.tobytes()
    return out
