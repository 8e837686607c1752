"""Reports of experiments: a JSON file of results, a Markdown summary and PNG figures, written
atomically (temporary file, then rename) into one folder."""
from __future__ import annotations

import os

from .._io import atomic_write_bytes, atomic_write_json


def write_report(out_dir: str, results: dict, markdown: str, figures: dict | None = None) -> list[str]:
    """Write ``report.json``, ``report.md`` and each ``figures[name]`` (a matplotlib figure) as
    ``name``.png into ``out_dir``; returns the paths written."""
    paths = []
    p = os.path.join(out_dir, "report.json")
    atomic_write_json(p, results)
    paths.append(p)
    p = os.path.join(out_dir, "report.md")
    atomic_write_bytes(p, markdown.encode())
    paths.append(p)
    for name, fig in (figures or {}).items():
        import io

        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=fig.dpi)
        p = os.path.join(out_dir, f"{name}.png")
        atomic_write_bytes(p, buf.getvalue())
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
