"""A small hand-built street scene for the renderers' tests and benchmark.

Independent of the seeded generators of :mod:`catadioptric.scenes` on purpose: the
renderers, the tracer and the dataset code are checked on a scene whose every number
is visible here. Ground (label 1), box buildings on both sides of a street along x,
one building turned by ``yaw_deg`` (its own line families), and line tubes along
building edges and road markings, each tube with its own label. No two faces of
different objects are coplanar where they overlap (a ray meeting both at once has no
well-defined first hit, and renderers break such ties differently).
"""
from __future__ import annotations

import numpy as np

from ..frames import RigPose
from ..scenes.scene import Scene, SceneObject

__all__ = ["street_scene", "tube_mesh", "box_mesh", "street_views"]


def box_mesh(lo, hi):
    """Closed axis-aligned box from corner ``lo`` to ``hi``: vertices (8, 3), faces (12, 3), outward."""
    lo = np.asarray(lo, float)
    hi = np.asarray(hi, float)
    v = np.array([[x, y, z] for z in (lo[2], hi[2]) for y in (lo[1], hi[1]) for x in (lo[0], hi[0])])
    f = np.array([[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
                  [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]])
    return v, f


def tube_mesh(a, b, radius, sections=8):
    """Closed prism of ``sections`` sides around the segment ``a``-``b`` (caps included)."""
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    axis = b - a
    axis /= np.linalg.norm(axis)
    helper = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    ang = 2 * np.pi * np.arange(sections) / sections
    ring = radius * (np.cos(ang)[:, None] * e1 + np.sin(ang)[:, None] * e2)
    v = np.concatenate([a + ring, b + ring, [a, b]])
    n = sections
    faces = []
    for i in range(n):
        j = (i + 1) % n
        faces += [[i, j, n + i], [j, n + j, n + i], [2 * n, j, i], [2 * n + 1, n + i, n + j]]
    return v, np.array(faces)


def _yaw(deg):
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def street_scene(seed: int = 0, *, tube_radius: float = 0.06, yaw_deg: float = 30.0, ground_size: float = 400.0,
                 sections: int = 8) -> Scene:
    """A street along x with buildings on both sides; ``seed`` jitters the building sizes."""
    rng = np.random.default_rng(seed)
    objects: list[SceneObject] = []
    segs, fams, seg_labels = [], [], []
    families = [np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0])]
    yaw = _yaw(yaw_deg)
    families += [yaw @ families[0], yaw @ families[1]]

    def add(name, label_kind, v, f, color):
        objects.append(SceneObject(name, len(objects) + 1, np.asarray(v, float), np.asarray(f, np.int64),
                                   tuple(float(c) for c in color), label_kind))
        return len(objects)

    def add_line(name, a, b, fam, color=(0.95, 0.85, 0.1)):
        # the tube stops one radius short of each end so that its caps never lie in a face of the
        # building or ground it touches (coplanar faces have no well-defined first hit)
        a, b = np.asarray(a, float), np.asarray(b, float)
        u = (b - a) / np.linalg.norm(b - a)
        v, f = tube_mesh(a + tube_radius * u, b - tube_radius * u, tube_radius, sections)
        lab = add(name, "line", v, f, color)
        segs.append([a, b])
        fams.append(fam)
        seg_labels.append(lab)

    g = ground_size / 2
    add("ground", "ground", [[-g, -g, 0], [g, -g, 0], [g, g, 0], [-g, g, 0]], [[0, 1, 2], [0, 2, 3]],
        (0.35, 0.36, 0.33))
    k = 0
    for side in (-1, 1):
        x = -28.0
        while x < 28.0:
            w = rng.uniform(6.0, 10.0)
            d = rng.uniform(6.0, 9.0)
            h = rng.uniform(6.0, 18.0)
            y0 = side * 7.0
            y1 = side * (7.0 + d)
            lo = np.array([x, min(y0, y1), 0.0])
            hi = np.array([x + w, max(y0, y1), h])
            v, f = box_mesh(lo, hi)
            col = rng.uniform(0.45, 0.85, 3)
            add(f"building_{k}", "building", v, f, col)
            # the street-side edges: vertical corners and the roof line
            yf = y0 - side * 0.0
            add_line(f"edge_{k}_v0", [x, yf, 0.0], [x, yf, h], 2)
            add_line(f"edge_{k}_roof", [x, yf, h], [x + w, yf, h], 0)
            k += 1
            x += w + rng.uniform(1.0, 3.0)
    # a building turned by yaw_deg, beyond the street's end
    v, f = box_mesh([-5.0, -5.0, 0.0], [5.0, 5.0, 12.0])
    c = np.array([45.0, 0.0, 0.0])
    add("turned_building", "building", v @ yaw.T + c, f, (0.7, 0.55, 0.45))
    for i, (a, b, fam) in enumerate([((-5, -5, 12), (5, -5, 12), 3), ((-5, -5, 12), (-5, 5, 12), 4),
                                      ((-5, -5, 0.3), (5, -5, 0.3), 3)]):
        add_line(f"turned_edge_{i}", yaw @ np.array(a, float) + c, yaw @ np.array(b, float) + c, fam)
    # road markings: dashes along the street axis, slightly above the ground
    for i, x in enumerate(np.arange(-26.0, 26.0, 6.0)):
        add_line(f"marking_{i}", [x, 0.0, 1.5 * tube_radius], [x + 3.0, 0.0, 1.5 * tube_radius], 0, (0.95, 0.95, 0.95))
    scene = Scene(objects=objects, segments=np.array(segs, float), segment_family=np.array(fams, np.int64),
                  families=np.array(families, float), segment_label=np.array(seg_labels, np.int64),
                  name="test_street", seed=seed, sun=np.array([0.4, -0.3, 0.866]) / np.linalg.norm([0.4, -0.3, 0.866]),
                  spec={"generator": "catadioptric.render.testscene.street_scene", "seed": seed,
                        "tube_radius": tube_radius, "yaw_deg": yaw_deg})
    scene.segment_radius = np.full(len(segs), tube_radius)  # the tube around each segment
    return scene


def street_views(rig_name: str = "hyperboloid") -> list[tuple[str, RigPose]]:
    """A few poses of a rig in the street (mirror 2 m above the ground).

    Rigs whose reflected rays go mostly up (a sphere or a cone seen from above) are
    mounted upside down so that they see the street."""
    flip = rig_name.startswith(("sphere", "cone"))
    out = []
    for i, (x, y, yaw) in enumerate([(0.0, 0.0, 0.0), (-6.0, 1.5, 20.0), (8.0, -1.0, -35.0)]):
        # x_M = R x_W + t: the mirror origin sits at (x, y, 2) in W
        Rw = _yaw(yaw)  # mirror axes in W (columns)
        if flip:
            Rw = Rw @ np.diag([1.0, -1.0, -1.0])
        out.append((f"view_{i:02d}", RigPose.from_mirror_in_world(Rw, np.array([x, y, 2.0]))))
    return out
