"""``catadioptric validate``: run an experiment and write its report (JSON + Markdown + PNG).

    catadioptric validate relative-pose DATASET --views A B --out DIR [--noise PX ...] [--draws N] ...
    catadioptric validate benchmark [--spec FILE] [--quick] --out DIR [--data DIR] [--workers N] [--images | --images-only]
        [--only PAIRS] [--quality [RENDERER=]PRESET] [--report-only]
    catadioptric validate noise-sweep --out DIR [--trials N] [--seed N]
    catadioptric validate real --data DIR --out DIR [--max-rotation DEG]
    catadioptric validate restore REPORT [--data DIR]
    catadioptric validate compare BASE NEW [--prior DEG|none]
    catadioptric validate image-runs RESULTS [RESULTS ...]
    catadioptric validate family-bound --out FILE [--spec FILE] [--data DIR] | --from-json FILE
    catadioptric validate pixel-residuals DATASET VIEW [VIEW ...]

``relative-pose`` exits with code 3 when a draw's answer is ambiguous (its report lists every
candidate), 2 on bad input, 0 otherwise.
"""
from __future__ import annotations

import os
import shlex
import sys

from ..cliargs import check_out_dir, nonnegative_float, positive_int

AMBIGUOUS_EXIT = 3
DEFAULT_SPEC = os.path.join("validate", "relative_pose.toml")


def _command(args) -> str:
    return "catadioptric " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if args.command_line is None \
        else args.command_line


def _relative_pose(args) -> int:
    from .._checks import CatadioptricError
    from .._extras import require
    from ..dataset import Dataset
    from . import relative_pose as rp
    from .report import write_report

    out = check_out_dir(args.out)
    try:
        ds = Dataset(args.dataset)
    except CatadioptricError as exc:
        raise CatadioptricError(f"DATASET: {exc}") from None
    if args.views is None:
        if len(ds.names) < 2:
            raise CatadioptricError(f"--views: the dataset has {len(ds.names)} view(s); expected at least two")
        views = ds.names[:2]
    else:
        views = args.views
        if views[0] == views[1]:
            raise CatadioptricError(f"--views: expected two different views, got {views[0]!r} twice")
    if args.max_pixels is not None and args.min_pixels > args.max_pixels:
        raise CatadioptricError(f"--min-pixels: expected at most --max-pixels ({args.max_pixels}), got "
                                f"{args.min_pixels}")
    res = rp.evaluate_pair(ds, views, noise_levels=args.noise, draws=args.draws, seed=args.seed,
                           pixels=args.pixels, min_pixels=args.min_pixels, max_pixels=args.max_pixels, ends=args.ends,
                           central=not args.no_central)
    figures = {}
    try:
        require("matplotlib", "the pair figure")
        figures["lines"] = rp.pair_figure(res, ds)
    except ImportError:
        pass
    paths = write_report(out, res, rp.pair_markdown(res, _command(args)), figures)
    amb = 0
    for d in res["draws"]:
        c = d.get("central", {})
        if "error" in d:
            print(f"noise {d['noise_px']:g} px, draw {d['draw']}: failed: {d['error']}")
            continue
        amb += int(d["ambiguous"])
        state = "AMBIGUOUS (every candidate is in the report)" if d["ambiguous"] else \
            f"rotation {d['rotation_error_deg']:.4f} deg (Frobenius {d['frobenius_error']:.4f})"
        tr = ""
        if d["translation_error_m"] is not None:
            tr = (f", translation {d['translation_error_m']:.3f} m" if rp.length_observable(d) else
                  f", translation length {rp.translation_text(d)}")
        if d["translation_direction_error_deg"] is not None:
            tr += f", direction {d['translation_direction_error_deg']:.2f} deg"
        cen = ""
        if c and "error" not in c:
            cen = f" | central: rotation {c['rotation_error_deg']:.4f} deg" + (" (ambiguous)" if c["ambiguous"] else "")
        print(f"noise {d['noise_px']:g} px, draw {d['draw']}: {state}{tr}{cen}")
    print("wrote " + ", ".join(paths))
    if amb:
        print(f"{amb} of {len(res['draws'])} draws are ambiguous: no answer is given for them", file=sys.stderr)
        return AMBIGUOUS_EXIT
    return 0


def _images_only(spec, data, out, args) -> int:
    from .benchmark import run_images_only

    def f(x, unit=""):
        return "-" if x is None else f"{x:.3f}{unit}"

    agg = run_images_only(spec, data, out=out, workers=args.workers, progress=not args.no_progress,
                          command=_command(args))
    for key, e in agg.items():
        if not key.endswith("/all"):
            continue
        for prior, q in e["priors"].items():
            print(f"{key[:-4]:22s} prior {prior:>4s}: {e['pairs']} pairs, ambiguous {q['ambiguous']}, failed "
                  f"{q['failed']}, wrong and unflagged {q['over_10deg_unflagged']}, same families "
                  f"{f(q['same_families'])}, matched families all right {f(q['families_right'])}, rotation "
                  f"{f(q['rotation_deg']['median'], ' deg')}")
    print(f"per-pair results in {os.path.join(data, 'results_images')}; wrote {os.path.join(out, 'images.md')} (the "
          "label path beside it: run without --images-only)")
    return 0


def _subset(spec, data, only, args) -> int:
    """``--only``: the pairs named, rendered and evaluated (resuming) into ``data``'s per-pair
    results; a summary printed, no report written (a report is of every pair)."""
    from .benchmark import evaluate_benchmark, render_benchmark, results_folder
    from .benchmark_report import aggregate, aggregate_images

    render_benchmark(spec, data, workers=args.workers, progress=not args.no_progress, only=set(only))
    kinds = ["images"] if args.images_only else ["labels", "images"] if args.images else ["labels"]
    for kind in kinds:
        res = evaluate_benchmark(spec, data, workers=args.workers, progress=not args.no_progress, kind=kind,
                                 only=only)
        if kind == "labels":
            for name, a in aggregate(spec, res).items():
                for noise, e in a["noise"].items() if a["pairs"] else ():
                    q = e["exact"]["rotation_deg"]["median"]
                    print(f"{name:22s} {float(noise):4.1f} px: {a['pairs']} pairs, rotation exact "
                          f"{'-' if q is None else f'{q:.3f}'} deg")
        else:
            for key, e in aggregate_images(spec, [], res).items():
                if key.endswith("/all"):
                    q = e["priors"][f"{spec['images']['max_rotation_deg'][-1]:g}"]
                    print(f"{key[:-4]:22s} images: {e['pairs']} pairs, ambiguous {q['ambiguous']}, failed {q['failed']}")
        print(f"per-pair results of {len(res)} pairs in {results_folder(data, kind)}")
    print("no report written for a subset of the pairs: compare the results with `catadioptric validate compare`")
    return 0


def _benchmark(args) -> int:
    from .._checks import CatadioptricError
    from .benchmark import rewrite_report, run_benchmark
    from .benchmark_spec import load_benchmark_spec, quick_spec, select_pairs, with_quality

    spec_path = args.spec or DEFAULT_SPEC
    if args.spec is None and not os.path.exists(spec_path):
        raise CatadioptricError(f"--spec: no {DEFAULT_SPEC} here (run from the repository root or give --spec FILE)")
    try:
        spec = load_benchmark_spec(spec_path)
    except CatadioptricError as exc:
        raise CatadioptricError(f"--spec: {exc}") from None
    if args.quick:
        spec = quick_spec(spec)
    if args.quality:
        spec = with_quality(spec, args.quality)
    only = select_pairs(spec, args.only) if args.only is not None else None
    if only is not None and args.report_only:
        raise CatadioptricError("--only: a report is of every pair; --report-only writes one, so not both")
    out = check_out_dir(args.out)
    data = check_out_dir(args.data, "--data") if args.data else out
    if args.report_only:
        cmd = " ".join(w for w in _command(args).split(" ") if w != "--report-only")
        digests = rewrite_report(spec, data, out, images=args.images, images_only=args.images_only, command=cmd)
        for kind, d in digests:
            print(f"{kind}: per-pair results of code digest " + ", ".join(f"{k} ({n} pairs)" for k, n in d.items()))
        print(f"wrote {os.path.join(out, 'images.md' if args.images_only else 'report.md')} (nothing computed)")
        return 0
    if only is not None:
        return _subset(spec, data, only, args)
    if args.images_only:
        return _images_only(spec, data, out, args)
    agg = run_benchmark(spec, out, data=data, workers=args.workers, progress=not args.no_progress,
                        command=_command(args), images=args.images)
    for name, a in agg.items():
        for noise, e in a["noise"].items():
            ex, ce = e["exact"], e["central"]
            med = lambda q: "-" if q["median"] is None else f"{q['median']:.3f}"
            print(f"{name:22s} {float(noise):4.1f} px: rotation exact {med(ex['rotation_deg'])} deg, central "
                  f"{med(ce['rotation_deg'])} deg; ambiguous {ex['ambiguous']}/{ex['draws']}, failed {ex['failed']}, "
                  f"wrong and unflagged {ex['over_10deg_unflagged']}")
    print(f"wrote {os.path.join(out, 'report.md')}")
    return 0


def _noise_sweep(args) -> int:
    from . import noise_sweep as ns
    from .report import write_report

    out = check_out_dir(args.out)
    res = ns.run(trials=args.trials, seed=args.seed)
    cmd = f"catadioptric validate noise-sweep --out {args.out} --trials {args.trials} --seed {args.seed}"
    paths = write_report(out, res, ns.markdown(res, cmd), {"noise_sweep": ns.figure(res)})
    for name, r in res["rigs"].items():
        print(f"  {name:22s} direction error at 10 px: {r['direction_error_deg'][-1]:.3f} deg; rotation |dR|_F at "
              f"10 px: {r['rotation_error_frobenius'][-1]:.4f}")
    print("wrote " + ", ".join(paths))
    return 0


def register(sub) -> None:
    p = sub.add_parser("validate", help="experiments on rendered datasets (relative pose, benchmark, noise sweeps)")
    vs = p.add_subparsers(dest="experiment", required=True)
    r = vs.add_parser("relative-pose", help="relative pose (rotation, metric translation) of two views of a dataset",
                      description="Relative pose of two views from the pixels of their labelled lines, by the exact "
                                  "model and by the fair central baseline, against the ground truth.")
    r.add_argument("dataset", metavar="DATASET", help="dataset folder written by `catadioptric render`")
    r.add_argument("--views", nargs=2, metavar=("A", "B"), help="the two views (default: the first two)")
    r.add_argument("--out", required=True, metavar="DIR", help="report folder")
    r.add_argument("--noise", type=nonnegative_float, nargs="+", default=[2.0], metavar="PX",
                   help="Gaussian pixel noise levels added to the line pixels (default 2, as the paper)")
    r.add_argument("--draws", type=positive_int, default=1,
                   help="noise draws per level above 0 (one at 0 px, whose pixels every draw shares; default 1)")
    r.add_argument("--seed", type=int, default=0, help="seed of the noise draws (default 0)")
    r.add_argument("--pixels", choices=["curve", "ridge"], default="curve",
                   help="line pixels: the exact curve where the label shows the line (default) or the integer "
                        "ridge of the label band")
    r.add_argument("--min-pixels", type=positive_int, default=30,
                   help="lines with fewer pixels are not used (default 30)")
    r.add_argument("--max-pixels", type=positive_int, default=None,
                   help="at most this many pixels per line and view, evenly spread (default: every pixel, as "
                        "the benchmark)")
    r.add_argument("--ends", choices=["unknown", "given"], default="unknown",
                   help="which end of each family is which: searched (default) or given (matched vanishing "
                        "points from the ground truth, the paper's assumption)")
    r.add_argument("--no-central", action="store_true", help="skip the central baseline")
    r.set_defaults(func=_relative_pose, command_line=None)
    b = vs.add_parser("benchmark", help="the relative-pose benchmark: render the spec's view pairs, evaluate, report")
    b.add_argument("--spec", metavar="FILE", help=f"benchmark spec (default {DEFAULT_SPEC})")
    b.add_argument("--quick", action="store_true", help="the spec's [quick] size (what CI runs)")
    b.add_argument("--out", required=True, metavar="DIR", help="report folder")
    b.add_argument("--data", metavar="DIR", help="working folder for the rendered datasets and per-pair results "
                                                 "(default: --out)")
    b.add_argument("--workers", type=positive_int, default=1, help="processes (default 1)")
    b.add_argument("--images", action="store_true",
                   help="also the image-only path on every pair (catadioptric relative-pose; no labels)")
    b.add_argument("--images-only", action="store_true",
                   help="the image-only path alone: its per-pair results, a summary printed and its own report "
                        "(images.md in --out; report.md is not touched)")
    b.add_argument("--only", metavar="PAIRS",
                   help="only these pairs, comma-separated: CONFIG:PAIR, a configuration or a renderer (e.g. "
                        "sphere:0,ellipsoid:3 or mitsuba); rendered and evaluated into --data, a summary printed, "
                        "no report written (compare two runs' results with `catadioptric validate compare`)")
    b.add_argument("--quality", action="append", metavar="[RENDERER=]PRESET",
                   help="render at this quality preset instead of the spec's (repeatable; e.g. mitsuba=standard): "
                        "with another --data, a copy of the benchmark's views whose image path can be compared "
                        "with the benchmark's")
    b.add_argument("--report-only", action="store_true",
                   help="write the report again from the per-pair results already in --data, whatever code made "
                        "them (the report names each digest), computing nothing; keeps the command and timing of "
                        "the report already in --out")
    b.add_argument("--no-progress", action="store_true", help="no progress bars")
    b.set_defaults(func=_benchmark, command_line=None)
    n = vs.add_parser("noise-sweep", help="synthetic noise sweeps of VPs, directions and rotation (paper Figs. 5-6)")
    n.add_argument("--out", required=True, metavar="DIR", help="report folder")
    n.add_argument("--trials", type=positive_int, default=100, help="trials per noise level (default 100)")
    n.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    n.set_defaults(func=_noise_sweep)
    from .compare import register_compare
    from .family_bound import register_family_bound
    from .image_runs import register_image_runs
    from .pixel_residuals import register_pixel_residuals
    from .real import register_real
    from .restore import register_restore

    register_real(vs)
    register_restore(vs)
    register_compare(vs)
    register_image_runs(vs)
    register_family_bound(vs)
    register_pixel_residuals(vs)
    from .peers_report import register_peers
    register_peers(vs)
