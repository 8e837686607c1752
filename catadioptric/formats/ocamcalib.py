"""OCamCalib's ``calib_results.txt`` (Scaramuzza's polynomial model), both directions:
:func:`read_ocamcalib` reads it as a :class:`catadioptric.models.ScaramuzzaCamera` (in
OCamCalib's own camera frame), :func:`ocamcalib_text` writes one back.

The file, as the toolbox writes it and its C code (``get_ocam_model``) reads it: blocks, each a
comment line starting with ``#`` and then its numbers::

    #polynomial coefficients for the DIRECT mapping function (ocam_model.ss in MATLAB). ...
    5 -2.665880e+02 0.000000e+00 1.220001e-03 -5.781730e-07 2.003631e-09
    #polynomial coefficients for the inverse mapping function (ocam_model.invpol in MATLAB). ...
    12 443.183827 308.133563 ...
    #center: "row" and "column", starting from 0 (C convention)
    545.872616 674.318875
    #affine parameters "c", "d", "e"
    0.999998 0.000003 0.000026
    #image size: "height" and "width"
    1080 1300

(a polynomial's first number is how many coefficients follow). Blocks are recognised by their
comment line, in any order; other blocks are left alone. Two optional blocks that pyomniunwarp
adds are read too: ``#ROI max min radius`` (the annulus of the image the mirror fills, about the
centre: the model's ``roi``) and ``#left right cropped pixel`` (the columns cropped off the
photograph before calibrating: the model is then the camera of the full photograph, its width
``file width + left + right`` and its centre column ``file column + left``).
"""
from __future__ import annotations

import os
import re

from .._checks import CatadioptricError

__all__ = ["read_ocamcalib", "ocamcalib_text", "OCAMCALIB_BLOCKS"]

#: the blocks of the file: key -> (what it is called in errors, comment line the writer writes)
OCAMCALIB_BLOCKS = {
    "ss": ("the ss block (cam2world polynomial)",
           "#polynomial coefficients for the DIRECT mapping function (ocam_model.ss in MATLAB). "
           "These are used by cam2world"),
    "invpol": ("the invpol block (world2cam polynomial)",
               "#polynomial coefficients for the inverse mapping function (ocam_model.invpol in MATLAB). "
               "These are used by world2cam"),
    "center": ("the center block (row and column)", '#center: "row" and "column", starting from 0 (C convention)'),
    "affine": ("the affine block (c, d, e)", '#affine parameters "c", "d", "e"'),
    "size": ("the image size block (height and width)", '#image size: "height" and "width"'),
    "roi": ("the ROI block (max and min radius)", "#ROI max min radius"),
    "crop": ("the crop block (left and right cropped pixels)", "#left right cropped pixel"),
}
_REQUIRED = ("ss", "invpol", "center", "affine", "size")


def _block_key(header: str) -> str | None:
    h = header.lower()
    if "inverse mapping" in h or "world2cam" in h or "invpol" in h:
        return "invpol"
    if "direct mapping" in h or "cam2world" in h or "ocam_model.ss" in h:
        return "ss"
    if "center" in h or "centre" in h:
        return "center"
    if "affine" in h:
        return "affine"
    if "image size" in h:
        return "size"
    if re.search(r"\broi\b", h):
        return "roi"
    if "crop" in h:
        return "crop"
    return None


def _blocks(path: str, text: str) -> dict:
    """``{key: [token, ...]}`` of the blocks the file holds."""
    out, key = {}, None
    for line in text.splitlines():
        s = line.strip()
        if s.startswith("#"):
            key = _block_key(s)
            if key is not None:
                if key in out:
                    raise CatadioptricError(f"{path}: {OCAMCALIB_BLOCKS[key][0]}: given twice")
                out[key] = []
        elif s and key is not None:
            out[key].extend(s.split())
    return out


def _values(path: str, key: str, tokens, n: int | None, whole: bool = False) -> list:
    name = OCAMCALIB_BLOCKS[key][0]
    vals = []
    for t in tokens:
        try:
            v = float(t)
        except ValueError:
            raise CatadioptricError(f"{path}: {name}: expected numbers, got {t!r}") from None
        if v != v or v in (float("inf"), float("-inf")):
            raise CatadioptricError(f"{path}: {name}: expected finite numbers, got {t!r}")
        if whole and not v.is_integer():
            raise CatadioptricError(f"{path}: {name}: expected whole numbers of pixels, got {t!r}")
        vals.append(int(v) if whole else v)
    if n is not None and len(vals) != n:
        raise CatadioptricError(f"{path}: {name}: expected {n} numbers, got {len(vals)}")
    return vals


def _polynomial(path: str, key: str, tokens) -> list[float]:
    name = OCAMCALIB_BLOCKS[key][0]
    if not tokens:
        raise CatadioptricError(f"{path}: {name}: expected the number of coefficients and the coefficients, got "
                                f"nothing")
    n = _values(path, key, tokens[:1], 1, whole=True)[0]
    coeffs = _values(path, key, tokens[1:], None)
    if n < 1 or len(coeffs) != n:
        raise CatadioptricError(f"{path}: {name}: expected {n} coefficients (its first number), got {len(coeffs)}")
    return coeffs


def read_ocamcalib(path):
    """The :class:`catadioptric.models.ScaramuzzaCamera` of an OCamCalib ``calib_results.txt``
    (module docstring): ``ss``, ``invpol``, the centre (row, column), the affine ``c d e`` and
    the image size (height, width); pyomniunwarp's ROI and crop blocks when present. Pixels are
    ours (OpenCV's: ``(u, v) = (column, row)``), directions OCamCalib's (x along the rows, y
    along the columns, the camera looking along -z). Errors name the file and the block."""
    from ..models import ScaramuzzaCamera

    path = os.fspath(path)
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except (OSError, UnicodeDecodeError) as exc:
        raise CatadioptricError(f"{path}: cannot be read ({exc})") from None
    blocks = _blocks(path, text)
    for key in _REQUIRED:
        if key not in blocks:
            raise CatadioptricError(f"{path}: {OCAMCALIB_BLOCKS[key][0]}: missing")
    ss = _polynomial(path, "ss", blocks["ss"])
    invpol = _polynomial(path, "invpol", blocks["invpol"])
    xc, yc = _values(path, "center", blocks["center"], 2)
    c, d, e = _values(path, "affine", blocks["affine"], 3)
    height, width = _values(path, "size", blocks["size"], 2, whole=True)
    left, right = _values(path, "crop", blocks["crop"], 2, whole=True) if "crop" in blocks else (0, 0)
    if left < 0 or right < 0:
        raise CatadioptricError(f"{path}: {OCAMCALIB_BLOCKS['crop'][0]}: expected numbers >= 0, got {left} {right}")
    yc = yc + left
    roi = None
    if "roi" in blocks:
        rmax, rmin = _values(path, "roi", blocks["roi"], 2)
        if not 0 <= rmin <= rmax:
            raise CatadioptricError(f"{path}: {OCAMCALIB_BLOCKS['roi'][0]}: expected max >= min >= 0, got "
                                    f"{rmax!r} {rmin!r}")
        roi = (yc, xc, rmin, rmax)
    try:
        return ScaramuzzaCamera(width + left + right, height, ss=tuple(ss), invpol=tuple(invpol), xc=xc, yc=yc, c=c,
                                d=d, e=e, roi=roi, crop=(left, right))
    except CatadioptricError as exc:
        raise CatadioptricError(f"{path}: {exc}") from None


def ocamcalib_text(cam) -> str:
    """``cam`` (a :class:`catadioptric.models.ScaramuzzaCamera`) as a ``calib_results.txt`` that
    :func:`read_ocamcalib` reads back to the same camera exactly (numbers written with ``repr``),
    with pyomniunwarp's ROI block when ``cam.roi`` is set and its crop block when ``cam.crop``
    is not ``(0, 0)`` (the numbers are then the cropped image's, as that file holds them)."""
    from ..models import ScaramuzzaCamera

    if not isinstance(cam, ScaramuzzaCamera):
        raise CatadioptricError(f"cam: expected a ScaramuzzaCamera, got {type(cam).__name__}")
    left, right = cam.crop
    width = cam.width - left - right
    if width <= 0:
        raise CatadioptricError(f"cam.crop: expected to leave some of the {cam.width} columns, got {cam.crop}")
    yc = cam.yc - left
    if left and yc + left != cam.yc:  # pragma: no cover - exact for any centre of a real image
        raise CatadioptricError(f"cam.yc: {cam.yc!r} - {left} does not read back exactly")
    if cam.roi is not None and (cam.roi[0] != cam.yc or cam.roi[1] != cam.xc):
        raise CatadioptricError(f"cam.roi: the file's ROI is about the centre (u0, v0) = ({cam.yc!r}, {cam.xc!r}), "
                                f"got ({cam.roi[0]!r}, {cam.roi[1]!r})")

    def block(key, values):
        return [OCAMCALIB_BLOCKS[key][1], "", " ".join(values), ""]

    lines = block("ss", [str(len(cam.ss))] + [repr(v) for v in cam.ss])
    lines += block("invpol", [str(len(cam.invpol))] + [repr(v) for v in cam.invpol])
    lines += block("center", [repr(cam.xc), repr(yc)])
    lines += block("affine", [repr(cam.c), repr(cam.d), repr(cam.e)])
    lines += block("size", [str(cam.height), str(width)])
    if cam.roi is not None:
        lines += block("roi", [repr(cam.roi[3]), repr(cam.roi[2])])
    if cam.crop != (0, 0):
        lines += block("crop", [str(left), str(right)])
    return "\n".join(lines)
