"""The benchmark's image-only path on some of its pairs with other detector options, written as a
``results_images`` folder that ``tools/image_results_compare.py compare`` sets beside a full run;
or, with ``--detection-only``, each view's detection scored against its labels with the default
options and with those given, side by side.

    .venv/bin/python tools/image_path_options.py sphere,hyperboloid --pairs 8 --detect grow_gap_px=3 \\
        --out /tmp/grow3 [--workers 1]
    .venv/bin/python tools/image_results_compare.py compare \\
        render/out/relative_pose_benchmark/results_images /tmp/grow3
    .venv/bin/python tools/image_path_options.py all --pairs 4 --detect grow_gap_px=3 --detection-only \\
        [--json ROWS]
    .venv/bin/python tools/image_path_options.py all --pairs 20 --renderer mitsuba --detect denoise=none \\
        --data DATA_HIGH --out /tmp/high     # DATA_HIGH: tools/render_quality.py's datasets

Each pair is the benchmark's (validate/relative_pose.toml, the first ``--pairs`` of each
configuration), evaluated as ``catadioptric validate benchmark --images`` does
(:func:`catadioptric.validate.image_pairs.evaluate_image_pair`, the spec's priors and
``min_pixels``), with ``detect_options`` from ``--detect KEY=VALUE`` (the options of
:func:`catadioptric.detect.detect_lines`; values read as Python literals). Pairs already in
``--out`` are kept (a rerun resumes). ``--detection-only``: the means over the views of the
labelled pixels recovered, the lines, the family precision and recall
(:func:`catadioptric.detect.evaluate_view`), per renderer; ``--json`` keeps every view's row.
Needs the benchmark's datasets (README, "relative pose benchmark").
"""
from __future__ import annotations

import argparse
import ast
import json
import os
from multiprocessing import get_context
from pathlib import Path

from catadioptric._io import atomic_write_json, jsonable
from catadioptric.validate.benchmark import dataset_folder
from catadioptric.validate.benchmark_spec import load_benchmark_spec, pairs_of


def _evaluate(args):
    spec, data, config, pair, options, path = args
    from threadpoolctl import threadpool_limits

    from catadioptric.validate.image_pairs import evaluate_image_pair

    with threadpool_limits(1):
        res = evaluate_image_pair(dataset_folder(data, config, pair.renderer), pair.names,
                                  priors=(None, *spec["images"]["max_rotation_deg"]), min_pixels=spec["min_pixels"],
                                  detect_options=options)
    res.update({"config": config, "pair": pair.index, "renderer": pair.renderer, "detect_options": options})
    atomic_write_json(path, jsonable(res))
    return path


_SCORES = ("recovered_fraction", "detected_lines", "line_precision", "family_precision", "family_recall",
           "family_recall_3")


def _detection(args):
    data, config, pair, side, options = args
    import time

    from threadpoolctl import threadpool_limits

    from catadioptric.dataset import Dataset
    from catadioptric.detect import detect_lines, evaluate_view

    view = Dataset(dataset_folder(data, config, pair.renderer))[f"p{pair.index:02d}{side}"]
    row = {"config": config, "pair": pair.index, "renderer": pair.renderer, "side": side}
    with threadpool_limits(1):
        for tag, o in (("default", {}), ("options", options)):
            t = time.perf_counter()
            s = evaluate_view(detect_lines(view["beauty"], view["camera"], **o), view, min_label_pixels=30)
            row[tag] = {k: float(s[k]) for k in _SCORES} | {"seconds": time.perf_counter() - t}
    return row


def _detection_table(rows, options):
    print(f"means over the views, default options -> {options}")
    print("renderer | views | " + " | ".join(_SCORES + ("seconds",)))
    for ren in ("mitsuba", "povray", "all"):
        rs = [r for r in rows if ren in ("all", r["renderer"])]
        if rs:
            print(f"{ren} | {len(rs)} | " + " | ".join(
                f"{sum(r['default'][k] for r in rs) / len(rs):.3f} -> {sum(r['options'][k] for r in rs) / len(rs):.3f}"
                for k in _SCORES + ("seconds",)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("configs", help="comma-separated configuration names of the spec")
    ap.add_argument("--pairs", type=int, default=4, help="the first N pairs of each configuration (default 4)")
    ap.add_argument("--detect", action="append", default=[], metavar="KEY=VALUE", help="a detector option")
    ap.add_argument("--out", help="folder of the per-pair results (not with --detection-only)")
    ap.add_argument("--detection-only", action="store_true", help="score each view's detection instead")
    ap.add_argument("--json", help="with --detection-only: write every view's row here")
    ap.add_argument("--spec", default="validate/relative_pose.toml")
    ap.add_argument("--data", default="render/out/relative_pose_benchmark")
    ap.add_argument("--renderer", choices=("mitsuba", "povray"),
                    help="only the pairs of this renderer (among the first --pairs)")
    ap.add_argument("--only", metavar="CONFIG:PAIR,...",
                    help="only these pairs (e.g. ellipsoid:0,sphere:12; among the first --pairs)")
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args()
    options = {}
    for kv in args.detect:
        k, sep, v = kv.partition("=")
        if not sep:
            ap.error(f"--detect: expected KEY=VALUE, got {kv!r}")
        try:
            options[k] = ast.literal_eval(v)
        except (ValueError, SyntaxError):
            options[k] = v
    spec = load_benchmark_spec(args.spec)
    names = [c["name"] for c in spec["configs"]]
    configs = names if args.configs == "all" else args.configs.split(",")
    for name in configs:
        if name not in names:
            ap.error(f"configs: expected 'all' or some of {names}, got {name!r}")

    only = None if not args.only else {(c, int(k)) for c, _, k in (x.partition(":") for x in args.only.split(","))}

    def pairs(name):
        return [p for p in pairs_of(spec, spec["configs"][names.index(name)])[: args.pairs]
                if args.renderer in (None, p.renderer) and (only is None or (name, p.index) in only)]

    if args.detection_only:
        todo = [(args.data, name, pair, side, options) for name in configs
                for pair in pairs(name) for side in "AB"]
        rows = _run(_detection, todo, args.workers)
        if args.json:
            atomic_write_json(args.json, rows)
        _detection_table(rows, options)
        return
    if not args.out:
        ap.error("--out: required unless --detection-only")
    todo = []
    for name in configs:
        os.makedirs(os.path.join(args.out, name), exist_ok=True)
        for pair in pairs(name):
            path = os.path.join(args.out, name, f"p{pair.index:02d}.json")
            if os.path.exists(path) and json.loads(Path(path).read_text()).get("detect_options") == options:
                continue
            todo.append((spec, args.data, name, pair, options, path))
    print(f"{len(todo)} pairs to evaluate with detector options {options}", flush=True)
    _run(_evaluate, todo, args.workers)


def _run(fn, todo, workers):
    from tqdm import tqdm

    if workers > 1:
        with get_context("spawn").Pool(workers) as pool:
            return list(tqdm(pool.imap(fn, todo), total=len(todo)))
    return [fn(t) for t in tqdm(todo)]


if __name__ == "__main__":
    main()
