"""Peak memory of line detection on images of growing size (issue 39, item 3: it must grow with the
image, not with chains x centres; docs/detect.md, "Image size").

For each size (square images, ``--sizes``), the packaged scene ``tiny_street`` is rendered at that
size (``catadioptric render ... --quality draft --views A``) and detected in a fresh process with
:func:`catadioptric.detect.detect_lines` and the rig of ``--rig``; the child reports its peak resident
set size (``resource.getrusage``), its size once the package is imported (before the image is read)
and the detection's time. A second child computes only the mirror region
(:func:`catadioptric.detect.region.mirror_region`, the pixel rays of the whole image), the
detection's largest single stage. The slope of the peak against the megapixels is fitted (least
squares) and everything written to ``bench/results/detect-memory.json``.

Run (about 5 minutes with the default sizes on two cores)::

    .venv/bin/python bench/bench_detect_memory.py
    .venv/bin/python bench/bench_detect_memory.py --sizes 500,1000 --rig hyperboloid --out /tmp/dm.json
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from common import metadata, write_json  # noqa: E402

_CHILD = r"""
import json, resource, sys, time
import numpy as np
import catadioptric
from catadioptric.detect import detect_lines
from catadioptric.detect.cli import read_image
from catadioptric.detect.region import mirror_region
from catadioptric.rigspec import load_rig

def rss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0

what, path, rig = sys.argv[1:4]
base = rss_mb()
img = read_image(path)
H, W = img.shape[:2]
cam = load_rig(rig, width=W, height=H)
t = time.perf_counter()
if what == "region":
    mirror_region(cam)
    out = {}
else:
    det = detect_lines(img, cam)
    out = {"lines": len(det), "families": len(det.families), "chains": len(det.chains),
           "stage_seconds": det.seconds}
out.update({"base_rss_mb": base, "peak_rss_mb": rss_mb(), "seconds": time.perf_counter() - t})
print(json.dumps(out))
"""


def _child(what: str, image: str, rig: str) -> dict:
    run = subprocess.run([sys.executable, "-c", _CHILD, what, image, rig], capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"{what} of {image} failed:\n{run.stderr}")
    return json.loads(run.stdout.strip().splitlines()[-1])


def _render(size: int, folder: str) -> str:
    out = os.path.join(folder, f"street_{size}")
    subprocess.run([sys.executable, "-c", "import sys; from catadioptric.cli import main; sys.exit(main(sys.argv[1:]))",
                    "render", "tiny_street", "--resolution", f"{size}x{size}",
                    "--quality", "draft", "--views", "A", "--out", out, "--no-progress"], check=True,
                   capture_output=True)
    return os.path.join(out, "A", "beauty.png")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="500,1000,1500,2000", help="square image sizes, pixels (comma-separated)")
    ap.add_argument("--rig", default="hyperboloid", help="rig name (default hyperboloid)")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "detect-memory.json"), help="JSON written here")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for size in sizes:
            image = _render(size, tmp)
            det = _child("detect", image, args.rig)
            reg = _child("region", image, args.rig)
            row = {"width": size, "height": size, "megapixels": size * size / 1e6, **det,
                   "region_peak_rss_mb": reg["peak_rss_mb"], "region_seconds": reg["seconds"]}
            rows.append(row)
            print(f"{size}x{size}: peak {det['peak_rss_mb']:.0f} MB (imports {det['base_rss_mb']:.0f} MB, the region "
                  f"alone {reg['peak_rss_mb']:.0f} MB), {det['lines']} lines, {det['seconds']:.1f} s", flush=True)
    mp = np.array([r["megapixels"] for r in rows])
    fit = {}
    if len(rows) >= 2:
        for key in ("peak_rss_mb", "region_peak_rss_mb"):
            slope, icpt = np.polyfit(mp, [r[key] for r in rows], 1)
            fit[key] = {"mb_per_megapixel": float(slope), "mb_at_zero": float(icpt)}
    from catadioptric.detect.image import MAX_PIXELS

    write_json(args.out, {"benchmark": "detect-memory", "meta": metadata(), "rig": args.rig, "scene": "tiny_street",
                          "quality": "draft", "max_pixels": MAX_PIXELS, "sizes": rows, "linear_fit": fit})
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
