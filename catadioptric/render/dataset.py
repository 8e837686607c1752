"""Datasets on disk: one folder per view plus a manifest (format: docs/formats.md, "Datasets").

Each view folder holds ``beauty.png`` (RGB, 8-bit), ``labels.png`` (16-bit, the float64
tracer's labels), ``groundtruth.json`` + ``groundtruth.npz`` and ``preview.png``, every
file written atomically (temporary file + ``os.replace``), then ``done.json``: the
completion marker with the view's parameter fingerprint and the SHA-256 of every file.
A rerun skips a view whose marker matches its parameters and files, and redoes any
other (missing, killed half-way, corrupted, or rendered with other parameters).

Views run in this process (``workers=1``), in a local process pool (``workers=N``), or
on a Dask cluster (``scheduler=ADDRESS``): the same function renders each view, so the
outputs are byte-identical whichever way they ran.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError
from ..frames import RigPose
from .._io import atomic_write_bytes, atomic_write_json, jsonable, sha256_file
from .common import RenderError, encode_labels_png, load_quality
from .tracer import scene_digest

__all__ = ["render_dataset", "render_view_files", "ViewTask", "view_status", "FILES", "RENDERERS", "FORMAT"]

FORMAT = "catadioptric-dataset/1"
FILES = ("beauty.png", "labels.png", "groundtruth.json", "groundtruth.npz", "preview.png")
MARKER = "done.json"
RENDERERS = ("mitsuba", "povray")
MANIFEST = "manifest.json"
LOCK = ".catadioptric-lock"  # held (flock) by the run writing the dataset
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,127}$")


@dataclass
class ViewTask:
    """Everything one worker needs to render one view (picklable)."""

    name: str
    folder: str
    renderer: str
    quality: dict
    camera: dict
    pose: dict
    seed: int
    fingerprint: str
    scene_digest: str
    threads: int | None = None
    line_images: str = "core"
    extras: tuple = ()  # optional outputs (catadioptric.render.extras)
    mitsuba_variant: str | None = None  # the variant of the fingerprint: every worker must run it


_sha256 = sha256_file


def view_status(folder: str, fingerprint: str, extra_files=()) -> str:
    """``done`` (marker matches parameters and every file's checksum), ``stale`` (rendered with
    other parameters), ``broken`` (marker missing, unreadable or malformed, a file differs or is
    not a regular file, or the folder is a file or a symbolic link) or ``missing``."""
    if not os.path.lexists(folder):
        return "missing"
    if os.path.islink(folder) or not os.path.isdir(folder):
        return "broken"  # a link could be another view's folder: never written through
    try:
        with open(os.path.join(folder, MARKER), encoding="utf-8") as f:
            marker = json.load(f)
    except (OSError, ValueError):
        return "broken"
    if not isinstance(marker, dict):
        return "broken"
    if marker.get("fingerprint") != fingerprint:
        return "stale"
    files = marker.get("files")
    if not isinstance(files, dict) or set(files) != set(FILES) | set(extra_files):
        return "broken"
    for name, digest in files.items():
        p = os.path.join(folder, name)
        if not isinstance(digest, str) or os.path.islink(p) or not os.path.isfile(p) or _sha256(p) != digest:
            return "broken"
    return "done"


def _remove(path: str) -> None:
    """Remove whatever is at ``path`` (a file, a link, a folder tree); nothing if nothing is there."""
    if os.path.islink(path) or os.path.isfile(path):
        os.unlink(path)
    elif os.path.isdir(path):
        shutil.rmtree(path)


@contextlib.contextmanager
def _dataset_lock(out_dir: str):
    """Hold an exclusive lock on the dataset folder for a whole run (released when the process
    ends, however it ends): a second run on the same folder stops at once instead of deleting
    the first one's temporary files."""
    import fcntl

    path = os.path.join(out_dir, LOCK)
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise CatadioptricError(f"out_dir: another run is writing the dataset {out_dir!r} (it holds {path}); "
                                    f"wait for it to finish or write to another folder") from None
        yield
    finally:
        os.close(fd)


def _view_seed(scene_seed: int, name: str) -> int:
    return int.from_bytes(hashlib.sha256(f"{int(scene_seed)}/{name}".encode()).digest()[:4], "little")


def _fingerprint(d: dict) -> str:
    return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()


# ------------------------------------------------------------------- one view
def render_view_files(scene, task: ViewTask) -> dict:
    """Render one view and write its folder (the function every worker runs)."""
    import cv2

    from ..cameras import CatadioptricCamera
    from .groundtruth import ground_truth, groundtruth_json, preview_image, write_npz
    from .tracer import pixel_rays, trace_rays

    t_start = time.perf_counter()
    if getattr(scene, "_catadioptric_digest", None) is None:
        scene._catadioptric_digest = scene_digest(scene)
    if scene._catadioptric_digest != task.scene_digest:
        raise CatadioptricError(f"scene: the worker received a scene whose digest {scene._catadioptric_digest[:12]} "
                                f"differs from the task's {task.scene_digest[:12]}")
    cam = CatadioptricCamera.from_dict(task.camera)
    pose = RigPose(np.array(task.pose["R"]), np.array(task.pose["t"]))
    if os.path.islink(task.folder) or (os.path.lexists(task.folder) and not os.path.isdir(task.folder)):
        _remove(task.folder)  # a link (perhaps to another view's folder) or a file where the folder goes
    os.makedirs(task.folder, exist_ok=True)
    # a stale marker must not survive a half-written rerun; leftovers of killed writes go too (the run
    # holds the dataset's lock: no other run's temporaries are in flight)
    for name in os.listdir(task.folder):
        if name == MARKER or (name.startswith(".") and name.endswith(".tmp")):
            _remove(os.path.join(task.folder, name))
    if task.renderer not in RENDERERS:
        raise CatadioptricError(f"renderer: expected one of {list(RENDERERS)}, got {task.renderer!r}")

    def truth():
        t = time.perf_counter()
        traced = trace_rays(scene, cam, pose)
        t_trace = time.perf_counter()
        gt = ground_truth(scene, cam, pose, view=task.name, traced=traced, line_images=task.line_images)
        return traced, gt, t_trace - t, time.perf_counter() - t_trace

    # the ground truth does not depend on the render: unless the view is held to one thread, it
    # is computed beside the renderer (in a thread; the same arrays either way)
    pixel_rays(cam)  # the rig's pixel rays, shared by both, computed once
    with ThreadPoolExecutor(max_workers=1) as pool:
        beside = pool.submit(truth) if task.threads != 1 else None
        t0 = time.perf_counter()
        if task.renderer == "mitsuba":
            from .mitsuba import ENV, mitsuba_variant, render_mitsuba

            if task.mitsuba_variant:
                os.environ.setdefault(ENV, task.mitsuba_variant)
                if mitsuba_variant() != task.mitsuba_variant:
                    raise RenderError(f"mitsuba: this worker runs the variant {mitsuba_variant()!r}, the dataset's "
                                      f"fingerprint says {task.mitsuba_variant!r}; set {ENV}={task.mitsuba_variant} "
                                      f"on every worker")
            if task.threads:
                import drjit as dr

                dr.set_thread_count(int(task.threads))
            res = render_mitsuba(scene, cam, pose, task.quality, seed=task.seed)
        else:
            from .povray import render_povray

            res = render_povray(scene, cam, pose, task.quality, threads=task.threads)
        t1 = time.perf_counter()
        traced, gt, s_trace, s_gt = beside.result() if beside is not None else truth()
    t3 = time.perf_counter()
    diff = res.labels != traced.labels
    agreement = {"renderer": task.renderer, "differing_pixels": int(diff.sum()), "pixels": int(diff.size),
                 "differing_unambiguous_pixels": int((diff & ~traced.ambiguous).sum()),
                 "first_differing": [[int(r), int(c), int(traced.labels[r, c]), int(res.labels[r, c])]
                                     for r, c in np.argwhere(diff)[:20]]}
    info = {k: v for k, v in res.info.items() if not k.startswith("seconds")}
    j = groundtruth_json(gt, scene, {"renderer": info, "renderer_label_agreement": agreement,
                                     "scene": {"name": scene.name, "seed": int(scene.seed),
                                               "digest": task.scene_digest},
                                     "seed": task.seed})

    def png(img, *flags):
        ok, buf = cv2.imencode(".png", img, list(flags))
        if not ok:
            raise RenderError(f"opencv: could not encode a PNG for view {task.name!r}")
        return buf.tobytes()

    blobs = {
        "beauty.png": png(np.ascontiguousarray(res.beauty[..., ::-1]), cv2.IMWRITE_PNG_COMPRESSION, 6),
        "labels.png": png(encode_labels_png(traced.labels), cv2.IMWRITE_PNG_COMPRESSION, 6),
        "groundtruth.json": (json.dumps(j, indent=1, allow_nan=False) + "\n").encode(),
        "groundtruth.npz": write_npz(gt.arrays()),
        "preview.png": png(np.ascontiguousarray(preview_image(res.beauty, gt, scene)[..., ::-1]),
                           cv2.IMWRITE_PNG_COMPRESSION, 6),
    }
    if task.extras:
        from .extras import extra_blobs

        blobs.update(extra_blobs(task.extras, res, traced, pose))
    for name, data in blobs.items():
        path = os.path.join(task.folder, name)
        if os.path.islink(path) or os.path.isdir(path):
            _remove(path)  # a folder or a link where the file goes
        atomic_write_bytes(path, data)
    atomic_write_json(os.path.join(task.folder, MARKER), {
        "view": task.name, "fingerprint": task.fingerprint,
        "files": {name: hashlib.sha256(data).hexdigest() for name, data in blobs.items()}})
    t4 = time.perf_counter()
    return {"view": task.name, "status": "rendered", "seconds": t4 - t_start,
            "seconds_parts": {"render": t1 - t0, "trace": s_trace, "groundtruth": s_gt, "files": t4 - t3},
            "label_differing_pixels": agreement["differing_pixels"], "pixels": agreement["pixels"]}


_WORKER_SCENE = {}


def _pool_init(scene):
    _WORKER_SCENE["scene"] = scene


def _pool_run(task: ViewTask) -> dict:
    return render_view_files(_WORKER_SCENE["scene"], task)


# ------------------------------------------------------------------ versions
def _git_commit() -> dict:
    here = os.path.dirname(os.path.abspath(__file__))
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, cwd=here,
                                timeout=20).stdout.strip() or None
        dirty = bool(subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True,
                                    text=True, cwd=here, timeout=20).stdout.strip()) if commit else None
    except (OSError, subprocess.TimeoutExpired):
        commit, dirty = None, None
    return {"commit": commit, "dirty": dirty}


def _versions(renderer: str) -> dict:
    import cv2

    from .. import __version__
    from .mitsuba import mitsuba_version
    from .povray import povray_version

    out = {"python": platform.python_version(), "numpy": np.__version__, "opencv": cv2.__version__,
           "catadioptric": __version__, "mitsuba": mitsuba_version(), "povray": povray_version()}
    if renderer == "mitsuba":
        from .mitsuba import mitsuba_variant

        out["mitsuba_variant"] = mitsuba_variant()
    return out


# ------------------------------------------------------------------ the dataset
def render_dataset(scene, views, cam, out_dir, *, renderer: str = "mitsuba", quality="standard", workers: int = 1,
                   scheduler=None, rig: dict | None = None, progress: bool = True, line_images: str = "core",
                   extras=()) -> dict:
    """Render every view ``(name, RigPose)`` of ``scene`` seen by the rig ``cam`` into ``out_dir``.

    ``workers > 1`` renders views in a local process pool; ``scheduler`` (a Dask scheduler
    address such as ``tcp://127.0.0.1:8786``, or a ``distributed.Client``) runs them on a
    Dask cluster instead. Finished views are skipped (see :func:`view_status`). ``line_images``:
    how the ground truth's line images are computed (:func:`catadioptric.render.groundtruth.ground_truth`).
    ``extras``: optional outputs among ``rays``, ``beauty16``, ``mesh`` (:mod:`catadioptric.render.extras`).
    Returns the manifest (also written to ``out_dir/manifest.json``).
    """
    from ..cameras import CatadioptricCamera
    from .groundtruth import LINE_IMAGES

    if renderer not in RENDERERS:
        raise CatadioptricError(f"renderer: expected one of {list(RENDERERS)}, got {renderer!r}")
    if not isinstance(cam, CatadioptricCamera):
        raise CatadioptricError(f"cam: expected a CatadioptricCamera, got {type(cam).__name__}")
    if not (isinstance(workers, int) and not isinstance(workers, bool) and workers >= 1):
        raise CatadioptricError(f"workers: expected an integer >= 1, got {workers!r}")
    if line_images not in LINE_IMAGES:
        raise CatadioptricError(f"line_images: expected one of {sorted(LINE_IMAGES)}, got {line_images!r}")
    from .extras import EXTRA_FILES, MESH_FILE, check_extras

    extras = check_extras(extras, renderer)
    extra_files = [EXTRA_FILES[e] for e in extras if e in EXTRA_FILES]
    q = load_quality(quality)
    views = list(views)
    if not views:
        raise CatadioptricError("views: expected at least one (name, RigPose) pair, got none")
    names = set()
    reserved = {MANIFEST, MESH_FILE}
    for i, v in enumerate(views):
        if not (isinstance(v, (tuple, list)) and len(v) == 2 and isinstance(v[1], RigPose)):
            raise CatadioptricError(f"views[{i}]: expected a (name, RigPose) pair, got {v!r}")
        if not (isinstance(v[0], str) and _NAME.match(v[0])):
            raise CatadioptricError(f"views[{i}]: expected a view name of letters, digits, '_', '.', '-' "
                                    f"(a folder name), got {v[0]!r}")
        if v[0].lower() in reserved:
            raise CatadioptricError(f"views[{i}]: expected a view name other than the dataset's own files "
                                    f"{sorted(reserved)} (in any case), got {v[0]!r}")
        if v[0].lower() in names:
            raise CatadioptricError(f"views[{i}]: the view name {v[0]!r} is used twice (folder names are "
                                    f"compared without case)")
        names.add(v[0].lower())
    digest = scene_digest(scene)
    scene._catadioptric_digest = digest
    # what can fail before the first view fails before the output folder is made
    if renderer == "povray":
        from .povray import povray_binary

        povray_binary()  # a clear error now rather than in every worker
    versions = _versions(renderer)  # for mitsuba: probes and sets the variant once, before any worker starts
    if os.path.lexists(out_dir) and not os.path.isdir(out_dir):
        raise CatadioptricError(f"out_dir: expected a folder (new or a dataset's), got a file {out_dir!r}")
    for own in [MANIFEST] + ([MESH_FILE] if "mesh" in extras else []):  # written at the end of the run
        p = os.path.join(out_dir, own)
        if os.path.lexists(p) and not os.path.islink(p) and not os.path.isfile(p):
            what = "a folder" if os.path.isdir(p) else "not a regular file"
            raise CatadioptricError(f"out_dir: the dataset's file {p!r} is {what}; remove or rename it (the run "
                                    f"writes its {own} there)")
    try:
        os.makedirs(out_dir, exist_ok=True)
    except OSError as exc:  # a read-only or virtual file system (/proc), a name over the system's limit...
        raise CatadioptricError(f"out_dir: cannot create the folder {out_dir!r} ({exc.strerror or exc})") from None
    with _dataset_lock(out_dir):
        return _render_locked(scene, views, cam, out_dir, renderer, q, workers, scheduler, rig, progress, line_images,
                              extras, extra_files, digest, versions)


def _render_locked(scene, views, cam, out_dir, renderer, q, workers, scheduler, rig, progress, line_images, extras,
                   extra_files, digest, versions) -> dict:
    """The run of :func:`render_dataset` once its arguments are checked and the dataset is locked."""
    threads = None
    if workers > 1 or scheduler is not None:
        threads = max(1, (os.cpu_count() or 1) // workers) if scheduler is None else None
    def fingerprint(name, pose_dict):
        params = {"format": FORMAT, "renderer": renderer, "quality": q, "camera": cam.to_dict(), "pose": pose_dict,
                  "scene": digest, "seed": _view_seed(scene.seed, name), "line_images": line_images}
        if extras:  # absent when none, so that the fingerprints of plain datasets do not change
            params["extras"] = list(extras)
        if renderer == "mitsuba":  # llvm and the scalar fallback differ in their last bits: never mixed
            params["mitsuba_variant"] = versions["mitsuba_variant"]
        return _fingerprint(params)

    tasks, entries = [], []
    for name, pose in views:
        seed = _view_seed(scene.seed, name)
        fp = fingerprint(name, pose.to_dict())
        folder = os.path.join(out_dir, name)
        tasks.append(ViewTask(name, folder, renderer, q, cam.to_dict(), pose.to_dict(), seed, fp, digest, threads,
                              line_images, extras, versions.get("mitsuba_variant")))
        entries.append({"name": name, "folder": name, "seed": seed, "pose": pose.to_dict(), "fingerprint": fp})
    status = {t.name: view_status(t.folder, t.fingerprint, extra_files) for t in tasks}
    todo = [t for t in tasks if status[t.name] != "done"]
    results = {}
    t0 = time.perf_counter()
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(tasks), initial=len(tasks) - len(todo), unit="view", desc=f"render {renderer}",
                   file=sys.stderr, dynamic_ncols=True)
    try:
        for res in _run(scene, todo, workers, scheduler):
            results[res["view"]] = res
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    agreement = {}
    for e, t in zip(entries, tasks):
        with open(os.path.join(t.folder, "groundtruth.json")) as f:
            ag = json.load(f)["renderer_label_agreement"]
        e["label_differing_pixels"] = ag["differing_pixels"]
        agreement[t.name] = ag["differing_pixels"]
    # views of an earlier run that this one was not asked for (a subset) stay in the manifest while
    # their folders are done with these parameters: a run on some views does not hide the others
    kept = [e for e in _earlier_views(out_dir) if e["name"] not in status and view_status(
        os.path.join(out_dir, e["name"]), fingerprint(e["name"], e["pose"]), extra_files) == "done"]
    if kept:
        entries = sorted(entries + kept, key=lambda e: e["name"])
        agreement.update({e["name"]: e["label_differing_pixels"] for e in kept})
    total_px = cam.pinhole.width * cam.pinhole.height * len(entries)
    scene_info = {}
    if "mesh" in extras:
        from .extras import MESH_FILE, scene_ply

        atomic_write_bytes(os.path.join(out_dir, MESH_FILE), scene_ply(scene))
        scene_info = {"mesh": MESH_FILE}
    manifest = {
        "format": FORMAT,
        "scene": {"name": scene.name, "seed": int(scene.seed), "digest": digest, "spec": jsonable(scene.spec),
                  "objects": len(scene.objects), "segments": int(len(scene.segments)),
                  "families": int(len(scene.families)),
                  "triangles": int(sum(len(o.faces) for o in scene.objects)), **scene_info},
        "rig": {**jsonable(rig or {}), "camera": cam.to_dict()},
        "renderer": {"name": renderer, "quality": q},
        "line_images": line_images,
        "versions": versions,
        **_git_commit(),
        "files": list(FILES) + extra_files + [MARKER],
        "labels": {"sky": 0, "no_mirror": -1, "mirror_again": -2,
                   "png": "uint16; 0..65533 as is, 65535 = -1, 65534 = -2"},
        "views": entries,
        "label_agreement": {"differing_pixels": int(sum(agreement.values())), "pixels": int(total_px)},
        "run": {"created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "workers": workers,
                "scheduler": None if scheduler is None else str(getattr(scheduler, "scheduler", scheduler)),
                "rendered": sorted(results), "skipped": sorted(set(status) - set(results)),
                "status_before": status, "seconds": time.perf_counter() - t0,
                "view_seconds": {k: v.get("seconds_parts", {}) | {"total": v["seconds"]} for k, v in results.items()}},
    }
    atomic_write_json(os.path.join(out_dir, MANIFEST), manifest)
    return manifest


def _earlier_views(out_dir: str) -> list:
    """The view entries of the manifest already in ``out_dir`` (none when there is none or it is not
    a dataset's manifest)."""
    try:
        with open(os.path.join(out_dir, MANIFEST)) as f:
            views = json.load(f).get("views", [])
    except (OSError, ValueError, AttributeError):
        return []
    return [e for e in views if isinstance(e, dict) and isinstance(e.get("name"), str) and _NAME.match(e["name"])
            and isinstance(e.get("pose"), dict) and "label_differing_pixels" in e]


def _run(scene, todo, workers, scheduler):
    """Yield each view's result as it finishes (in-process, process pool or Dask)."""
    if not todo:
        return
    if scheduler is not None:
        from dask.distributed import Client, as_completed

        client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
        try:
            [fut_scene] = client.scatter([scene], broadcast=True)
            futs = [client.submit(render_view_files, fut_scene, t, pure=False, key=f"render-{t.name}-{t.fingerprint[:12]}")
                    for t in todo]
            for fut in as_completed(futs):
                yield fut.result()
        finally:
            if client is not scheduler:
                client.close()
        return
    if workers == 1:
        for t in todo:
            yield render_view_files(scene, t)
        return
    from .._pool import imap_spawn

    yield from imap_spawn(_pool_run, todo, workers, initializer=_pool_init, initargs=(scene,))
