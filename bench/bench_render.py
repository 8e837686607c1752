"""Rendering benchmark: seconds per 640x480 view for each renderer (beauty + labels + float64
ground truth + files) and views per minute of a dataset rendered with --workers 1 and 2.

    .venv/bin/python bench/bench_render.py [--scene urban_street] [--views 6] [--size 640x480]
                                           [--line-images core|sampled]
    .venv/bin/python bench/bench_render.py --agreement --size 160x120   # label agreement, 24 views
    .venv/bin/python bench/bench_render.py --dataset render/urban_street_walk.toml --views 1000 \
        --run workers:2|dask:1|dask:2 [--out DIR]                        # a whole dataset, end to end
    .venv/bin/python bench/bench_render.py --qualities standard,high [--renderers mitsuba] [--views 4]
                                                        # one renderer's presets, alternating view by view

Writes bench/results/render.json (render-sampled.json with --line-images sampled;
render-dataset-<views>-<run>.json with --dataset, render-quality-<renderer>.json with --qualities;
commit, versions, machine: bench/common.py).
Every timing comes with the CPU seconds it took (this process and its children: the load of
other work on a shared machine stretches wall time, not CPU time) and the load average
before and after. Standalone (not in bench/run.py: it needs POV-Ray and takes about ten
minutes on the 2-core machine).
"""
from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))

from common import metadata, write_json  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def cpu_seconds() -> float:
    """User + system CPU seconds of this process (all its threads) and of its finished children."""
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def _views(spec, n):
    """The spec's views, then the same positions turned about the vertical until there are n."""
    from catadioptric import RigPose
    from catadioptric.scenes import views

    base = views(spec)
    out = list(base)
    k = 0
    while len(out) < n:
        name, pose = base[k % len(base)]
        yaw = np.radians(37.0 * (k // len(base) + 1))
        Rz = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1.0]])
        Rw = Rz @ pose.R.T  # mirror axes in W, turned about W's vertical
        out.append((f"{name}_yaw{k}", RigPose.from_mirror_in_world(Rw, pose.origin_in_world)))
        k += 1
    return out[:n]


def run(scene_name="urban_street", n_views=6, size=(640, 480), renderers=("mitsuba", "povray"),
        line_images="core") -> dict:
    from catadioptric.render.common import load_quality
    from catadioptric.render.dataset import ViewTask, render_dataset, render_view_files
    from catadioptric.render.mitsuba import mitsuba_variant
    from catadioptric.render.povray import povray_version
    from catadioptric.render.groundtruth import ground_truth
    from catadioptric.render.tracer import scene_digest, trace_rays
    from catadioptric.scenes import build_scene, scene_rig

    load_before = os.getloadavg()
    t = time.perf_counter()
    scene = build_scene(scene_name)
    t_build = time.perf_counter() - t
    cam = scene_rig(scene.spec, width=size[0], height=size[1])
    views = _views(scene.spec, max(n_views, 3))
    scene._catadioptric_digest = scene_digest(scene)
    q = load_quality("standard")
    out = {"scene": {"name": scene.name, "triangles": scene.triangle_count, "segments": int(len(scene.segments)),
                     "build_seconds": t_build},
           "image": list(size), "quality": q, "line_images": line_images, "mitsuba_variant": mitsuba_variant(), "povray": povray_version(),
           "per_view": {}, "dataset": {}}
    # the ground truth alone (tracer + line images, no renderer beside it), first view twice (warm-up)
    alone = []
    for name, pose in [views[0]] + views[:3]:
        t, c = time.perf_counter(), cpu_seconds()
        traced = trace_rays(scene, cam, pose)
        t1 = time.perf_counter()
        ground_truth(scene, cam, pose, view=name, traced=traced, line_images=line_images)
        alone.append({"view": name, "trace": t1 - t, "groundtruth": time.perf_counter() - t1,
                      "cpu_seconds": cpu_seconds() - c})
    out["ground_truth_alone"] = {k: float(np.median([x[k] for x in alone[1:]]))
                                 for k in ("trace", "groundtruth", "cpu_seconds")} | {"views": alone}
    print("  ground truth alone: " + " ".join(f"{k} {v:.2f}" for k, v in out["ground_truth_alone"].items()
                                              if k != "views"), flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for r in renderers:
            rows = []
            # first view twice: the first run includes Mitsuba's kernel compilation and the BVH build
            for i, (name, pose) in enumerate([views[0]] + views[:3]):
                task = ViewTask(name, os.path.join(tmp, r, f"{i}_{name}"), r, q, cam.to_dict(), pose.to_dict(), 0,
                                "bench", scene._catadioptric_digest, line_images=line_images)
                c = cpu_seconds()
                res = render_view_files(scene, task)
                rows.append({"view": name, "seconds": res["seconds"], "cpu_seconds": cpu_seconds() - c,
                             **res["seconds_parts"], "label_differing_pixels": res["label_differing_pixels"]})
                print(f"  {r} {name}: {res['seconds']:.2f} s (cpu {rows[-1]['cpu_seconds']:.2f} s) "
                      + " ".join(f"{k} {v:.2f}" for k, v in res["seconds_parts"].items()), flush=True)
            warm = rows[1:]
            out["per_view"][r] = {"first_view_seconds": rows[0]["seconds"],
                                  "seconds_per_view": float(np.median([x["seconds"] for x in warm])),
                                  "cpu_seconds_per_view": float(np.median([x["cpu_seconds"] for x in warm])),
                                  "parts_median": {k: float(np.median([x[k] for x in warm]))
                                                   for k in ("render", "trace", "groundtruth", "files")},
                                  "views": rows}
            for workers in ((1, 2) if n_views else ()):  # --views 0: the per-view figures only
                d = os.path.join(tmp, f"ds_{r}_{workers}")
                t, c = time.perf_counter(), cpu_seconds()
                m = render_dataset(scene, views[:n_views], cam, d, renderer=r, quality=q, workers=workers,
                                   progress=False, line_images=line_images)
                dt = time.perf_counter() - t
                out["dataset"][f"{r}_workers{workers}"] = {
                    "views": n_views, "seconds": dt, "views_per_minute": 60.0 * n_views / dt,
                    "cpu_seconds_per_view": (cpu_seconds() - c) / n_views,
                    "label_differing_pixels": m["label_agreement"]["differing_pixels"],
                    "pixels": m["label_agreement"]["pixels"]}
                print(f"  {r} dataset of {n_views} views, --workers {workers}: {dt:.1f} s, "
                      f"{60 * n_views / dt:.1f} views/min", flush=True)
    out["loadavg_before"], out["loadavg_after"] = list(load_before), list(os.getloadavg())
    return out


def qualities(scene_name="urban_street", renderer="mitsuba", names=("standard", "high"), n_views=4,
              size=(640, 480)) -> dict:
    """Seconds per view of one renderer at each quality preset, measured in one run: each view is
    rendered at every preset in turn (the machine's load falls on all alike), after one warm-up
    view per preset; the ratios are of the medians to the first preset's."""
    from catadioptric.render.common import load_quality
    from catadioptric.render.dataset import ViewTask, render_view_files
    from catadioptric.render.tracer import scene_digest
    from catadioptric.scenes import build_scene, scene_rig

    load_before = os.getloadavg()
    scene = build_scene(scene_name)
    scene._catadioptric_digest = scene_digest(scene)
    cam = scene_rig(scene.spec, width=size[0], height=size[1])
    views = _views(scene.spec, max(n_views, 1))
    presets = {q: load_quality(q) for q in names}
    rows = {q: [] for q in names}
    with tempfile.TemporaryDirectory() as tmp:
        for i, (name, pose) in enumerate([views[0]] + views[:n_views]):
            for q in names:
                task = ViewTask(name, os.path.join(tmp, q, f"{i}_{name}"), renderer, presets[q], cam.to_dict(),
                                pose.to_dict(), 0, "bench", scene._catadioptric_digest)
                c = cpu_seconds()
                res = render_view_files(scene, task)
                row = {"view": name, "seconds": res["seconds"], "cpu_seconds": cpu_seconds() - c,
                       "render": res["seconds_parts"]["render"]}
                print(f"  {renderer} {q} {name}: {row['seconds']:.2f} s (render {row['render']:.2f} s, cpu "
                      f"{row['cpu_seconds']:.2f} s){' warm-up' if i == 0 else ''}", flush=True)
                if i:
                    rows[q].append(row)
    med = {q: {k: float(np.median([r[k] for r in rows[q]])) for k in ("seconds", "render", "cpu_seconds")}
           for q in names}
    base = med[names[0]]
    return {"renderer": renderer, "image": list(size), "scene": scene.name, "views": n_views,
            "presets": presets, "median": med,
            "ratio_to_" + names[0]: {q: {k: med[q][k] / base[k] for k in base} for q in names},
            "rows": rows, "loadavg_before": list(load_before), "loadavg_after": list(os.getloadavg())}


def agreement(size=(160, 120)) -> dict:
    """Label images of both renderers against the float64 tracer on 24 views: the test street
    seen by six rigs (three views each) and the tiny_street, chessboard and urban_street specs
    (two views each). Counts differing pixels, and those off the tie pixels."""
    from catadioptric.render.mitsuba import render_mitsuba
    from catadioptric.render.povray import render_povray
    from catadioptric.render.testscene import street_scene, street_views
    from catadioptric.render.tracer import trace_rays
    from catadioptric.rigspec import load_rig
    from catadioptric.scenes import build_scene, scene_rig, views

    W, H = size
    cases = []
    street = street_scene(0)
    for rig in ("hyperboloid_9pct", "hyperboloid_central", "sphere", "ellipsoid", "paraboloid", "cone"):
        cases.append(("test_street", rig, street, load_rig(rig, width=W, height=H), street_views(rig)))
    for spec in ("tiny_street", "chessboard", "urban_street"):
        s = build_scene(spec)
        cases.append((spec, s.spec["rig"], s, scene_rig(s.spec, width=W, height=H), views(s.spec)))
    keys = ("mitsuba", "povray", "between", "mitsuba_off_ties", "povray_off_ties", "between_off_ties", "ties")
    total = dict.fromkeys(keys, 0) | {"pixels": 0, "views": 0}
    rows = []
    for name, rig, scene, cam, vs in cases:
        for vn, pose in vs:
            tr = trace_rays(scene, cam, pose)
            mi = render_mitsuba(scene, cam, pose, "draft", beauty=False).labels
            pv = render_povray(scene, cam, pose, "draft", beauty=False).labels
            tie = tr.ambiguous
            dm, dp, db = mi != tr.labels, pv != tr.labels, mi != pv
            row = {"scene": name, "rig": rig, "view": vn, "mitsuba": int(dm.sum()), "povray": int(dp.sum()),
                   "between": int(db.sum()), "mitsuba_off_ties": int((dm & ~tie).sum()),
                   "povray_off_ties": int((dp & ~tie).sum()), "between_off_ties": int((db & ~tie).sum()),
                   "ties": int(tie.sum())}
            rows.append(row)
            for k in keys:
                total[k] += row[k]
            total["pixels"] += tie.size
            total["views"] += 1
            print(f"  {name} {rig} {vn}: " + " ".join(f"{k} {row[k]}" for k in keys), flush=True)
    return {"image": [W, H], "total": total, "views": rows}


def dataset(spec_path, n_views, run_how, size=(640, 480), out_dir=None) -> dict:
    """Render the first ``n_views`` views of a scene spec into a dataset, end to end, with
    ``run_how`` = ``workers:N`` (local processes) or ``dask:N`` (a Dask LocalCluster of N
    single-threaded worker processes): views per minute, where the time goes (each view's parts,
    measured in the worker), CPU seconds, and for Dask the scheduler's overhead from its task
    stream (per task: the time a worker spent outside our function, and the idle gaps between
    tasks)."""
    from catadioptric.render.common import load_quality
    from catadioptric.render.dataset import render_dataset
    from catadioptric.scenes import build_scene, scene_rig, spec_path as resolve, views

    kind, _, count = run_how.partition(":")
    if kind not in ("workers", "dask") or not count.isdigit() or int(count) < 1:
        raise SystemExit(f"bench_render.py: error: --run: expected workers:N or dask:N, got {run_how!r}")
    count = int(count)
    load_before = os.getloadavg()
    t0 = time.perf_counter()
    scene = build_scene(resolve(spec_path))
    cam = scene_rig(scene.spec, width=size[0], height=size[1])
    vs = views(scene.spec)[:n_views]
    q = load_quality("standard")
    tmp = None
    if out_dir is None:
        tmp = tempfile.TemporaryDirectory()
        out_dir = tmp.name
    stream = None
    c0 = cpu_seconds()
    t_render = time.perf_counter()
    if kind == "workers":
        m = render_dataset(scene, vs, cam, out_dir, renderer="mitsuba", quality=q, workers=count, progress=False)
    else:
        from dask.distributed import Client, LocalCluster, get_task_stream

        with LocalCluster(n_workers=count, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
                Client(cluster) as client:
            t_render = time.perf_counter()
            with get_task_stream(client) as ts:
                m = render_dataset(scene, vs, cam, out_dir, renderer="mitsuba", quality=q, scheduler=client,
                                   progress=False)
            stream = ts.data
    wall = time.perf_counter() - t_render
    cpu = cpu_seconds() - c0
    total = time.perf_counter() - t0
    per = m["run"]["view_seconds"]
    parts = {k: [v[k] for v in per.values()] for k in ("render", "trace", "groundtruth", "files", "total")}
    out = {"spec": str(spec_path), "run": run_how, "image": list(size), "quality": q["name"], "views": len(vs),
           "rendered": len(m["run"]["rendered"]), "seconds": wall, "seconds_with_setup": total,
           "views_per_minute": 60.0 * len(m["run"]["rendered"]) / wall,
           "cpu_seconds": cpu, "cpu_seconds_per_view": cpu / max(len(m["run"]["rendered"]), 1),
           "view_seconds_median": {k: float(np.median(v)) for k, v in parts.items()},
           "view_seconds_sum": {k: float(np.sum(v)) for k, v in parts.items()},
           # the part of the wall time not spent inside a view (start-up, scheduling, the manifest)
           "overhead_seconds": wall - float(np.sum(parts["total"])) / count,
           "label_differing_pixels": m["label_agreement"]["differing_pixels"],
           "pixels": m["label_agreement"]["pixels"],
           "loadavg_before": list(load_before), "loadavg_after": list(os.getloadavg())}
    if stream:
        out["dask"] = _task_stream_overhead(stream, per)
    if tmp is not None:
        tmp.cleanup()
    return out


def _task_stream_overhead(stream, view_seconds) -> dict:
    """Per task: compute time on the worker minus the view's own seconds (call, (de)serialisation
    of the task and its result), and the idle gaps between one task's end and the next one's start
    on each worker thread (the scheduler's round trip), from Dask's task stream."""
    tasks = []
    for rec in stream:
        comp = [s for s in rec.get("startstops", []) if s.get("action") == "compute"]
        if not comp or not str(rec["key"]).startswith("render-"):
            continue
        name = str(rec["key"])[len("render-"):-13]  # render-<view>-<12 hex digits>
        tasks.append((rec["worker"], rec.get("thread"), comp[0]["start"], comp[-1]["stop"], name))
    extra = [stop - start - view_seconds[n]["total"] for _, _, start, stop, n in tasks if n in view_seconds]
    gaps = []
    by_thread = {}
    for w, th, start, stop, _ in tasks:
        by_thread.setdefault((w, th), []).append((start, stop))
    for runs in by_thread.values():
        runs.sort()
        gaps += [b[0] - a[1] for a, b in zip(runs, runs[1:])]
    return {"tasks": len(tasks), "worker_threads": len(by_thread),
            "in_task_outside_view_seconds_median": float(np.median(extra)) if extra else None,
            "gap_between_tasks_seconds_median": float(np.median(gaps)) if gaps else None,
            "gap_between_tasks_seconds_max": float(np.max(gaps)) if gaps else None,
            "gap_between_tasks_seconds_sum": float(np.sum(gaps)) if gaps else 0.0}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="urban_street", help="scene spec name or file (default urban_street)")
    ap.add_argument("--views", type=int, default=6,
                    help="views in the dataset runs (default 6; 0: per-view figures only); with --dataset: "
                         "the first N views of the spec")
    ap.add_argument("--size", default="640x480", help="image size WIDTHxHEIGHT (default 640x480)")
    ap.add_argument("--renderers", default="mitsuba,povray")
    ap.add_argument("--line-images", default="core", choices=["core", "sampled"])
    ap.add_argument("--agreement", action="store_true",
                    help="instead: label agreement of both renderers with the tracer on 24 views "
                         "(bench/results/render-agreement-WxH.json)")
    ap.add_argument("--dataset", metavar="SPEC",
                    help="instead: render the first --views views of this scene spec as one dataset "
                         "(bench/results/render-dataset-<views>-<run>.json)")
    ap.add_argument("--run", default="workers:2", help="with --dataset: workers:N or dask:N (default workers:2)")
    ap.add_argument("--out", help="with --dataset: keep the dataset in this folder (default: a temporary one)")
    ap.add_argument("--qualities", metavar="Q1,Q2,...",
                    help="instead: the first renderer of --renderers at these presets, view by view in turn "
                         "(bench/results/render-quality-<renderer>.json; --views views, default 6)")
    args = ap.parse_args()
    w, h = (int(x) for x in args.size.split("x"))
    if args.qualities:
        renderer = args.renderers.split(",")[0]
        names = tuple(args.qualities.split(","))
        res = qualities(args.scene, renderer, names, args.views, (w, h))
        path = os.path.join(HERE, "results", f"render-quality-{renderer}.json")
        write_json(path, {"benchmark": "render-quality", "meta": metadata(), **res})
        ratio = res["ratio_to_" + names[0]]
        print(f"wrote {os.path.relpath(path)}: " + ", ".join(
            f"{q} {res['median'][q]['seconds']:.2f} s per view ({ratio[q]['seconds']:.2f}x, render "
            f"{ratio[q]['render']:.2f}x, CPU {ratio[q]['cpu_seconds']:.2f}x)" for q in names))
        return 0
    if args.dataset:
        res = dataset(args.dataset, args.views, args.run, (w, h), args.out)
        path = os.path.join(HERE, "results", f"render-dataset-{args.views}-{args.run.replace(':', '')}.json")
        write_json(path, {"benchmark": "render-dataset", "meta": metadata(), **res})
        print(f"wrote {os.path.relpath(path)}: {res['views_per_minute']:.1f} views/min, "
              f"{res['cpu_seconds_per_view']:.2f} CPU s per view, overhead {res['overhead_seconds']:.1f} s")
        return 0
    if args.agreement:
        res = agreement((w, h))
        path = os.path.join(HERE, "results", f"render-agreement-{w}x{h}.json")
        write_json(path, {"benchmark": "render-agreement", "meta": metadata(), **res})
        print(f"wrote {os.path.relpath(path)}: {res['total']}")
        return 0
    res = run(args.scene, args.views, (w, h), tuple(args.renderers.split(",")), args.line_images)
    name = "render.json" if args.line_images == "core" else f"render-{args.line_images}.json"
    path = os.path.join(HERE, "results", name)
    write_json(path, {"benchmark": "render", "meta": metadata(), **res})
    print(f"wrote {os.path.relpath(path)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
