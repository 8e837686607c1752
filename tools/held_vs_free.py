"""The benchmark's exact-model draws split by the scale's choice (`pose.refine_far_or_free`): the
draws where the scene was held far and those where the free fit was kept, their median rotation
errors next to the central baseline's on the same draws, and the common-ground gaps by which the
free fits were kept (docs/relative_pose.md, the benchmark's "What it shows").

    .venv/bin/python tools/held_vs_free.py [validate/relative_pose/report.json]

Reads a benchmark report's draws (default the committed one, every pair of one code version) or
the per-pair result files a benchmark leaves (a ``results`` folder, ``<config>/pNN.json``);
computes nothing again.
"""
from __future__ import annotations

import argparse
import glob
import json
import os

import numpy as np


def _pairs(source: str) -> dict:
    """``{configuration: [pair results]}`` from a report's JSON or a results folder."""
    if os.path.isfile(source):
        with open(source) as f:
            rep = json.load(f)
        out: dict = {}
        for p in rep["pairs"]:
            out.setdefault(p["config"], []).append(p)
        return out
    return {os.path.basename(d): [json.load(open(f)) for f in sorted(glob.glob(os.path.join(d, "p*.json")))]
            for d in sorted(glob.glob(os.path.join(source, "*"))) if os.path.isdir(d)}


def rows(source: str) -> list[dict]:
    """One row per configuration and noise level above 0 with metric draws of the exact model."""
    out = []
    for config, pairs in sorted(_pairs(source).items()):
        draws = [d for p in pairs for d in p["draws"] if "scale_held" in d and "error" not in d
                 and "rotation_error_deg" in d.get("central", {})]
        for z in sorted({d["noise_px"] for d in draws if d["noise_px"] > 0}):
            ds = [d for d in draws if d["noise_px"] == z]
            held = np.array([bool(d["scale_held"]) for d in ds])
            e = np.array([d["rotation_error_deg"] for d in ds])
            c = np.array([d["central"]["rotation_error_deg"] for d in ds])
            gaps = np.array([d["far_gap"] for d in ds])[~held]

            def med(x):
                return float(np.median(x)) if len(x) else None

            out.append({"config": config, "noise_px": z, "draws": len(ds),
                        "free": int((~held).sum()), "exact_held": med(e[held]), "exact_free": med(e[~held]),
                        "central_held": med(c[held]), "central_free": med(c[~held]),
                        "gap_min": float(gaps.min()) if len(gaps) else None,
                        "gap_max": float(gaps.max()) if len(gaps) else None})
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("source", nargs="?", default="validate/relative_pose/report.json",
                    help="a benchmark report.json or a per-pair results folder (default the committed report)")
    a = ap.parse_args(argv)
    if not os.path.exists(a.source):
        ap.error(f"source: expected a benchmark report.json or results folder, got {a.source!r} (not found)")

    def f(x):
        return "-" if x is None else f"{x:.3f}"

    print("| configuration | noise (px) | draws | free kept | exact held | central on held | exact free | "
          "central on free | gaps of the free draws |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows(a.source):
        gap = "-" if r["gap_min"] is None else f"{r['gap_min']:.1f} to {r['gap_max']:.1f}"
        print(f"| {r['config']} | {r['noise_px']:g} | {r['draws']} | {r['free']} | {f(r['exact_held'])} | "
              f"{f(r['central_held'])} | {f(r['exact_free'])} | {f(r['central_free'])} | {gap} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
