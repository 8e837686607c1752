"""Why the detector misses true families on the relative-pose benchmark's views: each view's
lines detected from its beauty image (the benchmark's options), scored by its labels
(:func:`catadioptric.detect.evaluate_view`), and each true family no detected family matches
counted by its cause (``families_missed``: lines not detected, lines unassigned, direction off,
blended), for families of two labelled lines and of three or more apart (a family of two lines
per view can only be found with the other view).

With ``--pose``, the same for the image path's answer on each pair (prior ``max_rotation_deg``
60, :func:`catadioptric.validate.image_pairs.evaluate_image_pair`): each family the label path
uses that the answer does not match right, by where it was lost (``families_lost``: a view's
detection cause after the families found in both views at once, matched wrong, not matched).

    .venv/bin/python tools/family_misses.py sphere,hyperboloid --pairs 4 [--pose] [--json OUT]

``--joint-max-log-nfa X`` runs ``--pose`` with another bar for the families found in both views
at once (:func:`catadioptric.detect.joint_families.joint_families`, default -6). ``--significance
CONFIG:PAIR:F1,F2`` prints, for true families F1, F2 of that pair, their lines that no detected
family holds in each view, each line's chi-square against the true direction, and the
significance (log NFA over distinct planes, as the joint vote counts it) of those lines together
under the true rotation, next to what the joint vote finds there.

Needs the benchmark's datasets (render/out/relative_pose_benchmark/datasets; README, "relative
pose benchmark"). One view takes about 6 s.
"""
from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path

from threadpoolctl import threadpool_limits

from catadioptric._io import atomic_write_json
from catadioptric.dataset import Dataset
from catadioptric.detect import detect_lines, evaluate_view

DATA = Path("render/out/relative_pose_benchmark")
CAUSES = ("lines not detected", "lines unassigned", "direction off", "blended")


def view_rows(config: str, pairs: int, data: Path = DATA, min_pixels: int = 30) -> list[dict]:
    """One row per view of the first ``pairs`` pairs of ``config`` (pair k rendered by Mitsuba when
    k is even, POV-Ray when odd, as the benchmark): its true families and the missed ones."""
    rows = []
    for k in range(pairs):
        renderer = "mitsuba" if k % 2 == 0 else "povray"
        ds = Dataset(str(data / "datasets" / f"{config}_{renderer}"))
        for side in "AB":
            v = ds[f"p{k:02d}{side}"]
            with threadpool_limits(1):
                s = evaluate_view(detect_lines(v["beauty"], v["camera"]), v, min_label_pixels=min_pixels)
            rows.append({"config": config, "renderer": renderer, "view": f"p{k:02d}{side}",
                         "families_true": s["families_true"], "families_true_3": s["families_true_3"],
                         "family_recall": s["family_recall"], "families_missed": s["families_missed"]})
            print(f"{config} {rows[-1]['view']}: missed {[(m['family'], m['cause']) for m in s['families_missed']]}",
                  file=sys.stderr, flush=True)
    return rows


def pair_rows(config: str, pairs: int, data: Path = DATA, min_pixels: int = 30) -> list[dict]:
    """One row per pair of the first ``pairs`` of ``config``: the label families, and those the
    image path's answer (prior 60) loses, with where."""
    from catadioptric.validate.image_pairs import evaluate_image_pair

    rows = []
    for k in range(pairs):
        renderer = "mitsuba" if k % 2 == 0 else "povray"
        folder = str(data / "datasets" / f"{config}_{renderer}")
        r = evaluate_image_pair(folder, (f"p{k:02d}A", f"p{k:02d}B"), priors=(60.0,), min_pixels=min_pixels)
        run = r["runs"][0]
        rows.append({"config": config, "renderer": renderer, "pair": k, "families_label": r["families_label"],
                     "error": run.get("error"), "ambiguous": run.get("ambiguous"),
                     "rotation_error_deg": run.get("rotation_error_deg"),
                     "same_families": run.get("same_families"), "families_lost": run.get("families_lost", [])})
        print(f"{config} p{k:02d}: same families {rows[-1]['same_families']}, lost "
              f"{[(x['family'], x['cause']) for x in rows[-1]['families_lost']]}", file=sys.stderr, flush=True)
    return rows


def significance(config: str, pair: int, families: list[int], data: Path = DATA, min_pixels: int = 30) -> None:
    """Print the true ``families`` of one pair as the joint vote would see them (module docstring)."""
    import numpy as np

    from catadioptric.detect.evaluate import _match_lines, visible_curves
    from catadioptric.detect.families import _chi2
    from catadioptric.detect.joint_families import _log_nfa_distinct, joint_families

    renderer = "mitsuba" if pair % 2 == 0 else "povray"
    ds = Dataset(str(data / "datasets" / f"{config}_{renderer}"))
    va, vb = ds[f"p{pair:02d}A"], ds[f"p{pair:02d}B"]
    R = vb["pose"].R @ va["pose"].R.T
    with threadpool_limits(1):
        dets = [detect_lines(v["beauty"], v["camera"]) for v in (va, vb)]
    fam_of = []
    for d, v in zip(dets, (va, vb)):
        vis = visible_curves(v)
        m, _ = _match_lines([np.asarray(u) for u in d.uv], vis, 1.5, 0.5)
        fam_of.append([vis[j]["family"] if j >= 0 else None for j in m])
    free = [[i for i in range(len(d)) if d.family[i] < 0 and len(d.uv[i]) >= min_pixels] for d in dets]
    to_a = (np.eye(3), R)  # normals of A as they are, B's turned into A's frame (R^T n_B)
    print(f"{config} p{pair:02d} ({renderer}): lines in no family (of {min_pixels}+ pixels): A {len(free[0])}, "
          f"B {len(free[1])}")
    true_dir = {int(f["index"]): np.asarray(f["direction_M"], float) for f in va["families"]}
    for f in families:
        s = true_dir[f]
        N, C = [], []
        for side, d, fo, free_v, Rm in zip("AB", dets, fam_of, free, to_a):
            idx = [i for i in free_v if fo[i] == f]
            n = d.normal[idx] @ Rm
            c = np.einsum("ji,njk,kl->nil", Rm, d.normal_cov[idx], Rm)
            x2 = _chi2(n, c, s[None], np.sin(np.radians(0.1)) ** 2)[0] if idx else []
            print(f"  family {f}, view {side}: lines {idx}, chi-square against the true direction "
                  f"{[round(float(x), 1) for x in x2]}")
            N.append(n)
            C.append(c)
        nfa = _log_nfa_distinct(np.concatenate(N), np.concatenate(C), s, len(free[0]) + len(free[1]), 9.0, 0.1)
        print(f"  family {f}: log NFA over its distinct planes {nfa:.2f} (the joint vote asks <= -6)")
    found = joint_families(dets[0], dets[1], R, taken_a=[i for i in range(len(dets[0])) if dets[0].family[i] >= 0],
                           taken_b=[i for i in range(len(dets[1])) if dets[1].family[i] >= 0], min_pixels=min_pixels,
                           known_directions=[fam.direction for fam in dets[0].families])
    print(f"  the joint vote under the true rotation finds {len(found)} families: "
          f"{[([fam_of[0][i] for i in j.lines_a], [fam_of[1][i] for i in j.lines_b]) for j in found]}")


def pair_table(rows: list[dict]) -> str:
    """Markdown: per configuration and renderer, the pairs, those with the same families, the label
    families and the lost ones by cause."""
    groups: dict = {}
    for r in rows:
        groups.setdefault((r["config"], r["renderer"]), []).append(r)
    causes = sorted({x["cause"] for r in rows for x in r["families_lost"]})
    head = ["configuration / renderer", "pairs", "same families", "label families", *causes]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for (c, rend), rs in sorted(groups.items()):
        cnt = Counter(x["cause"] for r in rs for x in r["families_lost"])
        out.append("| " + " | ".join([f"{c} / {rend}", str(len(rs)), str(sum(bool(r["same_families"]) for r in rs)),
                                      str(sum(len(r["families_label"]) for r in rs)),
                                      *[str(cnt[k]) for k in causes]]) + " |")
    return "\n".join(out)


def table(rows: list[dict]) -> str:
    """Markdown: per configuration and renderer, the true families and the missed ones by cause
    (two-line families / three or more)."""
    groups: dict = {}
    for r in rows:
        groups.setdefault((r["config"], r["renderer"]), []).append(r)
    head = ["configuration / renderer", "views", "true families (2 lines / 3+)", *CAUSES]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for (c, rend), rs in sorted(groups.items()):
        n2 = sum(len(set(r["families_true"]) - set(r["families_true_3"])) for r in rs)
        n3 = sum(len(r["families_true_3"]) for r in rs)
        cnt = Counter((m["cause"], m["lines"] >= 3) for r in rs for m in r["families_missed"])
        out.append("| " + " | ".join([f"{c} / {rend}", str(len(rs)), f"{n2} / {n3}",
                                      *[f"{cnt[(k, False)]} / {cnt[(k, True)]}" for k in CAUSES]]) + " |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("configs", help="comma-separated configuration names of validate/relative_pose.toml")
    ap.add_argument("--pairs", type=int, default=4, help="the first N pairs of each configuration (default 4)")
    ap.add_argument("--data", type=Path, default=DATA, help=f"the benchmark's work folder (default {DATA})")
    ap.add_argument("--pose", action="store_true", help="the image path's answer per pair, not each view's detection")
    ap.add_argument("--joint-max-log-nfa", type=float,
                    help="with --pose: this bar for the families found in both views at once (default -6)")
    ap.add_argument("--significance", metavar="CONFIG:PAIR:F1,F2",
                    help="the joint vote's view of these true families of one pair (no table)")
    ap.add_argument("--json", type=Path, help="write the rows here")
    ap.add_argument("--from-json", type=Path, help="print the table of rows written before, detecting nothing")
    a = ap.parse_args(argv)
    if a.significance:
        config, pair, fams = a.significance.split(":")
        significance(config, int(pair), [int(f) for f in fams.split(",")], a.data)
        return 0
    if a.joint_max_log_nfa is not None:
        import functools

        import catadioptric.detect.joint_families as jf

        # the image path looks the function up at each call (catadioptric/twoview.py)
        jf.joint_families = functools.partial(jf.joint_families, max_log_nfa=a.joint_max_log_nfa)
    if a.from_json:
        rows = json.loads(a.from_json.read_text())
    else:
        rows = [r for c in a.configs.split(",") for r in (pair_rows if a.pose else view_rows)(c, a.pairs, a.data)]
        if a.json:
            atomic_write_json(str(a.json), rows)
    print(pair_table(rows) if rows and "families_lost" in rows[0] else table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
