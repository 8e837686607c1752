"""Where the two-view refinement's start puts each line, and what the refinement keeps of its
pixels, on one draw of the relative-pose benchmark (issue 8; docs/relative_pose.md, "Every line in
front of both views").

    .venv/bin/python tools/start_lines.py hyperboloid 14 2 0

Arguments: configuration, pair, noise (px), draw (the benchmark's seeds). Prints the answer's
rotation error, the start's length and, per line of the answer's refinement, the median distance
(px) of its pixels to its image at the start in A and B (inf: no image, e.g. the line behind that
view) and how many of its pixels the free and the far fit keep. Run it on another library with
``PYTHONPATH=WORKTREE``. Needs the benchmark's datasets (render/out/relative_pose_benchmark).
"""
from __future__ import annotations

import argparse
from types import SimpleNamespace

import numpy as np

import catadioptric.pose.scale as scale_mod
from catadioptric.dataset import Dataset
from catadioptric.pose import ViewLines, relative_pose, rotation_angle_deg
from catadioptric.validate.benchmark import dataset_folder
from catadioptric.validate.benchmark_spec import load_benchmark_spec, pairs_of
from catadioptric.validate.observations import line_pixels
from catadioptric.validate.relative_pose import _draw_pixels


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config")
    ap.add_argument("pair", type=int)
    ap.add_argument("noise", type=float)
    ap.add_argument("draw", type=int)
    ap.add_argument("--spec", default="validate/relative_pose.toml")
    ap.add_argument("--data", default="render/out/relative_pose_benchmark")
    args = ap.parse_args()
    spec = load_benchmark_spec(args.spec)
    cfg = next((c for c in spec["configs"] if c["name"] == args.config), None)
    if cfg is None:
        ap.error(f"config: expected one of {[c['name'] for c in spec['configs']]}, got {args.config!r}")
    pair = pairs_of(spec, cfg)[args.pair]
    ds = Dataset(str(dataset_folder(args.data, args.config, pair.renderer)))
    va, vb = ds[pair.names[0]], ds[pair.names[1]]
    R_gt = vb["pose"].R @ va["pose"].R.T
    base = [line_pixels(v, pixels=spec["pixels"], min_pixels=spec["min_pixels"]) for v in (va, vb)]
    rng = np.random.default_rng([spec["seed"], pair.index, int(round(args.noise * 1000)), args.draw])
    uvs = [_draw_pixels(b, rng, args.noise, spec["max_pixels"]) for b in base]
    views = [ViewLines(v["camera"], u, b.family, b.segment) for v, u, b in zip((va, vb), uvs, base)]
    runs = []
    real = scale_mod.far_and_free_fits

    def spy(*a, **kw):
        free, held = real(*a, **kw)
        runs.append((free, held, a))
        return free, held

    scale_mod.far_and_free_fits = spy
    res = relative_pose(views[0], views[1], seed=args.draw, max_pixels=spec["max_pixels"])
    err = lambda R: rotation_angle_deg(R @ R_gt.T)
    print(f"answer {err(res.R):.3f} deg; true baseline {np.linalg.norm(vb['pose'].t - R_gt @ va['pose'].t):.2f} m")
    free, held, a = min(runs, key=lambda r: rotation_angle_deg(r[1].R @ res.R.T))
    cam_a, cam_b, R0, t0, dirs0, points0, fam, uv_a, own_a, uv_b, own_b = a
    print(f"start: rotation {err(R0):.3f} deg, length {np.linalg.norm(t0):.2f} m; free fit {err(free.R):.3f} deg, "
          f"far fit {err(held.R):.3f} deg; pixels kept free {free.n_pixels.tolist()}, far {held.n_pixels.tolist()} "
          f"of {[len(uv_a), len(uv_b)]}")
    start = SimpleNamespace(R=R0, t=np.asarray(t0), directions=dirs0, points=points0, line_family=fam)
    d0 = scale_mod.pixel_distances(start, cam_a, cam_b, uv_a, own_a, uv_b, own_b)
    keep = {n: np.concatenate([f.inliers_a, f.inliers_b]) for n, f in (("free", free), ("far", held))}
    own = np.concatenate([own_a, own_b])
    in_a = np.arange(len(own)) < len(uv_a)
    print("line | family | start median px A / B | pixels A / B | kept free A / B | kept far A / B")
    for line in range(len(points0)):
        m = own == line
        med = [np.median(d0[m & v]) if np.any(m & v) else float("nan") for v in (in_a, ~in_a)]
        n = [int(np.sum(m & v)) for v in (in_a, ~in_a)]
        kf = [int(np.sum(m & v & keep["free"])) for v in (in_a, ~in_a)]
        kh = [int(np.sum(m & v & keep["far"])) for v in (in_a, ~in_a)]
        print(f"{line} | {fam[line]} | {med[0]:.2f} / {med[1]:.2f} | {n[0]} / {n[1]} | {kf[0]} / {kf[1]} | {kh[0]} / {kh[1]}")


if __name__ == "__main__":
    main()
