"""A geometry demo: a non-central hyperbolic rig, back-projection, exact forward projection
and the images of a few 3-D lines, as a printed table and a PNG."""
from __future__ import annotations

import os
import time

import numpy as np



def run_geometry_demo(out_dir: str, rig: str = "hyperboloid_9pct") -> dict:
    """Back-project and forward-project a pixel grid of ``rig`` (a rig name or a rig spec file, as
    every ``--rig``), print the figures and draw the exact images of a box's edges into
    ``out_dir/line_images.png`` (needs the extra ``plot``)."""
    from ._extras import require
    from .cliargs import resolve_rig

    cam, _ = resolve_rig(rig, flag="rig")
    require("matplotlib", "the geometry demo (its figure)")
    os.makedirs(out_dir, exist_ok=True)
    m = cam.mirror
    print(f"rig {rig}: {m.kind} A={m.A:.4g} B={m.B:.4g} C={m.C:.4g} z in [{m.z_min}, {m.z_max}], "
          f"camera at {np.round(cam.center, 4).tolist()}, central={cam.is_central}")
    uv = cam.pinhole.pixel_grid(4).reshape(-1, 2)
    t0 = time.perf_counter()
    rays = cam.backproject(uv)
    t1 = time.perf_counter()
    ok = rays.valid
    rng = np.random.default_rng(0)
    P = rays.origins[ok] + rng.uniform(0.5, 20.0, (ok.sum(), 1)) * rays.directions[ok]
    t2 = time.perf_counter()
    pr = cam.project(P)
    t3 = time.perf_counter()
    err = np.where(pr.valid, np.linalg.norm(pr.uv - uv[ok][:, None], axis=-1), np.inf).min(axis=1)
    rows = [
        ("pixels back-projected", f"{len(uv)}", f"{len(uv) / (t1 - t0):,.0f} px/s"),
        ("pixels seeing the world", f"{ok.sum()}", f"{ok.mean():.1%} of the image"),
        ("points forward-projected", f"{len(P)}", f"{len(P) / (t3 - t2):,.0f} points/s"),
        ("round-trip error max", f"{err.max():.2e} px", f"median {np.median(err):.2e} px"),
        ("points seen more than once", f"{np.sum(pr.valid.sum(1) > 1)}", ""),
    ]
    w = max(len(r[0]) for r in rows)
    for a, b, c in rows:
        print(f"  {a:<{w}}  {b:>14}  {c}")
    # images of 3-D lines: edges of a box around the rig (a room 6 m x 6 m x 3 m)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    corners = np.array([[x, y, z] for x in (-3, 3) for y in (-3, 3) for z in (-1.5, 1.5)], float)
    edges = [(i, j) for i in range(8) for j in range(i + 1, 8) if np.sum(corners[i] != corners[j]) == 1]
    fig, ax = plt.subplots(figsize=(6.4, 4.8), dpi=100)
    ax.set_xlim(-0.5, cam.pinhole.width - 0.5)
    ax.set_ylim(cam.pinhole.height - 0.5, -0.5)
    ax.set_aspect("equal")
    ax.set_facecolor("0.92")
    colors = plt.cm.tab20(np.linspace(0, 1, len(edges)))
    images = cam.segment_image(corners[[i for i, _ in edges]], corners[[j for _, j in edges]])
    for im, col in zip(images, colors):
        for piece in im.pieces:
            ax.plot(piece.uv[:, 0], piece.uv[:, 1], "-", lw=1.2, color=col)
    ax.set_title(f"{rig}: exact images of the 12 edges of a 6 x 6 x 3 m box", fontsize=8)
    import io

    from ._io import atomic_write_bytes

    path = os.path.join(out_dir, "line_images.png")
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())
    print(f"wrote {path}")
    return {"round_trip_max_px": float(err.max()), "png": path}


def run_main_job(out_dir: str, *, renderer: str = "mitsuba", scene: str = "urban_street", noise: float = 2.0,
                 resolution: str | None = None, quality: str = "standard") -> int:
    """The main job: render the paper's relative-pose setting (two views of an urban street seen
    by a non-central catadioptric camera) and validate the relative pose (rotation and metric
    translation) from the lines of the first two views (exit code 3 if the answer is ambiguous)."""
    from .cli import main

    data = os.path.join(out_dir, f"{scene}_{renderer}")
    argv = ["render", scene, "--renderer", renderer, "--out", data, "--quality", quality]
    if resolution:
        argv += ["--resolution", resolution]
    code = main(argv)
    if code:
        return code
    report = os.path.join(out_dir, "relative_pose")
    return main(["validate", "relative-pose", data, "--out", report, "--noise", str(noise)]) or 0


def register(sub) -> None:
    from .cliargs import RIG_HELP, nonnegative_float

    d = sub.add_parser("demo", help="the main job: render an image pair and validate the relative pose "
                                    "(--geometry: the geometry demo only)")
    d.add_argument("--out", default="out/demo", help="output folder (default: out/demo)")
    d.add_argument("--renderer", default="mitsuba", choices=["mitsuba", "povray"], help="renderer (default mitsuba)")
    d.add_argument("--scene", default="urban_street", help="scene spec (default urban_street)")
    d.add_argument("--noise", type=nonnegative_float, default=2.0,
                   help="pixel noise of the line pixels (default 2, as the paper)")
    d.add_argument("--resolution", help="render resolution (name or WxH; default the rig's 640x480)")
    d.add_argument("--geometry", action="store_true", help="run the geometry demo only (no rendering)")
    d.add_argument("--rig", default="hyperboloid_9pct", help=RIG_HELP + ", of the geometry demo")

    def run(args):
        from .cliargs import check_out_dir, parse_resolution, resolve_rig

        check_out_dir(args.out)
        if args.geometry:
            resolve_rig(args.rig)  # errors name --rig
            run_geometry_demo(args.out, rig=args.rig)
            return 0
        if args.resolution:
            parse_resolution(args.resolution)  # a bad size fails before anything runs
        return run_main_job(args.out, renderer=args.renderer, scene=args.scene, noise=args.noise,
                            resolution=args.resolution)

    d.set_defaults(func=run)
