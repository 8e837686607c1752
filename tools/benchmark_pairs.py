"""Some pairs of the benchmark evaluated as ``catadioptric validate benchmark`` evaluates them (the
same per-pair function, result format, fingerprint, code digest and overlay), into a folder of their
own: for a change that can only move some pairs (known beforehand), measured on those pairs without
the whole run, then set beside the whole run (``tools/image_results_compare.py compare``).

    .venv/bin/python tools/benchmark_pairs.py --only ellipsoid:0,sphere:12 --out DIR \\
        [--kind images|labels] [--spec validate/relative_pose.toml] \\
        [--data render/out/relative_pose_benchmark] [--workers 2]

``DIR/<config>/pNN.json`` (and ``pNN.png`` for the image path). Copied into the data folder's
``results_images/`` (or ``results/``), they are read back by the benchmark like its own, since
their fingerprint is the one it computes for this code; the other pairs' files there keep the
digest of the code that made them, and a report names every digest it holds
(``benchmark_report.code_line``).
"""
from __future__ import annotations

import argparse

from catadioptric._checks import CatadioptricError
from catadioptric.validate.benchmark import code_digest, evaluate_benchmark
from catadioptric.validate.benchmark_spec import load_benchmark_spec


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", required=True, metavar="CONFIG:PAIR,...", help="the pairs (e.g. ellipsoid:0,sphere:12)")
    ap.add_argument("--out", required=True, help="folder of the per-pair results")
    ap.add_argument("--kind", choices=("images", "labels"), default="images")
    ap.add_argument("--spec", default="validate/relative_pose.toml")
    ap.add_argument("--data", default="render/out/relative_pose_benchmark")
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args()
    spec = load_benchmark_spec(args.spec)
    wanted = set()
    for item in args.only.split(","):
        name, sep, k = item.partition(":")
        if not sep or not k.isdigit():
            ap.error(f"--only: expected CONFIG:PAIR, got {item!r}")
        wanted.add((name, int(k)))
    try:
        res = evaluate_benchmark(spec, args.data, workers=max(1, args.workers), kind=args.kind, only=wanted,
                                 out=args.out)
    except CatadioptricError as exc:
        ap.error(str(exc))
    print(f"{len(res)} pairs ({args.kind}) in {args.out}, code digest {code_digest()[:8]}")


if __name__ == "__main__":
    main()
