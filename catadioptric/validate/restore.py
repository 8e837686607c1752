"""``catadioptric validate restore``: a committed benchmark report's per-pair results written back
into a working folder.

    catadioptric validate restore validate/relative_pose/report.json [--data render/out/relative_pose_benchmark]
    catadioptric validate restore validate/relative_pose_heldout/images.json --data render/out/relative_pose_heldout

``report.json`` (and ``images.json`` of ``--images-only``) hold every pair's result as the run wrote
it, with its fingerprint (the spec's keys and the code digest). Written back to
``DATA/results/<config>/pNN.json`` (label path) and ``DATA/results_images/<config>/pNN.json`` (image
path), they are read back by a run of the same code instead of being computed again, and computed
again by any other; ``catadioptric validate benchmark --report-only`` writes the report again from
them, and ``catadioptric validate compare`` sets a new run beside them. So a fresh machine
reproduces a committed report, or compares a change with it, without the hours of computing.
"""
from __future__ import annotations

import json
import os

from .._checks import CatadioptricError
from .._io import atomic_write_json
from .benchmark import results_folder

__all__ = ["restore_results", "register_restore"]

#: what a report holds per path, and where the path's results go
_KINDS = (("pairs", "labels"), ("images_pairs", "images"))


def restore_results(report: str, data: str, *, force: bool = False) -> dict:
    """Write the per-pair results of ``report`` (a benchmark's ``report.json`` or ``images.json``)
    into ``data``'s results folders; a result already there is kept unless ``force``. Returns per
    path (``labels``, ``images``) ``{"written", "kept", "codes": {digest: pairs written}, "folder"}``."""
    try:
        with open(report) as f:
            rep = json.load(f)
    except FileNotFoundError:
        raise CatadioptricError(f"REPORT: no file {report!r}") from None
    except (OSError, ValueError) as exc:
        raise CatadioptricError(f"REPORT: {report!r} is not a readable JSON file ({exc})") from None
    if not isinstance(rep, dict) or not any(rep.get(key) for key, _ in _KINDS):
        raise CatadioptricError(f"REPORT: expected a benchmark's report.json or images.json (with 'pairs' or "
                                f"'images_pairs'), got {report!r}")
    out = {}
    for key, kind in _KINDS:
        rows = rep.get(key) or []
        if not rows:
            continue
        folder = results_folder(data, kind)
        written, kept, codes = 0, 0, {}
        for r in rows:
            try:
                path = os.path.join(folder, str(r["config"]), f"p{int(r['pair']):02d}.json")
            except (KeyError, TypeError, ValueError):
                raise CatadioptricError(f"REPORT: a result of {key!r} names no configuration and pair") from None
            if os.path.exists(path) and not force:
                kept += 1
                continue
            os.makedirs(os.path.dirname(path), exist_ok=True)
            atomic_write_json(path, r)
            written += 1
            code = str(r.get("code") or "unknown")[:8]
            codes[code] = codes.get(code, 0) + 1
        out[kind] = {"written": written, "kept": kept, "codes": codes, "folder": folder}
    return out


def _run(args) -> int:
    from ..cliargs import check_out_dir

    data = check_out_dir(args.data, "--data")
    for kind, r in restore_results(args.report, data, force=args.force).items():
        codes = ", ".join(f"{k} ({n})" for k, n in r["codes"].items()) or "none"
        print(f"{kind}: {r['written']} pair results written to {r['folder']}, {r['kept']} already there "
              f"(code digests written: {codes})")
    return 0


def register_restore(vs) -> None:
    """Add ``validate restore`` to the ``validate`` subparsers ``vs``."""
    p = vs.add_parser("restore", help="write a committed benchmark report's per-pair results back into --data",
                      description="Write the per-pair results a benchmark report holds (report.json: both paths; "
                                  "images.json: the image path) back into the working folder, so that the same "
                                  "code reads them instead of computing them again: `validate benchmark "
                                  "--report-only` then writes the report again, `validate compare` sets a new run "
                                  "beside them.")
    p.add_argument("report", metavar="REPORT", help="report.json or images.json of a committed benchmark report")
    p.add_argument("--data", default=os.path.join("render", "out", "relative_pose_benchmark"), metavar="DIR",
                   help="the benchmark's working folder (default render/out/relative_pose_benchmark)")
    p.add_argument("--force", action="store_true", help="overwrite result files already there")
    p.set_defaults(func=_run)
