"""The street generator: a straight street with blocks of buildings, windows and road markings.

Layout in W (metres, z up): the street runs along x over ``[-length/2, length/2]``,
the road (asphalt, the ground plane at z = 0) is ``|y| < road_width/2``. Cross
streets cut the street into blocks; on each side a block is a slab of height
``curb_height`` (the sidewalk, then the building lots, ``block_depth`` deep).
Buildings stand in a row on each block: extruded footprints (rectangles,
L-shapes, rectangles with a chamfered front corner), turned by a yaw drawn from
``buildings.yaw_deg``; some rectangles get a gable roof. The road carries
dashed lane lines, edge lines, a zebra crossing and a stop line before each
intersection.

Labelled segments (each drawn as its own tube): the curb edges, every building's
vertical corners and roof outline (eaves, ridge and rakes of gable roofs), floor
lines on the facades, the four edges of each window, and every road marking.
Segments stop ``lines.clearance`` short of the corners they run to so that no
tube cap lies in the plane of a face; segments drawn on a face (floor lines,
markings) are lifted off it so that their tube clears it by ``lines.clearance``.

Random streams: block lengths use ``default_rng([seed, 0])``; the buildings of
side ``s`` (0 north, 1 south) and block ``j`` use ``default_rng([seed, 1, s, j])``,
so a block's buildings do not depend on the other blocks.
"""
from __future__ import annotations

import math

import numpy as np

from .._checks import CatadioptricError
from .builder import SceneBuilder
from .meshes import extrude_polygon, extrude_profile, merge, oriented_box, quads, tube_depth, tube_half_width
from .scene import Scene
from .spec import sun_direction

__all__ = ["build_street", "street_blocks", "min_blocks", "footprint"]

_Z = np.array([0.0, 0.0, 1.0])
_BASE = -0.1  # solids start below the ground so that no face is coplanar with it
_FRAME_COLOR = (0.88, 0.87, 0.84)


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def _shade(color, k: float) -> tuple[float, float, float]:
    return tuple(float(min(1.0, max(0.0, k * c))) for c in color)


def street_blocks(spec: dict, seed: int) -> list[tuple[float, float]]:
    """The x ranges ``[(x0, x1), ...]`` of the blocks (the same on both sides of the street)."""
    st = spec["street"]
    lo, hi = st["block_length_range"]
    half = st["length"] / 2
    rng = np.random.default_rng([seed, 0])
    blocks = []
    x = -half
    while x < half - 1e-9:
        x1 = min(x + rng.uniform(lo, hi), half)
        if half - (x1 + st["cross_street_width"]) < lo / 2:
            x1 = half  # no room for another block: this one runs to the end of the street
        if not x1 > x:  # pragma: no cover - refused before by build_street's block count
            raise CatadioptricError(f"scene.street.length: {st['length']!r} m is beyond the float precision of "
                                    f"blocks of {lo!r} to {hi!r} m")
        blocks.append((float(x), float(x1)))
        x = x1 + st["cross_street_width"]
    return blocks


def min_blocks(spec: dict) -> float:
    """A lower bound of the number of blocks (each at most ``block_length_range[1]`` long, plus a
    cross street): known before any block is drawn."""
    st = spec["street"]
    return math.floor(st["length"] / (st["block_length_range"][1] + st["cross_street_width"]))


def footprint(kind: str, w: float, d: float, rng: np.random.Generator) -> np.ndarray:
    """A footprint polygon ``(P, 2)``, counter-clockwise, in the lot frame (p along the street,
    q away from it), spanning ``[0, w] x [0, d]``: a rectangle, an L (a back corner cut out) or a
    rectangle with one front corner cut at 45 degrees."""
    if kind == "rect":
        return np.array([[0.0, 0.0], [w, 0.0], [w, d], [0.0, d]])
    if kind == "L":
        cw, cd = w * rng.uniform(0.35, 0.6), d * rng.uniform(0.35, 0.6)
        if rng.random() < 0.5:  # cut the back-right corner
            return np.array([[0.0, 0.0], [w, 0.0], [w, d - cd], [w - cw, d - cd], [w - cw, d], [0.0, d]])
        return np.array([[0.0, 0.0], [w, 0.0], [w, d], [cw, d], [cw, d - cd], [0.0, d - cd]])
    if kind == "chamfer":
        c = min(w, d) * rng.uniform(0.2, 0.4)
        if rng.random() < 0.5:  # cut the front-right corner
            return np.array([[0.0, 0.0], [w - c, 0.0], [w, c], [w, d], [0.0, d]])
        return np.array([[c, 0.0], [w, 0.0], [w, d], [0.0, d], [0.0, c]])
    raise CatadioptricError(f"kind: expected one of rect, L, chamfer, got {kind!r}")


class _Street:
    """One run of the generator (keeps the builder and the shared settings)."""

    def __init__(self, spec: dict, seed: int):
        self.spec = spec
        self.seed = seed
        ln = spec["lines"]
        self.B = SceneBuilder(sides=ln["sides"], clearance=ln["clearance"], max_triangles=spec["max_triangles"])
        self.r = ln["radius"]
        self.flatten = ln["flatten"]
        self.eps = ln["clearance"]
        self.line_color = ln.get("color")

    def color(self, default):
        return tuple(self.line_color) if self.line_color is not None else tuple(default)

    def edge(self, name, a, b, normal, host, color, *, on_surface=False, inset=None):
        """A segment from ``a`` to ``b`` shortened by ``inset`` (default: the clearance) at each end."""
        a = np.asarray(a, dtype=np.float64)
        b = np.asarray(b, dtype=np.float64)
        d = b - a
        length = float(np.linalg.norm(d))
        inset = self.eps if inset is None else inset
        if length <= 2 * inset + 1e-6:
            return None
        u = d / length
        return self.B.add_segment(name, a + inset * u, u, length - 2 * inset, radius=self.r, color=color,
                                  normal=normal, on_surface=on_surface, flatten=self.flatten if on_surface else 1.0,
                                  host=host)

    # ------------------------------------------------------------------ parts
    def ground(self) -> int:
        g = self.spec["ground"]
        h = g["size"] / 2
        v, f = quads([[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]])
        return self.B.add_mesh("ground", v, f, g["color"], "ground")

    def block_slab(self, tag: str, side: int, x0: float, x1: float) -> None:
        st = self.spec["street"]
        hr, D, curb = st["road_width"] / 2, st["block_depth"], st["curb_height"]
        y_near, y_far = side * hr, side * (hr + D)
        v, f = oriented_box([x0, min(y_near, y_far), _BASE], np.eye(3), [x1 - x0, D, curb - _BASE])
        color = st["sidewalk_color"]
        label = self.B.add_mesh(f"block_{tag}", v, f, color, "solid")
        c = self.color(_shade(color, 0.75))
        toward_road = np.array([0.0, -side, 0.0])
        self.edge(f"block_{tag}:curb", [x0, y_near, curb], [x1, y_near, curb], toward_road + _Z, label, c)
        self.edge(f"block_{tag}:end0", [x0, y_near, curb], [x0, y_far, curb], [-1.0, 0.0, 1.0], label, c)
        self.edge(f"block_{tag}:end1", [x1, y_near, curb], [x1, y_far, curb], [1.0, 0.0, 1.0], label, c)

    def buildings(self, tag: str, side: int, side_index: int, j: int, x0: float, x1: float) -> None:
        st, bs = self.spec["street"], self.spec["buildings"]
        rng = np.random.default_rng([self.seed, 1, side_index, j])
        kinds = list(bs["footprints"])
        kw = np.array([bs["footprints"][k] for k in kinds])
        yaws = np.array(bs["yaw_deg"])
        yw = np.array(bs["yaw_weights"]) if bs.get("yaw_weights") is not None else np.ones(len(yaws))
        palette = bs["palette"]
        hr, Ws, D = st["road_width"] / 2, st["sidewalk_width"], st["block_depth"]
        max_q = D - Ws - 0.5
        cursor = x0 + rng.uniform(*bs["gap_range"])
        k = 0
        while True:
            kind = kinds[int(rng.choice(len(kinds), p=kw / kw.sum()))]
            w = rng.uniform(*bs["width_range"])
            d = rng.uniform(*bs["depth_range"])
            yaw = float(yaws[int(rng.choice(len(yaws), p=yw / yw.sum()))])
            setback = rng.uniform(*bs["setback_range"])
            height = rng.uniform(*bs["height_range"])
            color = palette[int(rng.integers(len(palette)))]
            gable = kind == "rect" and rng.random() < bs["gable_fraction"]
            pitch = bs["roof_pitch_deg"][int(rng.integers(len(bs["roof_pitch_deg"])))]
            poly = footprint(kind, w, d, rng)
            placed = None
            for yaw_try in (yaw, 0.0):  # a turned footprint too deep for the block is placed unturned
                c, s = math.cos(math.radians(yaw_try)), math.sin(math.radians(yaw_try))
                pr = poly @ np.array([[c, s], [-s, c]])
                lo = pr.min(axis=0)
                pr = pr + np.array([cursor - lo[0], setback - lo[1]])
                if pr[:, 1].max() <= max_q:
                    placed = pr
                    break
            if placed is None or placed[:, 0].max() > x1 - 0.5:
                break
            xy = np.stack([placed[:, 0], side * (hr + Ws + placed[:, 1])], axis=1)
            if side < 0:
                xy = xy[::-1]  # keep the polygon counter-clockwise in W
            self.building(f"{tag}_{k}", side, xy, height, color, gable, pitch)
            cursor = float(placed[:, 0].max()) + rng.uniform(*bs["gap_range"])
            k += 1

    def building(self, tag, side, xy, height, color, gable, pitch) -> None:
        st, bs, ws = self.spec["street"], self.spec["buildings"], self.spec["windows"]
        curb = st["curb_height"]
        top = curb + height
        name = f"building_{tag}"
        B = self.B
        P = len(xy)
        V = np.concatenate([xy, np.zeros((P, 1))], axis=1)
        E = np.roll(V, -1, axis=0) - V
        Elen = np.linalg.norm(E, axis=1)
        U = E / Elen[:, None]
        N = np.stack([U[:, 1], -U[:, 0], np.zeros(P)], axis=1)  # outward normals (counter-clockwise polygon)

        vw, fw = extrude_polygon(xy, _BASE, top)
        host = B.add_mesh(name, vw, fw, color, "building")
        edge_color = self.color(_shade(color, 0.6))
        floor_color = self.color(_shade(color, 0.78))

        # vertical corners: the tube's cross-section points along the corner's bisector
        for i in range(P):
            bis = N[i] + N[i - 1]
            self.edge(f"{name}:corner{i}", V[i] + curb * _Z, V[i] + top * _Z, bis, host, edge_color)
        if gable:
            self.gable_roof(name, V, Elen, U, top, pitch, edge_color)
        else:
            for i in range(P):
                self.edge(f"{name}:roof{i}", V[i] + top * _Z, V[i] + E[i] + top * _Z, N[i] + _Z, host, edge_color)

        street_dir = np.array([0.0, -side, 0.0])
        facing = N @ street_dir > 0.5
        fh = bs["floor_height"]
        n_floors = int(np.floor(height / fh + 1e-9))
        if bs["floor_lines"] != "none":
            for i in range(P):
                if bs["floor_lines"] == "street" and not facing[i]:
                    continue
                for f in range(1, n_floors):
                    z = curb + f * fh
                    if z > top - 0.3:
                        break
                    self.edge(f"{name}:floor{f}_{i}", V[i] + z * _Z, V[i] + E[i] + z * _Z, N[i], host, floor_color,
                              on_surface=True, inset=self.r + self.eps)
        if ws["facades"] != "none":
            self.windows(name, V, E, Elen, U, N, facing, curb, top, n_floors)

    def gable_roof(self, name, V, Elen, U, top, pitch, edge_color) -> None:
        """A gable roof on the rectangle ``V`` (4 corners), ridge along its longer side."""
        B = self.B
        bs = self.spec["buildings"]
        i0 = 0 if Elen[0] >= Elen[1] else 1
        o, r, lr = V[i0], U[i0], Elen[i0]
        a = -U[i0 - 1]  # across, from the eave at o toward the opposite eave
        la = Elen[i0 - 1]
        rise = 0.5 * la * math.tan(math.radians(pitch))
        profile = np.array([[0.0, top], [la, top], [0.5 * la, top + rise]])
        vr, fr = extrude_profile(profile, o * np.array([1.0, 1.0, 0.0]), a, _Z, r, lr)
        roof = B.add_mesh(f"{name}:roof", vr, fr, bs["roof_color"], "building")
        base = o + top * _Z
        for s, out in ((0.0, -r), (lr, r)):  # the two gable ends
            p = base + s * r
            ridge_end = p + 0.5 * la * a + rise * _Z
            self.edge(f"{name}:rake{int(s > 0)}a", p, ridge_end, out + _Z, roof, edge_color)
            self.edge(f"{name}:rake{int(s > 0)}b", p + la * a, ridge_end, out + _Z, roof, edge_color)
        self.edge(f"{name}:eave0", base, base + lr * r, -a + _Z, roof, edge_color)
        self.edge(f"{name}:eave1", base + la * a, base + la * a + lr * r, a + _Z, roof, edge_color)
        ridge = base + 0.5 * la * a + rise * _Z
        self.edge(f"{name}:ridge", ridge, ridge + lr * r, _Z, roof, edge_color)

    def windows(self, name, V, E, Elen, U, N, facing, curb, top, n_floors) -> None:
        ws, bs = self.spec["windows"], self.spec["buildings"]
        fh = bs["floor_height"]
        w, h, depth = ws["width"], ws["height"], ws["depth"]
        sunk = 0.05  # panes start inside the wall: no face is coplanar with the facade
        # count before making them: a box (12 triangles) and four edge tubes per window
        count = 0.0
        for i in range(len(V)):
            usable = Elen[i] - 2 * ws["margin"]
            if (ws["facades"] != "street" or facing[i]) and usable >= w:
                count += (math.floor((usable - w) / ws["spacing"] + 1e-9) + 1) * n_floors
        self.B.check(count * (12 + (4 * self.B.tube_triangles if ws["lines"] else 0)), f" ({count:.3g} windows on {name})")
        panes, frames = [], []
        for i in range(len(V)):
            if ws["facades"] == "street" and not facing[i]:
                continue
            usable = Elen[i] - 2 * ws["margin"]
            if usable < w:
                continue
            nc = int(np.floor((usable - w) / ws["spacing"] + 1e-9)) + 1
            centers = Elen[i] / 2 + (np.arange(nc) - (nc - 1) / 2) * ws["spacing"]
            axes = np.stack([U[i], N[i], _Z], axis=1)
            for f in range(n_floors):
                z = curb + f * fh + ws["sill"]
                if z + h > top - 0.3:
                    break
                for c in centers:
                    corner = V[i] + (c - w / 2) * U[i] + z * _Z
                    panes.append(oriented_box(corner - sunk * N[i], axes, [w, depth + sunk, h]))
                    frames.append((i, f, corner + depth * N[i]))
        if not panes:
            return
        vp, fp = merge(panes)
        host = self.B.add_mesh(f"{name}:windows", vp, fp, ws["color"], "window")
        if not ws["lines"]:
            return
        color = self.color(_FRAME_COLOR)
        for k, (i, f, A) in enumerate(frames):
            u, n = U[i], N[i]
            tag = f"{name}:window{k}"
            self.edge(f"{tag}_bottom", A, A + w * u, n - _Z, host, color)
            self.edge(f"{tag}_top", A + h * _Z, A + h * _Z + w * u, n + _Z, host, color)
            # the side edges stop a tube radius short of the top and bottom ones: overlapping tubes at
            # the corners would make pixels whose label is a tie between two coplanar faces
            side_inset = self.eps + self.r
            self.edge(f"{tag}_left", A, A + h * _Z, n - u, host, color, inset=side_inset)
            self.edge(f"{tag}_right", A + w * u, A + w * u + h * _Z, n + u, host, color, inset=side_inset)

    def markings(self, ground: int, blocks) -> None:
        st, m = self.spec["street"], self.spec["markings"]
        B = self.B
        hr = st["road_width"] / 2
        color = tuple(m["color"])
        t = m["thickness"]
        across, below = tube_half_width(B.sides), tube_depth(B.sides)

        def paint(name, a, b, width):
            """A flat tube exactly ``width`` wide and ``thickness`` thick lying on the road."""
            a, b = np.asarray(a, float), np.asarray(b, float)
            d = b - a
            length = float(np.linalg.norm(d))
            radius = width / (2 * across)
            flatten = min(1.0, t / (radius * (1 + below)))
            B.add_segment(name, a, d / length, length, radius=radius, color=color, normal=_Z, on_surface=True,
                          flatten=flatten, host=ground)

        lane_ys = [-hr + k * st["road_width"] / st["lanes"] for k in range(1, st["lanes"])]
        for j, (x0, x1) in enumerate(blocks):
            end = x1 - 1.0
            edge_end = x1 - 0.5
            crossing = j < len(blocks) - 1
            if crossing and m["zebra"]:
                zx1 = x1 - 0.5
                zx0 = zx1 - m["zebra_length"]
                sw, gap = m["zebra_stripe_width"], m["zebra_gap"]
                y = -hr + 0.5 + sw / 2
                k = 0
                while y + sw / 2 <= hr - 0.5 + 1e-9:
                    paint(f"zebra{j}_{k}", [zx0, y, 0.0], [zx1, y, 0.0], sw)
                    y += sw + gap
                    k += 1
                end = zx0 - 1.0
                edge_end = zx0 - 0.5
            if crossing and m["stop_lines"]:
                xs = end
                y0 = -hr + m["edge_offset"] + m["width"] / 2 + 0.05
                y1 = -m["width"] / 2 - 0.05
                if y1 > y0:
                    paint(f"stop{j}", [xs, y0, 0.0], [xs, y1, 0.0], m["stop_line_width"])
                end = xs - m["stop_line_width"] / 2 - 1.0
            if m["edge_lines"] and edge_end - (x0 + 0.5) > 0.5:
                for s, y in (("s", -hr + m["edge_offset"]), ("n", hr - m["edge_offset"])):
                    paint(f"edge{j}{s}", [x0 + 0.5, y, 0.0], [edge_end, y, 0.0], m["width"])
            for li, y in enumerate(lane_ys):
                x = x0 + 1.0
                k = 0
                while x + m["dash_length"] <= end + 1e-9:
                    paint(f"lane{j}_{li}_{k}", [x, y, 0.0], [x + m["dash_length"], y, 0.0], m["width"])
                    x += m["dash_length"] + m["dash_gap"]
                    k += 1


def build_street(spec: dict, seed: int) -> Scene:
    """The street scene of a normalised ``generator = "street"`` spec (see ``docs/formats.md``)."""
    g = _Street(spec, seed)
    sides = {"both": ((1, 0), (-1, 1)), "north": ((1, 0),), "south": ((-1, 1),)}[spec["street"]["sides"]]
    st = spec["street"]
    nb = min_blocks(spec)  # every block is at least a slab (a box, 12 triangles) on each side
    if 2 + 12 * len(sides) * nb > spec["max_triangles"]:
        raise CatadioptricError(
            f"scene.street.length: a street of {st['length']!r} m has at least {nb:.6g} blocks (each at most "
            f"block_length_range[1] + cross_street_width = {st['block_length_range'][1] + st['cross_street_width']!r} m "
            f"long), at least {12 * len(sides) * nb:.6g} triangles: more than max_triangles = "
            f"{spec['max_triangles']}; shorten the street or raise scene.max_triangles")
    ground = g.ground()
    blocks = street_blocks(spec, seed)
    for side, si in sides:
        for j, (x0, x1) in enumerate(blocks):
            tag = f"{'ns'[si]}{j}"
            g.block_slab(tag, side, x0, x1)
            g.buildings(tag, side, si, j, x0, x1)
    g.markings(ground, blocks)  # (the builder refuses, as it goes, to exceed max_triangles)
    return g.B.build(name=spec["name"], seed=seed, sun=sun_direction(spec), spec=spec)
