"""Reports of experiments: a JSON file of results, a Markdown summary and PNG figures, written
atomically (temporary file, then rename) into one folder."""
from __future__ import annotations

import json
import os
import tempfile

import numpy as np


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.floating, float)):
        f = float(x)
        return f if np.isfinite(f) else None
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    return x


def _atomic_write(path: str, data: bytes) -> None:
    d = os.path.dirname(os.path.abspath(path))
    os.makedirs(d, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=d, prefix=".tmp-", suffix=os.path.basename(path))
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write_report(out_dir: str, results: dict, markdown: str, figures: dict | None = None) -> list[str]:
    """Write ``report.json``, ``report.md`` and each ``figures[name]`` (a matplotlib figure) as
    ``name``.png into ``out_dir``; returns the paths written."""
    paths = []
    p = os.path.join(out_dir, "report.json")
    _atomic_write(p, (json.dumps(_jsonable(results), indent=1) + "\n").encode())
    paths.append(p)
    p = os.path.join(out_dir, "report.md")
    _atomic_write(p, markdown.encode())
    paths.append(p)
    for name, fig in (figures or {}).items():
        import io

        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=fig.dpi)
        p = os.path.join(out_dir, f"{name}.png")
        _atomic_write(p, buf.getvalue())
        paths.append(p)
    return paths


def md_table(header: list[str], rows: list[list]) -> str:
    def fmt(v):
        if isinstance(v, float):
            return f"{v:.4g}"
        return str(v)

    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(fmt(v) for v in r) + " |" for r in rows]
    return "\n".join(out)
