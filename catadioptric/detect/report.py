"""Detection over the views of rendered datasets, scored against their labels: per view a result
file (the detected lines and the scores), an overlay, and a summary (JSON and Markdown).

Reruns resume: a view whose result file records the same options, the same scoring options and
the same view files (the fingerprint of its ``done.json``) is read back instead of detected again.
"""
from __future__ import annotations

import hashlib
import json
import os

import numpy as np

from .._io import atomic_write_bytes, atomic_write_json, jsonable

__all__ = ["detect_view", "evaluate_dataset", "summarise", "markdown_table", "SUMMARY_KEYS", "write_png"]

#: The per-view scores averaged in summaries (keys of :func:`catadioptric.detect.evaluate_view`)
SUMMARY_KEYS = ("recovered_fraction", "line_precision", "line_precision_labels", "distance_median_px",
                "family_precision", "family_recall", "family_recall_3", "assignment_accuracy", "detected_lines",
                "seconds", "seconds_denoise")


def write_png(path: str, rgb: np.ndarray) -> None:
    """Write an RGB ``uint8`` image as PNG, atomically."""
    import cv2

    ok, buf = cv2.imencode(".png", np.ascontiguousarray(rgb[..., ::-1]))
    if not ok:  # pragma: no cover - OpenCV encodes any uint8 RGB image
        raise RuntimeError(f"could not encode {path!r} as PNG")
    atomic_write_bytes(path, buf.tobytes())


def _fingerprint(options: dict, scoring: dict, view) -> str:
    done = os.path.join(view["folder"], "done.json")
    with open(done, "rb") as f:
        marker = f.read()
    h = hashlib.sha256()
    h.update(json.dumps(jsonable({"options": options, "scoring": scoring}), sort_keys=True).encode())
    h.update(marker)
    return h.hexdigest()


def detect_view(view, out_dir: str | None = None, *, options: dict | None = None, scoring: dict | None = None,
                overlay: bool = True) -> dict:
    """Detect the lines of a dataset view (its beauty image and stored camera), score them against
    its labels, and (with ``out_dir``) write ``<out_dir>/<view>/result.json`` (the scores, the
    detected lines) and ``overlay.png``. Returns the scores (with ``view``, ``seconds``,
    ``seconds_denoise`` and ``denoise``)."""
    from .detector import detect_lines
    from .evaluate import evaluate_view
    from .overlay import overlay_image

    options, scoring = dict(options or {}), dict(scoring or {})
    folder = os.path.join(out_dir, view["name"]) if out_dir else None
    fp = _fingerprint(options, scoring, view)
    res_path = os.path.join(folder, "result.json") if folder else None
    if res_path and os.path.isfile(res_path):
        try:
            with open(res_path, encoding="utf-8") as f:
                old = json.load(f)
            if old.get("fingerprint") == fp:
                return old["scores"]
        except (OSError, ValueError, KeyError):
            pass  # unreadable: detect again
    det = detect_lines(view["beauty"], view["camera"], **options)
    scores = evaluate_view(det, view, **scoring)
    scores.update(view=view["name"], seconds=det.seconds["total"], seconds_denoise=det.seconds["denoise"],
                  denoise=det.denoise, noise=det.noise)
    if folder:
        if overlay:
            write_png(os.path.join(folder, "overlay.png"), overlay_image(view["beauty"], det))
        atomic_write_json(res_path, {"fingerprint": fp, "scores": scores, "lines": det.to_dict()})
    return jsonable(scores)


def evaluate_dataset(path, out_dir: str | None = None, *, views=None, options: dict | None = None,
                     scoring: dict | None = None, progress: bool = False) -> dict:
    """Detect and score every view (or ``views``, names) of the dataset at ``path``; with
    ``out_dir``, per-view results (:func:`detect_view`) and ``report.json``/``report.md`` there.
    Returns ``{"dataset", "views": [scores...], "summary": {...}}``."""
    from .._checks import CatadioptricError
    from ..dataset import Dataset

    ds = Dataset(path)
    names = list(ds.names) if views is None else list(views)
    unknown = [n for n in names if n not in ds.names]
    if unknown:
        raise CatadioptricError(f"views: expected views of {path!r} ({', '.join(ds.names[:6])}"
                                f"{', ...' if len(ds.names) > 6 else ''}), got {unknown}")
    it = names
    if progress:
        from tqdm import tqdm

        it = tqdm(names, desc=f"detect {os.path.basename(os.path.normpath(os.fspath(path)))}", unit="view")
    rows = [detect_view(ds[n], out_dir, options=options, scoring=scoring) for n in it]
    result = {"dataset": os.fspath(path), "options": options or {}, "scoring": scoring or {}, "views": rows,
              "summary": summarise(rows)}
    if out_dir:
        atomic_write_json(os.path.join(out_dir, "report.json"), result)
        md = [f"# Line detection on `{os.fspath(path)}`", "", markdown_table(rows, key="view"), "",
              "Mean over the views:", "", markdown_table([{"view": "mean", **result["summary"]}], key="view")]
        atomic_write_bytes(os.path.join(out_dir, "report.md"), ("\n".join(md) + "\n").encode())
    return jsonable(result)


def summarise(rows: list[dict]) -> dict:
    """The mean of each of :data:`SUMMARY_KEYS` over ``rows`` (views without a value left out), and
    the number of views."""
    out = {"views": len(rows)}
    for k in SUMMARY_KEYS:
        v = [r[k] for r in rows if r.get(k) is not None]
        out[k] = float(np.mean(v)) if v else None
    return out


_HEADERS = {"recovered_fraction": "recovered", "line_precision": "line precision",
            "line_precision_labels": "precision (labels)", "distance_median_px": "median dist (px)",
            "family_precision": "family precision", "family_recall": "family recall",
            "family_recall_3": "recall (3+ lines)", "assignment_accuracy": "line families right",
            "detected_lines": "lines", "seconds": "s/view", "seconds_denoise": "s denoise"}


def markdown_table(rows: list[dict], key: str = "view") -> str:
    """A Markdown table of :data:`SUMMARY_KEYS` per row, first column ``row[key]``."""
    def fmt(v):
        if v is None:
            return "-"
        if isinstance(v, float):
            return f"{v:.3g}" if abs(v) >= 10 else f"{v:.2f}"
        return str(v)

    head = [key] + [_HEADERS[k] for k in SUMMARY_KEYS]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        lines.append("| " + " | ".join([str(r.get(key, ""))] + [fmt(r.get(k)) for k in SUMMARY_KEYS]) + " |")
    return "\n".join(lines)
