"""The relative-pose benchmark: render the spec's view pairs (resumable datasets), evaluate every
pair at every noise level and draw (resumable, one result file per pair, a process pool with
``workers``), and aggregate the report (JSON, Markdown tables, plots).

Layout: the working folder ``data`` (large, not for committing) and the report folder ``out``::

    data/datasets/<config>_<renderer>/  the rendered views (catadioptric render format)
    data/results/<config>/pNN.json      one pair's draws (written atomically; reruns skip them while
                                        the spec's keys and the package's code are unchanged)
    data/results_images/<config>/pNN.json, pNN.png
                                        the image-only path on the pair (``images=True``) and its overlay
    out/report.json, report.md, *.png   the aggregate, every pair's draws included (written last)
"""
from __future__ import annotations

import hashlib
import json
import os
import sys
import time

from .._checks import CatadioptricError
from .._io import atomic_write_json, jsonable
from .benchmark_spec import pairs_of, quality_of

__all__ = ["render_benchmark", "evaluate_benchmark", "run_benchmark", "dataset_folder", "results_folder",
           "overlay_paths", "benchmark_scene", "code_digest", "read_results", "stored_results", "rewrite_report"]


def dataset_folder(data: str, config: str, renderer: str) -> str:
    return os.path.join(data, "datasets", f"{config}_{renderer}")


def results_folder(data: str, kind: str) -> str:
    """Where the per-pair results of ``kind`` (``"labels"`` or ``"images"``) go: ``data/results``,
    ``data/results_images``."""
    if kind not in _FOLDER:
        raise CatadioptricError(f"kind: expected one of {list(_FOLDER)}, got {kind!r}")
    return os.path.join(data, _FOLDER[kind])


def benchmark_scene(spec):
    """The scene the spec's views are of (``scene``: a scene name or spec file)."""
    from ..scenes import build_scene, spec_path

    return build_scene(spec_path(spec["scene"]))


def render_benchmark(spec: dict, data: str, *, workers: int = 1, progress: bool = True, only=None) -> dict:
    """Render every configuration's pairs (one dataset per configuration and renderer; views
    ``pNNA``/``pNNB``), or those of ``only`` (``(configuration, pair index)`` tuples). Finished
    views are skipped. Returns ``{(config, renderer): manifest}``."""
    from ..cliargs import parse_resolution
    from ..render.dataset import render_dataset
    from ..rigspec import load_rig

    w, h = parse_resolution(spec["resolution"], "resolution")
    scene = benchmark_scene(spec)
    manifests = {}
    for config in spec["configs"]:
        cam = load_rig(config["rig"], width=w, height=h)
        by_renderer: dict = {}
        for p in pairs_of(spec, config):
            if only is None or (config["name"], p.index) in only:
                by_renderer.setdefault(p.renderer, []).extend(zip(p.names, p.poses))
        for renderer, views in by_renderer.items():
            folder = dataset_folder(data, config["name"], renderer)
            if progress:
                print(f"[{config['name']} / {renderer}] {len(views)} views -> {folder}", file=sys.stderr)
            manifests[(config["name"], renderer)] = render_dataset(
                scene, views, cam, folder, renderer=renderer, quality=quality_of(spec, renderer), workers=workers,
                rig={"name": config["rig"]}, progress=progress)
    return manifests


#: what each kind of evaluation reads from the spec (its results are reused while these are unchanged);
#: the label path never reads the beauty image, and the labels are exact at every quality preset
#: (catadioptric/data/quality.toml), so the quality is the image path's key only
_KEYS = {"labels": ("scene", "resolution", "seed", "noise_px", "draws", "pixels", "min_pixels",
                    "max_pixels", "placement"),
         "images": ("scene", "resolution", "quality", "seed", "min_pixels", "placement", "images")}
_FOLDER = {"labels": "results", "images": "results_images"}


def code_digest(root: str | None = None) -> str:
    """SHA-256 of the package's Python sources (``root``: a package folder, default this package),
    file by file in sorted order of their relative paths. A pair's result is reused only while it
    is unchanged: results kept from other code would otherwise be mixed into a report silently."""
    root = root or os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    h = hashlib.sha256()
    files = sorted(os.path.relpath(os.path.join(d, f), root).replace(os.sep, "/")
                   for d, dirs, fs in os.walk(root) for f in fs if f.endswith(".py"))
    for rel in files:
        with open(os.path.join(root, rel), "rb") as f:
            data = f.read()
        h.update(f"{rel}\0{len(data)}\0".encode())
        h.update(data)
    return h.hexdigest()


def _fingerprint(spec: dict, config: dict, pair, kind: str = "labels", code: str | None = None) -> str:
    d = {k: spec[k] for k in _KEYS[kind]} | {"config": config, "pair": pair.index,
                                            "code": code_digest() if code is None else code}
    return hashlib.sha256(json.dumps(jsonable(d), sort_keys=True).encode()).hexdigest()


def _evaluate_pair(args) -> dict:
    spec, config, pair, folder, path, fp, kind, code, threads = args
    from .relative_pose import evaluate_pair

    t0 = time.perf_counter()
    if kind == "images":
        from .image_pairs import evaluate_image_pair

        res = evaluate_image_pair(folder, pair.names, priors=(None, *spec["images"]["max_rotation_deg"]),
                                  min_pixels=spec["min_pixels"], overlay=path[:-len(".json")] + ".png", threads=threads)
    else:
        res = evaluate_pair(folder, pair.names, noise_levels=spec["noise_px"], draws=spec["draws"],
                            seed=[spec["seed"], pair.index], pixels=spec["pixels"], min_pixels=spec["min_pixels"],
                            max_pixels=spec["max_pixels"], threads=threads)
    res.update({"config": config["name"], "rig": config["rig"], "pair": pair.index, "renderer": pair.renderer,
                "fingerprint": fp, "code": code, "seconds": time.perf_counter() - t0})
    atomic_write_json(path, jsonable(res))
    return res


def _evaluate_task(item):
    key, args = item
    return key, _evaluate_pair(args)


def evaluate_benchmark(spec: dict, data: str, *, workers: int = 1, progress: bool = True,
                       kind: str = "labels", only=None, out: str | None = None) -> list[dict]:
    """Evaluate every pair (resuming: a pair whose result file has this fingerprint, of the spec's
    keys and of the package's code (:func:`code_digest`), is read back, not recomputed).
    ``kind``: ``"labels"`` (the line pixels and families from the labels, every noise level) or
    ``"images"`` (the image-only path, :mod:`catadioptric.validate.image_pairs`). ``only``: the
    pairs to evaluate, ``(configuration, pair index)`` tuples (default every pair); ``out``: the
    folder of the per-pair results (default :func:`results_folder`; another one keeps a partial
    run apart from the benchmark's). Returns the pair results in spec order."""
    if kind not in _KEYS:
        raise CatadioptricError(f"kind: expected one of {list(_KEYS)}, got {kind!r}")
    every = [(c["name"], p.index) for c in spec["configs"] for p in pairs_of(spec, c)]
    if only is not None:
        only = {(str(c), int(k)) for c, k in only}
        unknown = sorted(only - set(every))
        if unknown:
            raise CatadioptricError(f"only: expected pairs of the spec (configurations "
                                    f"{[c['name'] for c in spec['configs']]}, indices below {spec['pairs']}), "
                                    f"got {unknown}")
    folder = results_folder(data, kind) if out is None else out
    tasks, results = [], {}
    code = code_digest()
    for config in spec["configs"]:
        for p in pairs_of(spec, config):
            if only is not None and (config["name"], p.index) not in only:
                continue
            path = os.path.join(folder, config["name"], f"p{p.index:02d}.json")
            fp = _fingerprint(spec, config, p, kind, code)
            key = (config["name"], p.index)
            try:
                with open(path) as f:
                    old = json.load(f)
                if old.get("fingerprint") == fp:
                    results[key] = old
                    continue
            except (OSError, ValueError):
                pass
            os.makedirs(os.path.dirname(path), exist_ok=True)
            # workers that keep every core busy run each draw's two refinements one after the other
            tasks.append((key, (spec, config, p, dataset_folder(data, config["name"], p.renderer), path, fp, kind,
                                code, 1 if workers > 1 else 2)))
    bar = None
    if progress and tasks:
        from tqdm import tqdm

        bar = tqdm(total=len(tasks), unit="pair", desc=f"evaluate ({kind})", file=sys.stderr, dynamic_ncols=True)
    try:
        if workers <= 1 or len(tasks) <= 1:
            for key, a in tasks:
                results[key] = _evaluate_pair(a)
                if bar is not None:
                    bar.update(1)
        else:
            from .._pool import imap_spawn

            for key, res in imap_spawn(_evaluate_task, tasks, workers):
                results[key] = res
                if bar is not None:
                    bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return [results[k] for k in every if k in results]


def run_images_only(spec: dict, data: str, *, out: str | None = None, workers: int = 1, progress: bool = True,
                    command: str = "") -> dict:
    """The image-only path alone: render (resuming) and evaluate it on every pair (resuming, per-pair
    results in ``data/results_images``); with ``out``, its own report there
    (:func:`~catadioptric.validate.benchmark_report.write_images_report`: ``images.md``; the full
    report sets it beside the label path). Returns
    :func:`~catadioptric.validate.benchmark_report.aggregate_images` of it, with the label path's
    columns empty."""
    from .benchmark_report import aggregate_images, write_images_report

    if not spec["configs"]:
        raise CatadioptricError("spec: expected at least one configuration")
    render_benchmark(spec, data, workers=workers, progress=progress)
    t0 = time.perf_counter()
    image_results = evaluate_benchmark(spec, data, workers=workers, progress=progress, kind="images")
    if out is None:
        return aggregate_images(spec, [], image_results)
    return write_images_report(spec, image_results, out, command=command, overlays=overlay_paths(spec, data),
                               timing={"images_seconds": time.perf_counter() - t0})


def read_results(folder: str, flag: str = "RESULTS") -> dict:
    """The per-pair results of a results folder (``data/results_images`` or ``data/results``, or a
    copy of one kept from a run before a change): ``{"<config>/pNN.json": result}``. A folder that
    is not there or holds no ``<config>/pNN.json`` is an error naming ``flag``."""
    if not os.path.isdir(folder):
        raise CatadioptricError(f"{flag}: expected a folder of per-pair results (<config>/pNN.json, e.g. "
                                f"DATA/results_images of catadioptric validate benchmark), got {folder!r}")
    out = {}
    for config in sorted(os.listdir(folder)):
        sub = os.path.join(folder, config)
        if not os.path.isdir(sub):
            continue
        for name in sorted(os.listdir(sub)):
            if not (name.startswith("p") and name.endswith(".json")):
                continue
            path = os.path.join(sub, name)
            try:
                with open(path) as f:
                    r = json.load(f)
            except (OSError, ValueError) as exc:
                raise CatadioptricError(f"{flag}: {path} is not a readable JSON file ({exc})") from None
            if not isinstance(r, dict) or "config" not in r:
                raise CatadioptricError(f"{flag}: {path} is not a per-pair result of the benchmark")
            out[f"{config}/{name}"] = r
    if not out:
        raise CatadioptricError(f"{flag}: no per-pair results (<config>/pNN.json) in {folder!r}")
    return out


def stored_results(spec: dict, data: str, kind: str) -> list[dict]:
    """Every pair's stored result of ``kind`` in ``data``, in spec order, whatever code computed it
    (each result names its code digest, and the report says which): nothing is computed. A pair
    without a result is an error naming the first one missing and how many are."""
    folder = results_folder(data, kind)
    out, missing = [], []
    for config in spec["configs"]:
        for p in pairs_of(spec, config):
            path = os.path.join(folder, config["name"], f"p{p.index:02d}.json")
            try:
                with open(path) as f:
                    out.append(json.load(f))
            except FileNotFoundError:
                missing.append(path)
            except (OSError, ValueError) as exc:
                raise CatadioptricError(f"--data: {path} is not a readable JSON file ({exc})") from None
    if missing:
        raise CatadioptricError(f"--data: no result for {len(missing)} of {len(missing) + len(out)} pairs ({kind} "
                                f"path), e.g. {missing[0]}: run the benchmark, or write a committed report's "
                                f"results back first (catadioptric validate restore)")
    return out


def rewrite_report(spec: dict, data: str, out: str, *, images: bool = False, images_only: bool = False,
                   command: str = "") -> list:
    """The benchmark's report (``report.md``, ``report.json``, the plots; with ``images_only`` the
    image path's ``images.md`` / ``images.json``) written again from the per-pair results already in
    ``data``, computing none (:func:`stored_results`): for when one path's results were computed again
    with newer code and the other's still stand, or the results of a committed report were written
    back (:mod:`catadioptric.validate.restore`). The report keeps the command and the timing of the
    report already in ``out`` (the command that computes everything), else ``command``; an overlay
    not in ``data`` is kept from ``out``. Returns the code digests per path, ``[(path, {digest:
    pairs})]``."""
    from .benchmark_report import write_benchmark_report, write_images_report

    if not spec["configs"]:
        raise CatadioptricError("spec: expected at least one configuration")
    old = {}
    try:
        with open(os.path.join(out, "images.json" if images_only else "report.json")) as f:
            old = json.load(f)
    except (OSError, ValueError):
        pass
    command, timing = old.get("command") or command, old.get("timing") or {}
    overlays = {name: path if os.path.isfile(path) else os.path.join(out, f"images_{name}.png")
                for name, path in overlay_paths(spec, data).items()}
    image_results = stored_results(spec, data, "images") if images or images_only else None
    if images_only:
        write_images_report(spec, image_results, out, command=command, timing=timing, overlays=overlays)
        return [("images", _digests(image_results))]
    results = stored_results(spec, data, "labels")
    write_benchmark_report(spec, results, out, command=command, timing=timing, image_results=image_results,
                           overlays=overlays if images else None)
    return [("labels", _digests(results))] + ([("images", _digests(image_results))] if images else [])


def _digests(results) -> dict:
    count: dict = {}
    for r in results:
        key = str(r.get("code") or "unknown")[:8]
        count[key] = count.get(key, 0) + 1
    return count


def overlay_paths(spec, data) -> dict:
    """The image path's overlay of the first pair of each configuration (the report shows them)."""
    return {c["name"]: os.path.join(results_folder(data, "images"), c["name"], "p00.png") for c in spec["configs"]}


def run_benchmark(spec: dict, out: str, *, data: str | None = None, workers: int = 1, progress: bool = True,
                  command: str = "", images: bool = False) -> dict:
    """Render, evaluate and write the report into ``out``; the datasets and per-pair results go to
    ``data`` (default ``out``). ``images``: also the image-only path on every pair (its table
    and one overlay per configuration in the report). Returns the aggregate."""
    data = out if data is None else data
    from .benchmark_report import write_benchmark_report

    if not spec["configs"]:
        raise CatadioptricError("spec: expected at least one configuration")
    t0 = time.perf_counter()
    render_benchmark(spec, data, workers=workers, progress=progress)
    t1 = time.perf_counter()
    results = evaluate_benchmark(spec, data, workers=workers, progress=progress)
    t2 = time.perf_counter()
    image_results = evaluate_benchmark(spec, data, workers=workers, progress=progress, kind="images") if images else None
    t3 = time.perf_counter()
    return write_benchmark_report(spec, results, out, command=command, image_results=image_results,
                                  overlays=overlay_paths(spec, data) if images else None, timing={"render_seconds": t1 - t0, "evaluate_seconds": t2 - t1,
                                                             "images_seconds": t3 - t2})
