"""Run the benchmarks and write bench/results/<name>.json (with commit, versions, machine).

    .venv/bin/python bench/run.py [projection ...] [--quick]
"""
from __future__ import annotations

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(__file__))

from common import metadata, write_json  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("which", nargs="*", default=None, help="benchmarks to run (default: all)")
    ap.add_argument("--quick", action="store_true", help="sizes up to 1e5 only")
    args = ap.parse_args()
    import bench_projection

    benches = {"projection": bench_projection}
    try:
        import bench_vanishing

        benches["vanishing"] = bench_vanishing
    except ImportError:
        pass
    names = args.which or list(benches)
    for name in names:
        print(f"[{name}]", flush=True)
        kw = {"sizes": (1_000, 10_000, 100_000)} if args.quick else {}
        res = benches[name].run(**kw)
        out = os.path.join(HERE, "results", f"{name}.json")
        write_json(out, {"benchmark": name, "meta": metadata(), **res})
        print(f"wrote {os.path.relpath(out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
