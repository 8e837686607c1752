"""How precisely the relative-pose benchmark knows its medians: each cell's median rotation error
with a 95 % bootstrap interval, for the exact model and the central baseline, and the Wilcoxon
signed-rank p-value of the two draw by draw (issue 8's aims are medians over 60 draws: 20 pairs x
3 noise draws).

    .venv/bin/python tools/median_ci.py [validate/relative_pose/report.json] [--noise 1,2,3]

The bootstrap resamples *pairs* (with all their draws), not draws: the three noise draws of one
pair share its scene, views and lines, so their errors are correlated and resampling them one by
one would claim more precision than 20 pairs give. Ambiguous or failed draws count as missing.
Reads a benchmark report's JSON (or a results folder, ``<config>/pNN.json``); computes nothing
again.
"""
from __future__ import annotations

import argparse
import glob
import json
import os

import numpy as np
from scipy.stats import wilcoxon


def _pairs(source: str) -> list[dict]:
    if os.path.isfile(source):
        with open(source) as f:
            return json.load(f)["pairs"]
    out = []
    for path in sorted(glob.glob(os.path.join(source, "*", "p*.json"))):
        with open(path) as f:
            out.append(json.load(f))
    return out


def _err(d: dict, model: str):
    rec = d if model == "exact" else d.get(model) or {}
    if rec.get("ambiguous") or rec.get("rotation_error_deg") is None:
        return np.nan
    return float(rec["rotation_error_deg"])


def median_interval(per_pair: list[np.ndarray], rng, n_boot: int = 4000, level: float = 0.95):
    """The median of all draws and its percentile bootstrap interval, resampling pairs."""
    flat = np.concatenate(per_pair)
    meds = np.empty(n_boot)
    for b in range(n_boot):
        pick = rng.integers(0, len(per_pair), len(per_pair))
        meds[b] = np.nanmedian(np.concatenate([per_pair[i] for i in pick]))
    lo, hi = np.percentile(meds, [50 * (1 - level), 50 * (1 + level)])
    return float(np.nanmedian(flat)), float(lo), float(hi)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("source", nargs="?", default="validate/relative_pose/report.json")
    ap.add_argument("--noise", default="1,2,3", help="comma-separated noise levels (px)")
    ap.add_argument("--seed", type=int, default=0, help="the bootstrap's seed")
    args = ap.parse_args()
    pairs = _pairs(args.source)
    rng = np.random.default_rng(args.seed)
    configs = list(dict.fromkeys(p["config"] for p in pairs))
    print("| configuration | noise (px) | draws | exact: median [95 % interval] | central: median [95 % interval] "
          "| Wilcoxon p |")
    print("|---|---|---|---|---|---|")
    for c in configs:
        for z in (float(x) for x in args.noise.split(",")):
            per = {m: [] for m in ("exact", "central")}
            for p in (p for p in pairs if p["config"] == c):
                ds = [d for d in p["draws"] if d["noise_px"] == z]
                for m in per:
                    per[m].append(np.array([_err(d, m) for d in ds]))
            if not any(len(a) for a in per["exact"]):
                continue
            e = np.concatenate(per["exact"])
            k = np.concatenate(per["central"])
            both = np.isfinite(e) & np.isfinite(k)
            p_val = wilcoxon(e[both], k[both]).pvalue if both.sum() > 0 and np.any(e[both] != k[both]) else float("nan")
            cells = [median_interval(per[m], rng) for m in ("exact", "central")]
            txt = [f"{m:.3f} [{lo:.3f}, {hi:.3f}]" for m, lo, hi in cells]
            print(f"| {c} | {z:g} | {int(np.isfinite(e).sum())} | {txt[0]} | {txt[1]} | {p_val:.2g} |")


if __name__ == "__main__":
    main()
