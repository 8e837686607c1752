"""The chessboard generator: chessboards of N x M squares at known poses on a ground plane.

Each board (see :func:`catadioptric.scenes.spec.board_frame` for its pose) has a
front face of N x M flat squares in the plane through ``center`` (dark squares
one mesh, light squares another), a light backing slab of ``thickness`` behind
it that also forms a white ``border`` around the squares, and labelled grid
lines: the N + 1 lines along its ``v`` axis and the M + 1 lines along its ``u``
axis (``lines = "inner"`` keeps the N - 1 and M - 1 inner ones). The grid lines
are drawn on the squares (their tubes are lifted to clear the face by
``lines.clearance``) and stop ``lines.clearance`` short of the checker's edge;
their host (``Scene.segment_host``) is the board's frame.
Boards with the same orientation share their two families.

The layout is fully given by the spec: the seed does not change the scene.
"""
from __future__ import annotations

import numpy as np

from .builder import SceneBuilder
from .meshes import oriented_box, quads
from .scene import Scene
from .spec import board_frame, board_size, sun_direction

__all__ = ["build_chessboard"]

_LINE_GREY = (0.5, 0.5, 0.5)


def _board(B: SceneBuilder, spec: dict, board: dict) -> None:
    c = spec["chessboard"]
    ln = spec["lines"]
    (nx, ny), s, border, thick = board_size(spec, board)
    R = board_frame(board)
    u, v, n = R[:, 0], R[:, 1], R[:, 2]
    center = np.asarray(board["center"], dtype=np.float64)
    name = board["name"]
    to_world = lambda p: center + np.asarray(p, dtype=np.float64) @ R.T  # noqa: E731  local (x, y, z) -> W

    # backing slab, its front face just behind the squares (never coplanar with them)
    gap = min(0.001, thick / 10)
    hw, hh = nx * s / 2 + border, ny * s / 2 + border
    vb, fb = oriented_box(to_world([-hw, -hh, -thick]), R, [2 * hw, 2 * hh, thick - gap])
    frame = B.add_mesh(f"{name}:frame", vb, fb, c["light_color"], "chessboard")

    xs = (np.arange(nx + 1) - nx / 2) * s
    ys = (np.arange(ny + 1) - ny / 2) * s
    ii, jj = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    corners = np.stack([
        np.stack([xs[ii], ys[jj]], -1), np.stack([xs[ii + 1], ys[jj]], -1),
        np.stack([xs[ii + 1], ys[jj + 1]], -1), np.stack([xs[ii], ys[jj + 1]], -1),
    ], axis=2)  # (nx, ny, 4, 2), counter-clockwise seen from the front (+n)
    corners = np.concatenate([corners, np.zeros(corners.shape[:-1] + (1,))], axis=-1)
    dark = (ii + jj) % 2 == 0
    vd, fd = quads(to_world(corners[dark]))
    B.add_mesh(f"{name}:dark", vd, fd, c["dark_color"], "chessboard")
    if np.any(~dark):  # (a 1 x 1 board has no light square)
        vl, fl = quads(to_world(corners[~dark]))
        B.add_mesh(f"{name}:light", vl, fl, c["light_color"], "chessboard")

    if c["lines"] == "none":
        return
    color = tuple(ln["color"]) if ln.get("color") is not None else _LINE_GREY
    eps = ln["clearance"]
    rng_x = range(nx + 1) if c["lines"] == "all" else range(1, nx)
    rng_y = range(ny + 1) if c["lines"] == "all" else range(1, ny)
    for i in rng_x:  # lines along v
        start = to_world([xs[i], ys[0] + eps, 0.0])
        B.add_segment(f"{name}:v{i}", start, v, ny * s - 2 * eps, radius=ln["radius"], color=color, normal=n,
                      on_surface=True, flatten=ln["flatten"], host=frame)
    for j in rng_y:  # lines along u
        start = to_world([xs[0] + eps, ys[j], 0.0])
        B.add_segment(f"{name}:u{j}", start, u, nx * s - 2 * eps, radius=ln["radius"], color=color, normal=n,
                      on_surface=True, flatten=ln["flatten"], host=frame)


def build_chessboard(spec: dict, seed: int) -> Scene:
    """The chessboard scene of a normalised ``generator = "chessboard"`` spec."""
    ln = spec["lines"]
    B = SceneBuilder(sides=ln["sides"], clearance=ln["clearance"], max_triangles=spec["max_triangles"])
    # count before building: a frame (12), two triangles a square, a tube a grid line; the ground (2)
    n_lines = {"all": 2, "inner": -2, "none": None}[spec["chessboard"]["lines"]]
    total = 2
    for board in spec["chessboard"]["boards"]:
        (nx, ny), *_ = board_size(spec, board)
        total += 12 + 2 * nx * ny + (0 if n_lines is None else (nx + ny + n_lines) * B.tube_triangles)
    B.check(total, f" ({len(spec['chessboard']['boards'])} boards)")
    g = spec["ground"]
    h = g["size"] / 2
    vg, fg = quads([[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]])
    B.add_mesh("ground", vg, fg, g["color"], "ground")
    for board in spec["chessboard"]["boards"]:
        _board(B, spec, board)
    return B.build(name=spec["name"], seed=seed, sun=sun_direction(spec), spec=spec)
