"""``catadioptric validate family-bound``: which of the label path's families a grouping of one
image's lines by direction could find at all, at best (docs/relative_pose.md, "What the images
could give").

    catadioptric validate family-bound --out ROWS.json [--spec validate/relative_pose.toml]
        [--data render/out/relative_pose_benchmark] [--configs sphere,...] [--pairs 20]
    catadioptric validate family-bound --from-json validate/relative_pose/family_identifiability.json

A line's image fixes the plane holding its rays; its direction is only known to lie in that plane.
A line whose plane holds the direction of another family of the scene as well (a horizontal line
near the rig's height lies in a nearly horizontal plane, which holds every horizontal direction)
agrees with both, and no grouping by direction can say which it belongs to. Every labelled line of
the benchmark's views (the exact curve's pixels, as the label path's) has its plane fitted
(:mod:`catadioptric.linefit.planes`, first-order covariance at ``--sigma`` pixels) and tested
against the true direction of every family the view has labelled lines of, as the detector's vote
tests it (chi-square ``(n . s)^2 / (s^T C s + sin(0.1 deg)^2) <= 9``, docs/detect.md, step 8). A
line *identifies* its family when it agrees with it and with no other; a family of the label path
(two lines or more in each view) is *identifiable* when at least ``--lines`` of its lines identify
it in each view.

**Significance.** Any two planes meet along some direction, so the vote also asks that a family's
lines be unlikely to agree by chance (a-contrario, :func:`catadioptric.detect.families.log_nfa`:
``log NFA <= -4`` over the lines still free, three lines it can assign, each agreeing with that
family alone within a band at most 2 degrees wide); the vote of both views at once (``detect.joint_families``) asks ``log NFA <= -6`` over
*distinct* planes and two such lines in each view. Here the vote gets every advantage: the
labelled lines whole, the true directions as its hypotheses, no other edges. ``own``: each family
with only the lines that agree with it free (no vote can do better); ``seq``: the vote's sequence,
every labelled line free at first, the most significant family taken first and the lines that
agree with it taken out, then the joint vote over the lines of no family found in both views. A
pair counts when every label family (or every one of three lines or more in each view) is found
one view at a time or both at once: an upper bound for the image path's "same families".

Writes the rows (one per pair) to ``--out`` (JSON, written atomically) and prints two tables; with
``--from-json`` it prints them from rows written before. Labels and geometry only (no detection):
a few seconds per view. Needs the benchmark's rendered datasets (``catadioptric validate benchmark
... --data DIR`` renders them).

**Through the pose** (``--through-pose``): the image path itself on every pair, its detected lines
grouped by the labels instead of its one-view vote (:func:`catadioptric.detect.evaluate.grouped_by_labels`;
:func:`catadioptric.validate.image_pairs.evaluate_image_pair` with ``grouping="labels"``; the rest of
the path as it is, the families found in both views at once included), each motion prior as the
benchmark runs it: how many pairs then have the same families of three lines or more as the labels
(``same_families_3``): the ceiling of any one-view grouping of the lines the detector finds, with the
matching and the fits as they are. Seconds per pair (``--workers`` share them).
"""
from __future__ import annotations

import json
import os

import numpy as np

from .._checks import CatadioptricError

__all__ = ["VoteBars", "view_lines", "pair_row", "family_bound", "bound_markdown", "grouping_bound",
           "grouping_markdown", "register_family_bound"]


class VoteBars:
    """The detector's bars (docs/detect.md, step 8; ``detect.joint_families``): agreement
    ``chi2_max`` with the angle floor ``floor_deg``, a band of at most ``max_band_deg`` to be
    assigned, ``log NFA`` at most ``one_view`` (one view) and ``joint`` (both views at once)."""

    def __init__(self, *, chi2_max: float = 9.0, floor_deg: float = 0.1, max_band_deg: float = 2.0,
                 one_view: float = -4.0, joint: float = -6.0):
        self.chi2_max, self.floor_deg, self.max_band_deg = chi2_max, floor_deg, max_band_deg
        self.one_view, self.joint = one_view, joint


def view_lines(view, min_pixels: int, sigma: float, bars: VoteBars | None = None,
               systematic_px: float = 0.0) -> list[dict]:
    """Each labelled line of at least ``min_pixels`` pixels of ``view`` (a dataset view): its family,
    the true families it agrees with, its chi-square against its own and the width of its band of
    agreement about each family's direction (``bands``, radians). ``systematic_px``: an error that
    does not average out along a line (the detector's is 0.15 px)."""
    from ..detect import label_curves
    from ..linefit.planes import pixel_rays_with_jacobian, plane_covariance, refine_plane

    bars = bars or VoteBars()
    dirs = {int(f["index"]): np.asarray(f["direction_M"], float) for f in view["families"]}
    lines = [t for t in label_curves(view) if len(t["uv"]) >= min_pixels]
    present = sorted({t["family"] for t in lines})
    if not present:
        return []
    S = np.array([dirs[f] for f in present])
    floor2 = np.sin(np.radians(bars.floor_deg)) ** 2
    out = []
    for t in lines:
        rays = pixel_rays_with_jacobian(view["camera"], t["uv"])
        if rays.ok.sum() < 3:
            continue
        n = refine_plane(rays)
        C = plane_covariance(n, rays, sigma)
        if systematic_px > 0:
            C = C + plane_covariance(n, rays, systematic_px) * (int(rays.ok.sum()) / 2.0)
        var = np.einsum("hi,ij,hj->h", S, C, S) + floor2
        chi2 = (S @ n) ** 2 / var
        out.append({"segment": t["segment"], "family": t["family"], "pixels": len(t["uv"]),
                    "agrees": [f for f, c in zip(present, chi2) if c <= bars.chi2_max],
                    "chi2_own": float(chi2[present.index(t["family"])]),
                    "bands": {f: float(np.sqrt(bars.chi2_max * v)) for f, v in zip(present, var)}})
    return out


def _assignable(lines, f, bars) -> int:
    """Lines of family ``f`` the vote's last step would give it: agreeing with it alone, within a
    band of at most ``max_band_deg``."""
    band = np.radians(bars.max_band_deg)
    return sum(1 for ln in lines if ln["family"] == f and ln["agrees"] == [f] and ln["bands"][f] <= band)


def _one_view(lines, f, free, bars):
    """Family ``f`` in one view as the vote sees it at best: the log NFA of the free lines that agree
    with its direction (whatever their family: the vote cannot tell) among ``free`` lines (at least
    those), and whether it keeps enough lines to assign."""
    from ..detect.families import log_nfa

    vote = [ln for ln in lines if f in ln["agrees"] and ln["free"]]
    eps = np.minimum([ln["bands"][f] for ln in vote], 1.0)
    return log_nfa(eps, max(free, len(vote))), _assignable(lines, f, bars) >= 3


def _vote(lines, label, pool, bars):
    """The label families one view's vote could find by the true directions (``pool``: ``own`` or
    ``seq``, module docstring)."""
    for ln in lines:
        ln["free"] = True
    if pool == "own":
        return [f for f in label if _one_view(lines, f, 0, bars)[0] <= bars.one_view
                and _one_view(lines, f, 0, bars)[1]]
    found, left = [], list(label)
    while left:
        n_free = sum(ln["free"] for ln in lines)
        lg, f = min((_one_view(lines, f, n_free, bars)[0], f) for f in left)
        if lg > bars.one_view:
            break
        left.remove(f)
        if _one_view(lines, f, n_free, bars)[1]:
            found.append(f)
        for ln in lines:
            if f in ln["agrees"]:
                ln["free"] = False
    return found


def _significance(per_view, label, bars) -> dict:
    from ..detect.families import log_nfa

    out = {}
    for pool in ("own", "seq"):
        found = [set(_vote(lines, label, pool, bars)) for lines in per_view]
        one = [f for f in label if all(f in x for x in found)]
        joint = []
        for f in label:
            if f in one:
                continue

            def in_joint(ln):  # the joint vote's lines (seq): those of no family found in both views
                return pool == "own" or not any(g in one for g in ln["agrees"])

            band = {}  # a segment seen in both views counts once: its two planes nearly coincide
            for lines in per_view:
                for ln in lines:
                    if f in ln["agrees"] and in_joint(ln):
                        band[ln["segment"]] = min(band.get(ln["segment"], 1.0), ln["bands"][f])
            free = {ln["segment"] for lines in per_view for ln in lines if pool == "seq" and in_joint(ln)}
            lg = log_nfa(np.minimum(list(band.values()), 1.0), max(len(free), len(band)))
            if lg <= bars.joint and min(_assignable(lines, f, bars) for lines in per_view) >= 2:
                joint.append(f)
        out[f"significant_{pool}"] = one
        out[f"significant_joint_{pool}"] = joint
    return out


def pair_row(views, min_pixels: int, sigma: float, need: int = 2, *, search_pixels: int = 20,
             systematic_px: float = 0.0, bars: VoteBars | None = None) -> dict:
    """One pair (``views``: its two dataset views): its label families (two lines of ``min_pixels``
    or more in each view; ``families_label_3``: three or more), those identifiable in both views
    (``need`` lines identify each), the lines agreeing with several families, and the significance
    to the vote (module docstring). The vote sees every labelled line of ``search_pixels`` or more
    (the detector's shortest line)."""
    bars = bars or VoteBars()
    per_view = [view_lines(v, search_pixels, sigma, bars, systematic_px) for v in views]
    long_ = [[ln for ln in lines if ln["pixels"] >= min_pixels] for lines in per_view]
    count = [{} for _ in views]
    ident = [{} for _ in views]
    for k, lines in enumerate(long_):
        for ln in lines:
            count[k][ln["family"]] = count[k].get(ln["family"], 0) + 1
            if ln["agrees"] == [ln["family"]]:
                ident[k][ln["family"]] = ident[k].get(ln["family"], 0) + 1
    label = sorted(f for f in count[0] if count[0][f] >= 2 and count[1].get(f, 0) >= 2)
    label_3 = [f for f in label if min(count[0][f], count[1][f]) >= 3]
    ok = [f for f in label if all(ident[k].get(f, 0) >= need for k in range(2))]
    return {"families_label": label, "families_label_3": label_3, "identifiable": ok,
            "not_identifiable": {str(f): [ident[k].get(f, 0) for k in range(2)] for f in label if f not in ok},
            "lines": [len(v) for v in long_],
            "lines_agreeing_with_several": [sum(1 for ln in lines if len(ln["agrees"]) > 1) for lines in long_],
            "lines_off_own_family": [sum(1 for ln in lines if ln["family"] not in ln["agrees"]) for lines in long_],
            **_significance(per_view, label, bars)}


def family_bound(spec: dict, data: str, *, configs=None, pairs: int | None = None, sigma: float = 0.5,
                 need: int = 2, systematic_px: float = 0.0, bars: VoteBars | None = None) -> list[dict]:
    """A row per pair (:func:`pair_row`) of the spec's configurations (``configs``: those named,
    default all), its first ``pairs`` pairs (default all), from the rendered datasets in ``data``."""
    rows = []
    for name, p, views in _rendered_pairs(spec, data, configs, pairs):
        rows.append({"config": name, "pair": p.index, "renderer": p.renderer,
                     **pair_row(views, spec["min_pixels"], sigma, need, systematic_px=systematic_px, bars=bars)})
    return rows


def _rendered_pairs(spec: dict, data: str, configs, pairs):
    """``(configuration name, pair, its two dataset views)`` for the spec's configurations named in
    ``configs`` (all when None), their first ``pairs``; a configuration the spec lacks or a pair not
    rendered in ``data`` is an error naming it."""
    from ..dataset import Dataset
    from .benchmark import dataset_folder
    from .benchmark_spec import pairs_of

    names = [c["name"] for c in spec["configs"]]
    unknown = sorted(set(configs or ()) - set(names))
    if unknown:
        raise CatadioptricError(f"--configs: expected names of the spec's configurations ({', '.join(names)}), got "
                                f"{unknown}")
    for c in spec["configs"]:
        if configs and c["name"] not in configs:
            continue
        for p in pairs_of(spec, c)[:pairs]:
            folder = dataset_folder(data, c["name"], p.renderer)
            try:
                ds = Dataset(folder)
                views = [ds[n] for n in p.names]
            except (CatadioptricError, KeyError) as exc:
                raise CatadioptricError(f"--data: pair {p.index} of {c['name']} is not rendered in {folder!r} ({exc}); "
                                        "render the benchmark first (catadioptric validate benchmark --data DIR)") from None
            yield c["name"], p, views


def bound_markdown(rows: list[dict]) -> str:
    """The two tables the command prints: identifiability per configuration, then significance."""
    if not rows:
        raise CatadioptricError("rows: expected at least one pair")
    names = list(dict.fromkeys(r["config"] for r in rows))
    L = ["| configuration | pairs | label families | identifiable in both views | pairs with every label family "
         "identifiable | lines agreeing with 2+ families (share) |", "|---|---|---|---|---|---|"]
    for name in [*names, None]:
        cell = [r for r in rows if name is None or r["config"] == name]
        nl = sum(len(r["families_label"]) for r in cell)
        ni = sum(len(r["identifiable"]) for r in cell)
        npairs = sum(len(r["identifiable"]) == len(r["families_label"]) for r in cell)
        if name is None:
            L.append(f"| all | {len(cell)} | {nl} | {ni} | {npairs} | |")
            continue
        sh = sum(sum(r["lines_agreeing_with_several"]) for r in cell)
        tot = sum(sum(r["lines"]) for r in cell)
        L.append(f"| {name} | {len(cell)} | {nl} | {ni} | {npairs} | {sh} of {tot} ({sh / max(tot, 1):.0%}) |")
    if "significant_own" not in rows[0]:
        return "\n".join(L) + "\n"
    L += ["", "Significance to the vote, at best (own: only the family's lines free; seq: the vote's sequence over "
              "every labelled line); pairs whose every label family / every family of 3+ lines could be found:", "",
          "| configuration | pairs | label families | one view at a time (own / seq) | or both views at once "
          "(own / seq) | pairs, every family (own / seq) | pairs, every family of 3+ lines (own / seq) |",
          "|---|---|---|---|---|---|---|"]

    def every(r, p, fams):
        return set(fams) <= set(r[f"significant_{p}"]) | set(r[f"significant_joint_{p}"])

    for name in [*names, None]:
        cell = [r for r in rows if name is None or r["config"] == name]
        nl = sum(len(r["families_label"]) for r in cell)
        one = [sum(len(r[f"significant_{p}"]) for r in cell) for p in ("own", "seq")]
        both = [sum(len(r[f"significant_{p}"]) + len(r[f"significant_joint_{p}"]) for r in cell) for p in ("own", "seq")]
        pall = [sum(every(r, p, r["families_label"]) for r in cell) for p in ("own", "seq")]
        p3 = [sum(every(r, p, r.get("families_label_3", [])) for r in cell) for p in ("own", "seq")]
        L.append(f"| {name or 'all'} | {len(cell)} | {nl} | {one[0]} / {one[1]} | {both[0]} / {both[1]} | "
                 f"{pall[0]} / {pall[1]} | {p3[0]} / {p3[1]} |")
    return "\n".join(L) + "\n"


def _grouped_row(task) -> dict:
    """One pair through the pose with its lines grouped by the labels (:func:`grouping_bound`)."""
    from .image_pairs import evaluate_image_pair

    (config, index, renderer, names), folder, priors = task
    res = evaluate_image_pair(folder, names, priors=priors, grouping="labels", threads=1)
    L3 = res["families_label_3"]
    runs = []
    for r in res["runs"]:
        if "error" in r:
            runs.append({"max_rotation_deg": r["max_rotation_deg"], "error": r["error"]})
            continue
        runs.append({k: r[k] for k in ("max_rotation_deg", "ambiguous", "rotation_error_deg", "same_families_3",
                                      "families_right")}
                    | {"lost_3": [x["cause"] for x in r["families_lost"] if x["family"] in L3]})
    return {"config": config, "pair": index, "renderer": renderer, "families_label_3": L3, "runs": runs}


def grouping_bound(spec: dict, data: str, *, configs=None, pairs: int | None = None, workers: int = 1,
                   progress: bool = True) -> list[dict]:
    """A row per pair of the spec's configurations (``configs``: those named, default all; their
    first ``pairs``) from the rendered datasets in ``data``: the image path with its detected lines
    grouped by the labels (module docstring, "Through the pose"), for the benchmark's priors (none,
    and the spec's ``images.max_rotation_deg``). Per prior: ``ambiguous``, ``rotation_error_deg``,
    ``same_families_3``, ``families_right`` and ``lost_3`` (where each family of three lines or more
    not matched right was lost, as the benchmark's ``families_lost`` says)."""
    from .benchmark import dataset_folder

    priors = (None, *spec["images"]["max_rotation_deg"])
    tasks = [((name, p.index, p.renderer, list(p.names)), dataset_folder(data, name, p.renderer), priors)
             for name, p, _ in _rendered_pairs(spec, data, configs, pairs)]
    bar = None
    if progress and tasks:
        import sys

        from tqdm import tqdm

        bar = tqdm(total=len(tasks), unit="pair", desc="through the pose", file=sys.stderr, dynamic_ncols=True)
    rows = []
    try:
        if workers <= 1 or len(tasks) <= 1:
            results = map(_grouped_row, tasks)
        else:
            from .._pool import imap_spawn

            results = imap_spawn(_grouped_row, tasks, workers)
        for row in results:
            rows.append(row)
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    order = {(c, i): k for k, (c, i) in enumerate((t[0][0], t[0][1]) for t in tasks)}
    return sorted(rows, key=lambda r: order[(r["config"], r["pair"])])


def grouping_markdown(rows: list[dict]) -> str:
    """The table ``--through-pose`` prints: per configuration and prior, the pairs answered and
    those with the same families of three lines or more as the labels."""
    if not rows:
        raise CatadioptricError("rows: expected at least one pair")
    names = list(dict.fromkeys(r["config"] for r in rows))
    priors = [run["max_rotation_deg"] for run in rows[0]["runs"]]
    head = " | ".join(f"{'no prior' if p is None else f'prior {p:g}'}: answered / same families of 3+"
                      for p in priors)
    L = ["The image path with its detected lines grouped by the labels (the grouping's ceiling):", "",
         f"| configuration | pairs | {head} |", "|---|---|" + "---|" * len(priors)]
    for name in [*names, None]:
        cell = [r for r in rows if name is None or r["config"] == name]
        cols = []
        for k in range(len(priors)):
            runs = [r["runs"][k] for r in cell if "error" not in r["runs"][k]]
            cols.append(f"{sum(not x['ambiguous'] for x in runs)} / {sum(bool(x['same_families_3']) for x in runs)}")
        L.append(f"| {name or 'all'} | {len(cell)} | " + " | ".join(cols) + " |")
    return "\n".join(L) + "\n"


def _markdown(rows) -> str:
    return grouping_markdown(rows) if rows and "runs" in rows[0] else bound_markdown(rows)


def _run(args) -> int:
    from .._io import atomic_write_json
    from ..cliargs import check_out_dir
    from .benchmark_spec import load_benchmark_spec

    if args.from_json:
        try:
            with open(args.from_json) as f:
                rows = json.load(f)
        except (OSError, ValueError) as exc:
            raise CatadioptricError(f"--from-json: {args.from_json!r} is not a readable JSON file ({exc})") from None
        if not isinstance(rows, list) or not rows or not all(
                isinstance(r, dict) and ("families_label" in r or "runs" in r) for r in rows):
            raise CatadioptricError(f"--from-json: expected the rows family-bound --out writes, got {args.from_json!r}")
        print(_markdown(rows), end="")
        return 0
    if not args.out:
        raise CatadioptricError("--out: expected a file for the rows (or --from-json FILE to print written ones)")
    check_out_dir(os.path.dirname(os.path.abspath(args.out)), "--out")
    try:
        spec = load_benchmark_spec(args.spec or os.path.join("validate", "relative_pose.toml"))
    except CatadioptricError as exc:
        raise CatadioptricError(f"--spec: {exc}") from None
    configs = args.configs.split(",") if args.configs else None
    if args.through_pose:
        rows = grouping_bound(spec, args.data, configs=configs, pairs=args.pairs, workers=args.workers,
                              progress=not args.no_progress)
    else:
        bars = VoteBars(one_view=args.max_log_nfa, joint=args.joint_max_log_nfa)
        rows = family_bound(spec, args.data, configs=configs, pairs=args.pairs, sigma=args.sigma, need=args.lines,
                            systematic_px=args.systematic, bars=bars)
    atomic_write_json(args.out, rows)
    print(_markdown(rows), end="")
    print(f"wrote {args.out}")
    return 0


def register_family_bound(vs) -> None:
    """Add ``validate family-bound`` to the ``validate`` subparsers ``vs``."""
    from ..cliargs import nonnegative_float, positive_float, positive_int

    p = vs.add_parser("family-bound", help="which label families a grouping of one image's lines by direction "
                                           "could find at best",
                      description="For every pair of the benchmark, the label path's families that the detector's "
                                  "vote could find from the labelled lines' planes and the true directions (an "
                                  "upper bound for the image path's 'same families'; docs/relative_pose.md, \"What "
                                  "the images could give\"); with --through-pose, the image path itself with its "
                                  "detected lines grouped by the labels. Needs the benchmark's rendered datasets.")
    p.add_argument("--out", metavar="FILE", help="write the rows (one per pair, JSON) here")
    p.add_argument("--from-json", metavar="FILE", help="print the tables from rows written before (computes nothing)")
    p.add_argument("--spec", metavar="FILE", help="benchmark spec (default validate/relative_pose.toml)")
    p.add_argument("--data", default=os.path.join("render", "out", "relative_pose_benchmark"), metavar="DIR",
                   help="the benchmark's working folder (default render/out/relative_pose_benchmark)")
    p.add_argument("--configs", metavar="NAMES", help="comma-separated configurations (default all)")
    p.add_argument("--pairs", type=positive_int, metavar="N", help="the first N pairs of each (default all)")
    p.add_argument("--sigma", type=positive_float, default=0.5, metavar="PX",
                   help="pixel noise of each line's plane fit (default 0.5)")
    p.add_argument("--lines", type=positive_int, default=2, help="lines that must identify a family in each view (2)")
    p.add_argument("--max-log-nfa", type=float, default=-4.0, help="the one-view vote's bar (the detector's: -4)")
    p.add_argument("--joint-max-log-nfa", type=float, default=-6.0, help="the joint vote's bar (the detector's: -6)")
    p.add_argument("--systematic", type=nonnegative_float, default=0.0, metavar="PX",
                   help="pixel error that does not average out along a line (the detector's: 0.15; default 0)")
    p.add_argument("--through-pose", action="store_true",
                   help="run the image path on every pair with its detected lines grouped by the labels: the "
                        "ceiling of any grouping of them (seconds per pair)")
    p.add_argument("--workers", type=positive_int, default=1, help="processes for --through-pose (default 1)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_run)
