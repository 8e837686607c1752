"""The report and the command of ``catadioptric validate peers`` (the measurement itself:
:mod:`catadioptric.validate.peers`): ``report.md`` of one pair and of the benchmark's pairs, and the
subcommand's arguments.
"""
from __future__ import annotations

import sys

import numpy as np

from .._checks import CatadioptricError
from .peers import (PEERS, SPACING_PX, THRESHOLD_FLOOR_PX, THRESHOLD_SIGMAS, evaluate_benchmark_peers, evaluate_peers,
                    methods_of, require_poselib)

__all__ = ["peers_markdown", "benchmark_peers_markdown", "register_peers"]


def _f(x, fmt=".3g"):
    return "-" if x is None else format(x, fmt)


def _mq(v, fmt=".3g"):
    """``median [q1, q3]``."""
    return "-" if v[0] is None else f"{v[0]:{fmt}} [{v[1]:{fmt}}, {v[2]:{fmt}}]"


_NAME = {"central": "central 5-point", "generalized": "generalized 6-point", "label_path": "label path"}


def _method_text(opt: dict, rad_per_px: float | None, loss_px, label_path: bool) -> list[str]:
    deg = "" if rad_per_px is None else f" (the rig's {np.degrees(rad_per_px):.3f} deg per pixel)"
    return ["**Peers**: PoseLib's 5-point solver on the rays' directions (central) and its 6-point generalized "
            "solver on the rays with their origins, each in an MSAC with PoseLib's options (at least "
            f"{opt['min_iterations']} iterations, success probability {opt['success_prob']:g}, dynamic trials x"
            f"{opt['dyn_num_trials_mult']:g}, a local refinement of each new best), threshold max("
            f"{THRESHOLD_FLOOR_PX:g}, {THRESHOLD_SIGMAS:g} x noise) px{deg}, then PoseLib's refinement of the "
            "Sampson error in each ray's tangent plane (Cauchy loss at "
            + ("the threshold" if loss_px is None else f"{loss_px:g} px")
            + ") over the inliers (docs/peers.md). Seconds: from the noisy pixels to the pose (back-projection "
              "included), one process, one thread."
            + (" The label path: `catadioptric validate relative-pose` (exact model, every pixel of each line, the "
               "same noise levels, draws and seeds), its own seconds; its metric translation counted where its "
               "length is observable (its deviation below its length)." if label_path else ""), "",
            "Errors against the ground truth (`x_B = R x_A + t` between the mirror frames). The central peer's "
            "translation is a direction, compared with the direction between the two views' ray centres; the "
            "generalized peer's is metric (`length ratio`: its length over the truth's). The peers are given "
            "which point of each line matches which: more than the label path is given (which line matches "
            "which, every pixel of it).", ""]


def peers_markdown(res: dict, command: str) -> str:
    """The Markdown report of :func:`evaluate_peers`."""
    from .report import md_table

    A, B = res["views"]
    p = res["points"]
    methods = methods_of(res)
    rows = []
    for noise, row in res["summary"].items():
        for m in methods:
            q = row[m]
            if q["skipped"]:
                rows.append([noise, _NAME[m], "skipped: central rig", "", "", "", "", "", "", ""])
                continue
            rows.append([noise, _NAME[m], f"{q['answered']}/{q['draws']}", _f(q["rotation_deg"][0]),
                         _f(q["rotation_max_deg"]), _f(q["translation_direction_deg"][0]), _f(q["translation_m"][0]),
                         _f(q["length_ratio"][0]), _f(q["inliers"][0], ".0f"), _f(q["seconds"][0], ".2f")])
    per_draw = []
    for d in res["draws"]:
        for m in methods:
            r = d.get(m)
            if r is None or "skipped" in r:
                continue
            if "error" in r:
                per_draw.append([d["noise_px"], d["draw"], _NAME[m], "failed: " + r["error"][:80], "", "", "", "", ""])
                continue
            rot = "AMBIGUOUS" if r.get("ambiguous") else _f(r["rotation_error_deg"], ".4g")
            per_draw.append([d["noise_px"], d["draw"], _NAME[m], rot, _f(r["translation_direction_error_deg"], ".3g"),
                             _f(r.get("translation_error_m")), _f(r.get("length_ratio"), ".4g"),
                             "-" if r.get("inliers") is None else f"{r['inliers']}/{r['points']}",
                             _f(r["seconds"], ".3f")])
    fams = ", ".join(f"{k}: {v}" for k, v in p["per_family"].items())
    L = [f"# PoseLib's relative pose beside the label path: views {A} and {B}", "",
         f"Baseline {res['baseline_m']:.2f} m; {'a central' if res['central_rig'] else 'a non-central'} rig; "
         f"PoseLib {res['poselib']}.", "",
         f"**Points**: {p['count']} exact correspondences on the {p['lines']} labelled lines both views see "
         f"(lines of at least {res['min_pixels']} pixels in both, one point every {p['spacing_px']:g} pixels of "
         f"arc where the line shows in both; per family {fams}), Gaussian noise per pixel coordinate, each "
         f"noisy pixel back-projected by the exact camera"
         + (f"; the label path is given every pixel of the same lines ({res['label_path_pixels']} in the two "
            f"views)." if res["label_path"] else "."), "",
         *_method_text(res["ransac"], res["rad_per_px"], res["loss_px"], res["label_path"]),
         "Medians over the draws:", "",
         md_table(["noise (px)", "method", "answered", "rotation (deg)", "worst rotation (deg)",
                   "translation direction (deg)", "translation (m)", "length ratio", "inliers", "seconds"], rows), "",
         *_generalized_notes(res["summary"], res["draws"]),
         "Every draw:", "",
         md_table(["noise (px)", "draw", "method", "rotation (deg)", "translation direction (deg)", "translation (m)",
                   "length ratio", "inliers", "seconds"], per_draw), "",
         f"Reproduce: `{command}`", ""]
    return "\n".join(L)


#: a rotation this far off (degrees) is a failure, not an error of the noise
FAR_DEG = 10.0


def _generalized_notes(summary: dict, draws: list, where: str = "") -> list[str]:
    """Sentences on the generalized peer: draws whose rotation is more than :data:`FAR_DEG` off with
    a translation shorter than a tenth of the truth's (the views' ray centres made to coincide,
    docs/peers.md, "The generalized peer on a near-central rig"), and noise levels where its median
    length is off by more than half (the scale not fixed by the points)."""
    out = []
    for noise, row in summary.items():
        g = row.get("generalized")
        if g is None or not g["answered"]:
            continue
        recs = [d["generalized"] for d in draws if f"{d['noise_px']:g}" == noise and "rotation_error_deg"
                in d.get("generalized", {})]
        far = [r for r in recs if r["rotation_error_deg"] > FAR_DEG]
        short = [r for r in far if r["length_ratio"] is not None and r["length_ratio"] < 0.1]
        if far:
            out.append(f"At {noise} px{where} the generalized peer answers a rotation more than {FAR_DEG:g} degrees "
                       f"off on {len(far)} of {len(recs)} draws"
                       + (f", {len(short)} of them with a translation shorter than a tenth of the truth's: the "
                          "views' ray centres made to coincide, an answer that fits the rays of a near-central rig "
                          "for any rotation (docs/peers.md)." if short else "."))
        lr = g["length_ratio"][0]
        if lr is not None and abs(np.log(lr)) > np.log(1.5) and len(far) < len(recs) / 2:
            out.append(f"At {noise} px{where} the generalized peer's translation length is off by more than half "
                       f"(median ratio {lr:.3g}): the rays' origins differ too little against the noise for the "
                       "points to fix a scale; its direction stands.")
    return [" ".join(out), ""] if out else []


_VERDICT = {"lower": "the label path's lower", "higher": "the peer's lower", "unresolved": "not told apart"}


def _versus_rows(res: dict) -> list[str]:
    """The table of :func:`~catadioptric.validate.peers.versus_peers` per configuration (none without
    the label path)."""
    from .report import md_table

    rows = [[name, noise, _NAME[m], f"{_f(v['difference'])} [{_f(v['lo'])}, {_f(v['hi'])}]", v["pairs"],
             _VERDICT[v["verdict"]]]
            for name, c in res["configs"].items() for noise, row in c.get("versus", {}).items()
            for m, v in row.items() if v["pairs"]]
    if not rows:
        return []
    return ["The label path's median rotation error against each peer's on the same pairs: label path minus peer "
            "(degrees; negative: the label path's is lower) and its 95 % bootstrap interval, resampling the pairs "
            "with all their draws; the medians are told apart when the interval does not hold 0:", "",
            md_table(["configuration", "noise (px)", "peer", "difference (deg) [95 % interval]", "pairs",
                      "median error"], rows), ""]


def benchmark_peers_markdown(res: dict, command: str) -> str:
    """The Markdown report of :func:`evaluate_benchmark_peers`."""
    from .report import md_table

    methods = (*PEERS, "label_path") if res["label_path"] else PEERS
    first = res["pairs"][0]
    rows, notes = [], []
    for name, c in res["configs"].items():
        for noise, row in c["summary"].items():
            for m in methods:
                q = row[m]
                if q["skipped"]:
                    rows.append([name, noise, _NAME[m], "skipped: central rig", "", "", "", ""])
                    continue
                rows.append([name, noise, _NAME[m], f"{q['answered']}/{q['draws']}", _mq(q["rotation_deg"]),
                             _mq(q["translation_direction_deg"]),
                             _mq(q["length_ratio"]) if m == "generalized" else "-", _mq(q["seconds"], ".2f")])
        notes += _generalized_notes(c["summary"], [d for r in res["pairs"] if r["config"] == name
                                                   for d in r["draws"]], f" on {name}")
    versus = _versus_rows(res)
    per_pair = []
    for r in res["pairs"]:
        for noise, row in r["summary"].items():
            per_pair.append([f"{r['config']}:{r['pair']}", r["renderer"], f"{r['baseline_m']:.2f}",
                             r["points"]["count"], noise]
                            + [_f(row[m]["rotation_deg"][0]) + (f" ({_f(row[m]['seconds'][0], '.2f')} s)"
                                                                 if row[m]["seconds"][0] is not None else "")
                               for m in methods])
    L = [f"# PoseLib's relative pose beside the label path: the benchmark `{res['spec']}`", "",
         f"{len(res['pairs'])} view pairs of the benchmark (its spec, seeds and renders at {res['resolution']}; "
         f"pairs {', '.join(res['pairs_chosen'])}); PoseLib {first['poselib']}. Each pair's points: exact "
         f"correspondences on the labelled lines both views see, one every {first['points']['spacing_px']:g} "
         f"pixels of arc (lines of at least {first['min_pixels']} pixels in both; points per pair, median "
         "[quartiles]: " + ", ".join(f"{n} {_mq(c['points'], '.0f')}" for n, c in res["configs"].items())
         + "), the noise drawn with the benchmark's seeds of the pair, each noisy pixel back-projected by the "
           "exact camera.", "",
         *_method_text(first["ransac"], None, first["loss_px"], res["label_path"]),
         "Median [first quartile, third quartile] over every draw of the configuration's pairs:", "",
         md_table(["configuration", "noise (px)", "method", "answered", "rotation (deg)",
                   "translation direction (deg)", "length ratio", "seconds"], rows), "",
         *notes,
         *versus,
         "Per pair, the median rotation error (deg) and seconds over its draws:", "",
         md_table(["pair", "renderer", "baseline (m)", "points", "noise (px)", *[_NAME[m] for m in methods]],
                  per_pair), "",
         f"{res['seconds']:.0f} s on {res['workers']} worker(s) after the renders.", "",
         f"Reproduce: `{command}`", ""]
    return "\n".join(L)


# --------------------------------------------------------------------------- command
def _views(ds, views):
    if views is None:
        if len(ds.names) < 2:
            raise CatadioptricError(f"--views: the dataset has {len(ds.names)} view(s); expected at least two")
        return ds.names[:2]
    views = list(views)
    unknown = [v for v in views if v not in ds.names]
    if unknown:
        raise CatadioptricError(f"--views: expected names among {ds.names}, got unknown {unknown}")
    if views[0] == views[1]:
        raise CatadioptricError(f"--views: expected two different views, got {views[0]!r} twice")
    return views


def _print_summary(summary: dict, prefix: str = "") -> None:
    for noise, row in summary.items():
        for m, q in row.items():
            if q["answered"] == 0:
                continue
            print(f"{prefix}noise {noise} px, {m}: rotation {_f(q['rotation_deg'][0], '.4f')} deg, translation "
                  f"direction {_f(q['translation_direction_deg'][0], '.3f')} deg"
                  + ("" if q["translation_m"][0] is None else f", translation {q['translation_m'][0]:.3f} m")
                  + f", {q['seconds'][0]:.2f} s (medians of {q['answered']})")


def _run(args) -> int:
    import shlex

    from ..cliargs import check_out_dir
    from .report import write_report

    require_poselib()  # a missing extra: one line, nothing written
    command = args.command_line or "catadioptric " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    kw = {"noise_levels": args.noise, "draws": args.draws, "spacing": args.spacing, "min_pixels": args.min_pixels,
          "ransac_options": {} if args.min_iterations is None else {"min_iterations": args.min_iterations},
          "label_path": args.label_path}
    if args.spec is not None or args.only is not None:
        return _run_benchmark(args, kw, command)
    if args.quality or args.workers != 1:
        raise CatadioptricError(f"{'--quality' if args.quality else '--workers'}: only with --spec (the benchmark's "
                                "pairs)")
    from ..dataset import Dataset

    out = check_out_dir(args.out)
    try:
        ds = Dataset(args.data)
    except CatadioptricError as exc:
        raise CatadioptricError(f"--data: {exc}") from None
    views = _views(ds, args.views)
    res = evaluate_peers(ds, views, seed=args.seed, **kw)
    res["command"] = command
    paths = write_report(out, res, peers_markdown(res, command))
    print(f"{res['points']['count']} points on {res['points']['lines']} lines of views {views[0]} and {views[1]}")
    _print_summary(res["summary"])
    print("wrote " + ", ".join(paths))
    return 0


def _run_benchmark(args, kw, command) -> int:
    import os

    from ..cliargs import check_out_dir
    from .benchmark_spec import load_benchmark_spec, select_pairs, with_quality
    from .report import write_report

    if args.views is not None:
        raise CatadioptricError("--views: the benchmark's pairs are named by --only, not --views")
    spec_path = args.spec or os.path.join("validate", "relative_pose.toml")
    if args.spec is None and not os.path.exists(spec_path):
        raise CatadioptricError(f"--spec: no {spec_path} here (run from the repository root or give --spec FILE)")
    try:
        spec = load_benchmark_spec(spec_path)
    except CatadioptricError as exc:
        raise CatadioptricError(f"--spec: {exc}") from None
    if args.quality:
        spec = with_quality(spec, args.quality)
    only = set(select_pairs(spec, args.only)) if args.only is not None else None
    out = check_out_dir(args.out)
    data = check_out_dir(args.data, "--data")
    res = evaluate_benchmark_peers(spec, data, only=only, workers=args.workers, progress=not args.no_progress, **kw)
    res["command"] = command
    paths = write_report(out, res, benchmark_peers_markdown(res, command))
    for name, c in res["configs"].items():
        _print_summary(c["summary"], f"{name}: ")
    print("wrote " + ", ".join(paths))
    return 0


def register_peers(vs) -> None:
    """Add ``validate peers`` to the ``validate`` subparsers ``vs``."""
    from ..cliargs import nonnegative_float, positive_float, positive_int

    p = vs.add_parser("peers", help="PoseLib's point-based relative pose on a view pair, beside the label path",
                      description="PoseLib's 5-point (central, on the rays' directions) and 6-point generalized (on "
                                  "the rays with their origins) relative pose on exact point correspondences "
                                  "sampled on the labelled lines both views see, with the same pixel noise as the "
                                  "label path, on a dataset's view pair or on the relative-pose benchmark's pairs "
                                  "(--spec / --only; docs/peers.md). Needs the extra 'peers': pip install "
                                  "'catadioptric[peers]'.")
    p.add_argument("--data", required=True, metavar="DIR",
                   help="dataset folder written by `catadioptric render`; with --spec or --only, the benchmark's "
                        "working folder (its renders go to DIR/datasets, resuming)")
    p.add_argument("--views", nargs=2, metavar=("A", "B"), help="the two views (default: the first two)")
    p.add_argument("--out", required=True, metavar="DIR", help="report folder (report.json, report.md)")
    p.add_argument("--noise", type=nonnegative_float, nargs="+", default=[2.0], metavar="PX",
                   help="Gaussian pixel noise levels (default 2)")
    p.add_argument("--draws", type=positive_int, default=1,
                   help="noise draws per level above 0 (one at 0 px; default 1)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the noise draws, as the label path's (default 0; the benchmark's pairs: their own)")
    p.add_argument("--spacing", type=positive_float, default=SPACING_PX, metavar="PX",
                   help=f"one point every PX pixels of arc along each line (default {SPACING_PX:g}: 430 points on "
                        "the demo pair)")
    p.add_argument("--min-pixels", type=positive_int, default=30,
                   help="lines with fewer pixels in either view are not used (default 30, as the label path)")
    p.add_argument("--min-iterations", type=positive_int, default=None, metavar="N",
                   help="the RANSAC's minimum number of iterations (default PoseLib's, 1000)")
    p.add_argument("--label-path", action="store_true",
                   help="also the label path (catadioptric validate relative-pose, exact model) on the same pairs, "
                        "noise levels, draws and seeds, side by side")
    p.add_argument("--spec", metavar="FILE",
                   help="the relative-pose benchmark's spec (default validate/relative_pose.toml with --only): its "
                        "pairs, rendered into --data")
    p.add_argument("--only", metavar="PAIRS",
                   help="only these pairs of the spec, comma-separated: CONFIG:PAIR, a configuration or a renderer "
                        "(as `validate benchmark --only`)")
    p.add_argument("--quality", action="append", metavar="[RENDERER=]PRESET",
                   help="render the spec's pairs at this quality preset (repeatable; the labels, all the peers and "
                        "the label path read, are exact at every preset)")
    p.add_argument("--workers", type=positive_int, default=1, help="processes for the spec's pairs (default 1)")
    p.add_argument("--no-progress", action="store_true", help="no progress lines")
    p.set_defaults(func=_run, command_line=None)
