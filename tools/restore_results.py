"""The per-pair results of a committed benchmark report written back into the working folder, so
that a fresh machine can rewrite the report (``tools/rewrite_report.py``), compare a new run with
the committed one (``tools/image_results_compare.py``) or resume, without computing them again.

    .venv/bin/python tools/restore_results.py validate/relative_pose/report.json \\
        [--data render/out/relative_pose_benchmark]
    .venv/bin/python tools/restore_results.py validate/relative_pose_heldout/images.json \\
        --data render/out/relative_pose_heldout

``report.json`` (and ``images.json``) hold every pair's result as the run wrote it, with its
fingerprint (the spec's keys and the code digest): written back to ``data/results/<config>/pNN.json``
(label path) and ``data/results_images/<config>/pNN.json`` (image path), they are reused by a run of
the same code and recomputed by any other (:func:`catadioptric.validate.benchmark.evaluate_benchmark`).
A result file already there is left alone unless ``--force``. The overlays (``pNN.png``) are not in
the report: a run of the image path draws them again. Prints the code digests restored, per kind.
"""
from __future__ import annotations

import argparse
import collections
import json
import os

from catadioptric._io import atomic_write_json
from catadioptric.validate.benchmark import results_folder


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("report", help="report.json or images.json of a committed benchmark report")
    ap.add_argument("--data", default="render/out/relative_pose_benchmark", help="the benchmark's working folder")
    ap.add_argument("--force", action="store_true", help="overwrite result files already there")
    a = ap.parse_args()
    with open(a.report) as f:
        report = json.load(f)
    found = False
    for key, kind in (("pairs", "labels"), ("images_pairs", "images")):
        rows = report.get(key) or []
        found = found or bool(rows)
        written, kept, codes = 0, 0, collections.Counter()
        for r in rows:
            path = os.path.join(results_folder(a.data, kind), r["config"], f"p{int(r['pair']):02d}.json")
            if os.path.exists(path) and not a.force:
                kept += 1
                continue
            os.makedirs(os.path.dirname(path), exist_ok=True)
            atomic_write_json(path, r)
            written += 1
            codes[r.get("code", "?")[:8]] += 1
        if rows:
            print(f"{kind}: {written} pair results written to {results_folder(a.data, kind)}, {kept} already there "
                  f"(code digests written: {dict(codes)})")
    if not found:
        raise SystemExit(f"{a.report}: no 'pairs' or 'images_pairs' in it")


if __name__ == "__main__":
    main()
