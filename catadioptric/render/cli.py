"""``catadioptric render``: render a scene spec's views into a dataset folder.

    catadioptric render SPEC --renderer mitsuba|povray --out DIR [--rig RIG]
                        [--quality PRESET] [--resolution NAME|WxH] [--seed N] [--views A,B]
                        [--workers N] [--scheduler ADDRESS] [--line-images core|sampled]

SPEC is a scene spec file or the name of a packaged spec (``urban_street``, ...:
``catadioptric.scenes.spec_names()``); the special name ``builtin:test_street`` is the
renderers' own test scene (:mod:`catadioptric.render.testscene`). The rig is ``--rig`` (a rig
name or a rig spec file, as for every ``--rig``) or else the one the scene spec names.
"""
from __future__ import annotations

import sys

__all__ = ["register", "run"]

BUILTIN = "builtin:test_street"


def _load(args):
    """Scene, views, camera and rig description from the command line (errors name the flag)."""
    from .._checks import CatadioptricError
    from ..cliargs import flag_error, parse_resolution, resolve_rig

    w, h = parse_resolution(args.resolution) if args.resolution else (None, None)
    if args.spec == BUILTIN:
        from .testscene import street_scene, street_views

        scene = street_scene(0 if args.seed is None else args.seed)
        rig_name = args.rig or "hyperboloid_9pct"
        views = street_views(rig_name)
    else:
        from ..scenes import build_scene, spec_path
        from ..scenes import views as scene_views

        try:
            scene = build_scene(spec_path(args.spec), seed=args.seed)
        except CatadioptricError as exc:
            raise flag_error("SPEC", exc, "spec") from None
        views = scene_views(scene.spec)
        rig_name = args.rig
    if rig_name is not None:
        cam, rig = resolve_rig(rig_name, width=w, height=h)
    else:
        cam, rig = _scene_rig(scene.spec, w, h)
    if args.views:
        want = [v.strip() for v in args.views.split(",") if v.strip()]
        have = dict(views)
        missing = [v for v in want if v not in have]
        if missing:
            raise CatadioptricError(f"--views: expected names among {sorted(have)}, got unknown {missing}")
        views = [(v, have[v]) for v in want]
    return scene, views, cam, rig


def _scene_rig(spec: dict, w, h):
    """The camera of the rig a scene spec names and its description, with the normalised rig spec
    (``manifest.rig.spec``) whether the spec names it, points to a file or inlines it."""
    from pathlib import Path

    from ..rigspec import load_rig_spec
    from ..scenes import scene_rig

    cam = scene_rig(spec, width=w, height=h)
    r = spec.get("rig")
    if isinstance(r, dict):
        return cam, {"name": r.get("name", "inline"), "spec": r}
    base = Path(spec["source"]).parent if spec.get("source") else None
    return cam, {"name": r, "spec": load_rig_spec(r, base_dir=base)}


def run(args) -> int:
    from .._checks import CatadioptricError
    from ..cliargs import check_out_dir, check_scheduler, flag_error
    from .common import load_quality
    from .dataset import render_dataset
    from .extras import EXTRAS, check_extras

    scene, views, cam, rig = _load(args)
    try:
        load_quality(args.quality)
    except CatadioptricError as exc:
        raise flag_error("--quality", exc, "quality") from None
    try:
        check_extras([e for e in EXTRAS if getattr(args, e)], args.renderer)
    except CatadioptricError as exc:
        raise flag_error("--" + next(e for e in ("beauty16", "hdr") if getattr(args, e)), exc, "extras") from None
    check_out_dir(args.out)
    if args.scheduler is not None:
        check_scheduler(args.scheduler)
    try:
        manifest = render_dataset(scene, views, cam, args.out, renderer=args.renderer, quality=args.quality,
                                  workers=args.workers, scheduler=args.scheduler, rig=rig,
                                  progress=not args.no_progress, line_images=args.line_images,
                                  extras=[e for e in EXTRAS if getattr(args, e)])
    except CatadioptricError as exc:
        if str(exc).startswith("out_dir:"):  # the library's parameter, addressed to its flag
            raise flag_error("--out", exc, "out_dir") from None
        raise
    run_ = manifest["run"]
    ag = manifest["label_agreement"]
    print(f"{args.out}: {len(manifest['views'])} views ({len(run_['rendered'])} rendered, "
          f"{len(run_['skipped'])} already done) in {run_['seconds']:.1f} s; renderer labels differ from the "
          f"float64 tracer on {ag['differing_pixels']} of {ag['pixels']} pixels", file=sys.stdout)
    return 0


def register(sub) -> None:
    from ..cliargs import RIG_HELP, nonnegative_int, positive_int

    p = sub.add_parser("render", help="render a scene spec's views (beauty, exact labels, ground truth) into a "
                                      "dataset folder", description=__doc__.split("\n\n")[0])
    p.add_argument("spec", metavar="SPEC", help=f"scene spec file or the name of a packaged spec (or {BUILTIN})")
    p.add_argument("--renderer", choices=["mitsuba", "povray"], default="mitsuba",
                   help="mitsuba (default, in-process) or povray (the povray binary)")
    p.add_argument("--out", required=True, metavar="DIR", help="dataset folder (created; reruns resume)")
    p.add_argument("--rig", metavar="RIG", help=RIG_HELP + " (default: the rig the scene spec names)")
    p.add_argument("--quality", default="standard", metavar="PRESET",
                   help="draft | standard | high (the packaged quality.toml) or a TOML file (default: standard)")
    p.add_argument("--resolution", metavar="NAME|WxH",
                   help="tiny | small | vga | hd (the packaged resolution.toml) or WIDTHxHEIGHT, at most "
                        "4096x4096 pixels in all (default: the rig's)")
    p.add_argument("--seed", type=nonnegative_int, help="scene seed (default: the spec's)")
    p.add_argument("--views", metavar="A,B", help="render only these views (comma-separated names)")
    p.add_argument("--workers", type=positive_int, default=1, metavar="N",
                   help="render N views in parallel in local processes (default 1)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="run the views on this Dask scheduler instead "
                                                          "(e.g. tcp://127.0.0.1:8786)")
    p.add_argument("--line-images", choices=["core", "sampled"], default="core",
                   help="ground-truth line images from the geometry core's segment_image (default) or from "
                        "our bisection sampler (same curves, faster)")
    p.add_argument("--rays", action="store_true", help="also write each view's depth and per-pixel ray maps "
                                                       "(rays.npz: origin on the mirror and direction, frame M)")
    p.add_argument("--beauty16", action="store_true", help="also write a 16-bit beauty image (beauty16.png; Mitsuba)")
    p.add_argument("--hdr", action="store_true", help="also keep the linear (HDR) beauty (beauty_hdr.npz; Mitsuba)")
    p.add_argument("--mesh", action="store_true", help="also write the scene mesh once (scene.ply, faces labelled)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)
