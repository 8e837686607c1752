"""``catadioptric render``: render a scene spec's views into a dataset folder.

    catadioptric render SPEC --renderer mitsuba|povray --out DIR [--rig NAME_OR_FILE]
                        [--quality PRESET] [--resolution NAME|WxH] [--seed N] [--views A,B]
                        [--workers N] [--scheduler ADDRESS] [--line-images core|sampled]

SPEC is a scene spec file or a name in ``scenes/`` (``catadioptric.scenes``); the
special name ``builtin:test_street`` is the renderers' own test scene
(:mod:`catadioptric.render.testscene`). The rig is ``--rig`` (a name of ``render/rigs``
or a preset, or a rig spec file) or else the one the scene spec names.
"""
from __future__ import annotations

import sys

__all__ = ["register", "run"]

BUILTIN = "builtin:test_street"


def _load(args):
    """Scene, views, camera and rig description from the command line."""
    from .._checks import CatadioptricError
    from ..rigspec import load_rig, load_rig_spec
    from .common import load_resolution

    w, h = load_resolution(args.resolution) if args.resolution else (None, None)
    if args.spec == BUILTIN:
        from .testscene import street_scene, street_views

        scene = street_scene(0 if args.seed is None else args.seed)
        rig_name = args.rig or "hyperboloid_9pct"
        views = street_views(rig_name)
    else:
        from ..scenes import build_scene, spec_path
        from ..scenes import views as scene_views

        scene = build_scene(spec_path(args.spec), seed=args.seed)
        views = scene_views(scene.spec)
        rig_name = args.rig
    if rig_name is not None:
        cam = load_rig(rig_name, width=w, height=h)
        rig = {"name": rig_name, "spec": load_rig_spec(rig_name)}
    else:
        from ..scenes import scene_rig

        cam = scene_rig(scene.spec, width=w, height=h)
        r = scene.spec.get("rig")
        rig = {"name": r if isinstance(r, str) else "inline", "spec": r if isinstance(r, dict) else None}
    if args.views:
        want = [v.strip() for v in args.views.split(",") if v.strip()]
        have = dict(views)
        missing = [v for v in want if v not in have]
        if missing:
            raise CatadioptricError(f"--views: expected names among {sorted(have)}, got unknown {missing}")
        views = [(v, have[v]) for v in want]
    return scene, views, cam, rig


def run(args) -> int:
    from .dataset import render_dataset

    scene, views, cam, rig = _load(args)
    manifest = render_dataset(scene, views, cam, args.out, renderer=args.renderer, quality=args.quality,
                              workers=args.workers, scheduler=args.scheduler, rig=rig,
                              progress=not args.no_progress, line_images=args.line_images)
    run_ = manifest["run"]
    ag = manifest["label_agreement"]
    print(f"{args.out}: {len(manifest['views'])} views ({len(run_['rendered'])} rendered, "
          f"{len(run_['skipped'])} already done) in {run_['seconds']:.1f} s; renderer labels differ from the "
          f"float64 tracer on {ag['differing_pixels']} of {ag['pixels']} pixels", file=sys.stdout)
    return 0


def _positive_int(s: str) -> int:
    import argparse

    try:
        v = int(s)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {s!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {s!r}")
    return v


def register(sub) -> None:
    p = sub.add_parser("render", help="render a scene spec's views (beauty, exact labels, ground truth) into a "
                                      "dataset folder", description=__doc__.split("\n\n")[0])
    p.add_argument("spec", metavar="SPEC", help=f"scene spec file or name in scenes/ (or {BUILTIN})")
    p.add_argument("--renderer", choices=["mitsuba", "povray"], default="mitsuba",
                   help="mitsuba (default, in-process) or povray (the povray binary)")
    p.add_argument("--out", required=True, metavar="DIR", help="dataset folder (created; reruns resume)")
    p.add_argument("--rig", metavar="NAME_OR_FILE", help="rig name (render/rigs, presets) or rig spec file "
                                                         "(default: the rig the scene spec names)")
    p.add_argument("--quality", default="standard", metavar="PRESET",
                   help="draft | standard | high (render/quality.toml) or a TOML file (default: standard)")
    p.add_argument("--resolution", metavar="NAME|WxH",
                   help="tiny | small | vga | hd (render/resolution.toml) or WIDTHxHEIGHT (default: the rig's)")
    p.add_argument("--seed", type=int, help="scene seed (default: the spec's)")
    p.add_argument("--views", metavar="A,B", help="render only these views (comma-separated names)")
    p.add_argument("--workers", type=_positive_int, default=1, metavar="N",
                   help="render N views in parallel in local processes (default 1)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="run the views on this Dask scheduler instead "
                                                          "(e.g. tcp://127.0.0.1:8786)")
    p.add_argument("--line-images", choices=["core", "sampled"], default="core",
                   help="ground-truth line images from the geometry core's segment_image (default) or from "
                        "our bisection sampler (same curves, faster)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)
