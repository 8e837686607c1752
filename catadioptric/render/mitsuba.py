"""Mitsuba 3 backend (the default): an exact quadric mirror inside a Python ``mi.Sensor``.

The scene stays in the world frame W (float32 meshes, one per object, diffuse colours,
a sun and a clear-sky environment map). The sensor turns each film sample into an OpenCV
pixel (``u = x W - 0.5``, ``v = y H - 0.5``), intersects the camera ray with the exact
quadric in M (stable quadratic root, nearest root in the patch), reflects it about the
normal ``(x, y, A z + B/2)`` (again if the reflected ray meets the patch, up to three
times), moves it to W (``x_W = R^T (x_M - t)``) and returns it; pixels whose ray misses
the mirror get weight 0 (black), as in the POV-Ray backend. Only ``dr.*`` operations,
so the llvm variant compiles it; its parameters are opaque arrays, so one compiled
kernel serves every view.

Labels are not rendered: our own float64 pixel-centre reflected rays
(:func:`catadioptric.projection.backproject`, moved to W) are converted to float32 and
intersected with the Mitsuba scene (``scene.ray_intersect_preliminary``); the shape hit
gives the label. Pixels that miss the mirror (-1) or whose reflected ray meets it again
(-2) come from the same float64 rays.

The variant: ``llvm_ad_rgb`` when a probe in a subprocess renders with it (a wrong system
libLLVM aborts the whole process, so it is never tried in-process first), else
``scalar_rgb`` with a warning (about 170 times slower). ``$CATADIOPTRIC_MITSUBA_VARIANT``
forces a variant and caches the probe's answer for child processes.
"""
from __future__ import annotations

import os
import subprocess
import sys
import time
import warnings

import numpy as np

from .common import (LABEL_MIRROR_AGAIN, LABEL_NO_MIRROR, SUN_IRRADIANCE, RenderError, RenderResult, check_view,
                     linear_to_srgb8, load_quality, sky_radiance)
from .tracer import pixel_rays, scene_digest

__all__ = ["render_mitsuba", "mitsuba_variant", "mitsuba_version", "mitsuba_labels"]

PREFERRED = "llvm_ad_rgb"
FALLBACK = "scalar_rgb"
ENV = "CATADIOPTRIC_MITSUBA_VARIANT"
MAX_BOUNCES = 3  # reflections on the mirror followed inside the sensor

_PROBE = r"""
import mitsuba as mi
mi.set_variant({variant!r})
s = mi.load_dict({{'type': 'scene', 'integrator': {{'type': 'path', 'max_depth': 3}},
    'sensor': {{'type': 'perspective', 'film': {{'type': 'hdrfilm', 'width': 8, 'height': 8}},
               'sampler': {{'type': 'independent', 'sample_count': 2}}}},
    'e': {{'type': 'constant'}}, 'r': {{'type': 'rectangle', 'to_world': mi.ScalarTransform4f().translate([0, 0, 3])}}}})
img = mi.render(s)
print('OK', float(mi.Float(img.array)[0]) >= 0)
"""

_variant: str | None = None


def _probe(variant: str) -> tuple[bool, str]:
    try:
        p = subprocess.run([sys.executable, "-c", _PROBE.format(variant=variant)], capture_output=True, text=True,
                           timeout=300)
    except subprocess.TimeoutExpired:
        return False, "the probe timed out"
    ok = p.returncode == 0 and "OK" in p.stdout
    return ok, (p.stderr.strip().splitlines() or [f"exit code {p.returncode}"])[-1]


def mitsuba_variant() -> str:
    """Set (once per process) and return the Mitsuba variant this machine can run."""
    global _variant
    if _variant is not None:
        return _variant
    try:
        import mitsuba as mi
    except ImportError as exc:
        raise RenderError(f"mitsuba: the Python package is not installed ({exc}); "
                          "install it with `pip install mitsuba` (or `pip install -e .[render]`)") from None
    v = os.environ.get(ENV)
    if not v:
        ok, why = _probe(PREFERRED)
        if ok:
            v = PREFERRED
        else:
            warnings.warn(f"mitsuba: the {PREFERRED} variant does not run here ({why}); falling back to "
                          f"{FALLBACK}, about 170x slower. On Debian, `sudo apt-get install -y libllvm19` "
                          f"fixes it (drjit finds it, or set DRJIT_LIBLLVM_PATH).", RuntimeWarning, stacklevel=2)
            v = FALLBACK
        os.environ[ENV] = v
    if v not in mi.variants():
        raise RenderError(f"{ENV}: expected one of {mi.variants()}, got {v!r}")
    try:
        mi.set_variant(v)
    except Exception as exc:  # e.g. a cuda variant without a GPU: ImportError from drjit
        why = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise RenderError(f"{ENV}: the Mitsuba variant {v!r} does not run here ({why}); unset {ENV} to use "
                          f"{PREFERRED} (or {FALLBACK} when llvm is missing)") from None
    _variant = v
    return v


def mitsuba_version() -> str | None:
    try:
        import mitsuba as mi

        return mi.__version__
    except ImportError:
        return None


# ------------------------------------------------------------------- the sensor
_SENSOR_CLASSES: dict = {}


def _sensor_class():
    """The sensor class of the current variant (defined after ``set_variant``; registered once)."""
    import drjit as dr
    import mitsuba as mi

    v = mi.variant()
    if v in _SENSOR_CLASSES:
        return _SENSOR_CLASSES[v]

    def first_hit(q, o, d, t_min):
        """Nearest ``t > t_min`` where ``o + t d`` meets the patch (stable quadratic)."""
        A, B, C, z0, z1 = q
        a = d.x * d.x + d.y * d.y + A * d.z * d.z
        b = 2.0 * (o.x * d.x + o.y * d.y + A * o.z * d.z) + B * d.z
        c = o.x * o.x + o.y * o.y + A * o.z * o.z + B * o.z - C
        disc = b * b - 4.0 * a * c
        sq = dr.sqrt(dr.maximum(disc, 0.0))
        qq = -0.5 * (b + dr.copysign(sq, b))
        lin = dr.abs(a) <= 1e-12 * (dr.abs(b) + dr.abs(c))
        t1 = dr.select(lin, -c / b, qq / a)
        t2 = dr.select(lin, -c / b, c / qq)
        lo = dr.minimum(t1, t2)
        hi = dr.maximum(t1, t2)
        zlo = o.z + lo * d.z
        zhi = o.z + hi * d.z
        real = disc >= 0.0
        ok_lo = real & (lo > t_min) & (zlo >= z0) & (zlo <= z1)
        ok_hi = real & (hi > t_min) & (zhi >= z0) & (zhi <= z1)
        return dr.select(ok_lo, lo, hi), ok_lo | ok_hi

    def reflect(q, r, d):
        A, B = q[0], q[1]
        n = mi.Vector3f(r.x, r.y, A * r.z + 0.5 * B)
        return dr.normalize(d - 2.0 * n * (dr.dot(d, n) / dr.dot(n, n)))

    class QuadricMirrorSensor(mi.Sensor):
        """Pinhole + exact quadric mirror; parameters set by :meth:`set_rig` (opaque arrays)."""

        def __init__(self, props):
            mi.Sensor.__init__(self, props)
            self.params = None

        def set_rig(self, cam, pose):
            def f(x):
                a = mi.Float(float(x))
                dr.make_opaque(a)
                return a

            p = cam.pinhole
            m = cam.mirror
            G = cam.R_cam_from_mirror.T @ p.K_inv  # pixel (u, v, 1) -> ray direction in M
            self.params = {
                "size": (f(p.width), f(p.height)),
                "G": [f(x) for x in G.reshape(-1)],
                "c": [f(x) for x in cam.center],
                "q": [f(m.A), f(m.B), f(m.C), f(m.z_min), f(m.z_max)],
                "RW": [f(x) for x in pose.R.T.reshape(-1)],  # M -> W for directions
                "oW": [f(x) for x in pose.origin_in_world],
                "eps": f(1e-6 * m.scale),
            }

        def sample_ray(self, time, sample1, sample2, sample3, active=True):
            P = self.params
            W, H = P["size"]
            u = sample2.x * W - 0.5
            v = sample2.y * H - 0.5
            G = P["G"]
            d = dr.normalize(mi.Vector3f(G[0] * u + G[1] * v + G[2], G[3] * u + G[4] * v + G[5],
                                         G[6] * u + G[7] * v + G[8]))
            o = mi.Point3f(P["c"][0], P["c"][1], P["c"][2])
            q = P["q"]
            t, hit = first_hit(q, o, d, 0.0)
            r = o + dr.select(hit, t, 0.0) * d
            out = reflect(q, r, d)
            for _ in range(MAX_BOUNCES - 1):
                t2, again = first_hit(q, r, out, P["eps"])
                again &= hit
                r2 = r + dr.select(again, t2, 0.0) * out
                out = dr.select(again, reflect(q, r2, out), out)
                r = dr.select(again, r2, r)
            _, still = first_hit(q, r, out, P["eps"])
            ok = hit & ~still
            R, oW = P["RW"], P["oW"]
            rw = mi.Point3f(R[0] * r.x + R[1] * r.y + R[2] * r.z + oW[0],
                            R[3] * r.x + R[4] * r.y + R[5] * r.z + oW[1],
                            R[6] * r.x + R[7] * r.y + R[8] * r.z + oW[2])
            dw = mi.Vector3f(R[0] * out.x + R[1] * out.y + R[2] * out.z,
                             R[3] * out.x + R[4] * out.y + R[5] * out.z,
                             R[6] * out.x + R[7] * out.y + R[8] * out.z)
            rw = dr.select(ok, rw, mi.Point3f(oW[0], oW[1], oW[2]))
            dw = dr.select(ok, dw, mi.Vector3f(0.0, 0.0, 1.0))
            ray = mi.Ray3f(rw, dw, time, [])
            return ray, dr.select(ok, mi.Spectrum(1.0), mi.Spectrum(0.0))

        def sample_ray_differential(self, time, sample1, sample2, sample3, active=True):
            ray, w = self.sample_ray(time, sample1, sample2, sample3, active)
            return mi.RayDifferential3f(ray), w

        def to_string(self):
            return "QuadricMirrorSensor[]"

    mi.register_sensor("catadioptric_quadric_" + v, lambda props: QuadricMirrorSensor(props))
    _SENSOR_CLASSES[v] = QuadricMirrorSensor
    return QuadricMirrorSensor


# -------------------------------------------------------------------- the scene
_SCENES: dict = {}


def _env_bitmap(width=512, height=256):
    """Equirectangular sky in Mitsuba's envmap layout with identity ``to_world``
    (texel (col, row) looks along (sin th sin ph, cos th, -sin th cos ph), th = pi (row + .5)/h,
    ph = 2 pi (col + .5)/w), coloured by :func:`sky_radiance` of W's elevation (z)."""
    th = np.pi * (np.arange(height) + 0.5) / height
    ph = 2 * np.pi * (np.arange(width) + 0.5) / width
    TH, PH = np.meshgrid(th, ph, indexing="ij")
    z = -np.sin(TH) * np.cos(PH)
    return sky_radiance(z).astype(np.float32)


def _build_scene(scene, cam_size, quality):
    import mitsuba as mi

    cls = _sensor_class()
    v = mi.variant()
    sun = np.asarray(scene.sun, float)
    sun = sun / np.linalg.norm(sun)
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": int(quality["max_depth"]), "hide_emitters": False},
        "sensor": {"type": "catadioptric_quadric_" + v,
                   "film": {"type": "hdrfilm", "width": int(cam_size[0]), "height": int(cam_size[1]),
                            "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                   "sampler": {"type": "independent", "sample_count": int(quality["mitsuba_spp"])}},
        "sky": {"type": "envmap", "bitmap": mi.Bitmap(_env_bitmap())},
        "sun": {"type": "directional", "direction": (-sun).tolist(),
                "irradiance": {"type": "rgb", "value": [SUN_IRRADIANCE] * 3}},
    }
    labels = np.zeros(len(scene.objects) + 1, dtype=np.int32)
    for i, obj in enumerate(scene.objects):
        f = np.asarray(obj.faces, dtype=np.int64)
        if len(f) == 0:
            continue
        vtx = np.asarray(obj.vertices, dtype=np.float64)
        props = mi.Properties()
        props["bsdf"] = mi.load_dict({"type": "diffuse",
                                      "reflectance": {"type": "rgb", "value": [float(c) for c in obj.color]}})
        mesh = mi.Mesh(f"o{i}", len(vtx), len(f), props=props)
        p = mi.traverse(mesh)
        p["vertex_positions"] = type(p["vertex_positions"])(vtx.astype(np.float32).ravel())
        p["faces"] = type(p["faces"])(f.astype(np.uint32).ravel())
        p.update()
        d[f"o{i}"] = mesh
        labels[i + 1] = int(obj.label)
    if not quality["shadows"]:
        d["integrator"]["type"] = "direct"
    s = mi.load_dict(d)
    sensor = s.sensors()[0]
    if not isinstance(sensor, cls):
        raise RenderError(f"mitsuba: the scene's sensor is a {type(sensor).__name__}, not the quadric sensor")
    # label of each shape by its registry index (what ray_intersect reports)
    shape_label = {}
    for sh in s.shapes():
        shape_label[sh.id()] = labels[int(sh.id()[1:]) + 1]
    return s, shape_label


def _scene_for(scene, cam, quality):
    key = (getattr(scene, "_catadioptric_digest", None) or scene_digest(scene), cam.pinhole.width,
           cam.pinhole.height, quality["mitsuba_spp"], quality["max_depth"], quality["shadows"])
    entry = _SCENES.get(key)
    if entry is None:
        if len(_SCENES) >= 2:
            _SCENES.pop(next(iter(_SCENES)))
        entry = _SCENES[key] = _build_scene(scene, (cam.pinhole.width, cam.pinhole.height), quality)
    return entry


def mitsuba_labels(mscene, shape_label: dict, scene, cam, pose) -> np.ndarray:
    """Labels from ``ray_intersect`` of our float64 pixel-centre reflected rays (as float32) in W."""
    import drjit as dr
    import mitsuba as mi

    rays = pixel_rays(cam)  # shared with the float64 tracer (computed once per rig)
    H, W = rays.valid.shape
    labels = np.full((H, W), LABEL_NO_MIRROR, dtype=np.int32)
    labels[rays.hit & ~rays.valid] = LABEL_MIRROR_AGAIN
    ok = rays.valid
    o = ((rays.origins[ok] - pose.t) @ pose.R).astype(np.float32)
    dd = (rays.directions[ok] @ pose.R).astype(np.float32)
    if len(o) == 0:
        return labels
    shapes = mscene.shapes()
    if mi.variant().startswith("scalar"):
        out = np.zeros(len(o), dtype=np.int32)
        for i in range(len(o)):
            pi = mscene.ray_intersect_preliminary(mi.Ray3f(o[i].tolist(), dd[i].tolist()))
            if pi.is_valid():
                out[i] = shape_label[pi.shape.id()]
    else:
        ray = mi.Ray3f(mi.Point3f(*(mi.Float(o[:, k]) for k in range(3))),
                       mi.Vector3f(*(mi.Float(dd[:, k]) for k in range(3))))
        pi = mscene.ray_intersect_preliminary(ray)
        idx = np.asarray(dr.reinterpret_array(mi.UInt32, pi.shape), dtype=np.int64)
        valid = np.asarray(pi.is_valid(), dtype=bool)
        reg = np.asarray(dr.reinterpret_array(mi.UInt32, mscene.shapes_dr()), dtype=np.int64)
        lut = np.zeros(max(int(reg.max(initial=0)), int(idx.max(initial=0))) + 1, dtype=np.int32)
        for sh, r in zip(shapes, reg):
            lut[r] = shape_label[sh.id()]
        out = np.where(valid, lut[idx], 0).astype(np.int32)
    labels[ok] = out
    return labels


def render_mitsuba(scene, cam, pose, quality="standard", *, seed: int = 0, beauty: bool = True):
    """Render a view with Mitsuba 3: beauty RGB uint8 ``(H, W, 3)`` and labels int32 ``(H, W)``."""
    import mitsuba as mi

    check_view(scene, cam, pose)
    q = load_quality(quality)
    variant = mitsuba_variant()
    t0 = time.perf_counter()
    mscene, shape_label = _scene_for(scene, cam, q)
    sensor = mscene.sensors()[0]
    sensor.set_rig(cam, pose)
    info = {"renderer": "mitsuba", "mitsuba": mi.__version__, "variant": variant, "quality": q, "seed": int(seed),
            "seconds_scene": time.perf_counter() - t0}
    t0 = time.perf_counter()
    labels = mitsuba_labels(mscene, shape_label, scene, cam, pose)
    info["seconds_labels"] = time.perf_counter() - t0
    if beauty:
        t0 = time.perf_counter()
        img = mi.render(mscene, sensor=sensor, seed=int(seed) & 0xFFFFFFFF, spp=int(q["mitsuba_spp"]))
        linear = np.asarray(img, dtype=np.float64)[..., :3]
        rgb = linear_to_srgb8(linear)
        info["seconds_beauty"] = time.perf_counter() - t0
    else:
        rgb, linear = np.zeros((cam.pinhole.height, cam.pinhole.width, 3), np.uint8), None
    return RenderResult(rgb, labels, info, linear)
