"""POV-Ray backend: the exact quadric mirror, camera vectors from K, a beauty pass and an exact label pass.

Everything is written in the world frame W: scene meshes as they are (``mesh2``), the
mirror as POV-Ray's exact ``quadric { <1,1,A>, <0,0,0>, <0,0,B>, -C }`` clipped and
bounded by a box around the patch and moved M -> W by ``matrix`` (``x_W = R^T (x_M - t)``),
the camera by its centre and axes in W. Camera vectors (see render/README.md
and docs/formats.md): ``location C``, ``right x_c W/fx``, ``up -y_c H/fy`` (plus the skew
term), ``direction`` the ray of the image centre, so that POV-Ray's pixel (col, row) is
sampled at the OpenCV pixel centre (u, v) = (col, row).

Scene objects are ``no_image`` (seen only through the mirror) and a black shroud around
the rig that reflected rays do not see stops camera rays that miss the mirror: pixels
outside the mirror are black in the beauty image, as in the Mitsuba backend.

Label pass (exact, one ray per pixel centre, no antialiasing, gamma 1, 16-bit PNG): each
object emits ``rgb <label/65535, 0, 0>``; the mirror has ``reflection 1`` and emits
``rgb <0, 256/65535, 0>``, so that green counts the mirror hits along the pixel's path
(0: the pixel misses the mirror -> -1; 1: the label in red; 2 or more: the reflected ray
met the mirror again -> -2).
"""
from __future__ import annotations

import functools
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np

from .._checks import CatadioptricError
from .common import (AMBIENT, LABEL_MIRROR_AGAIN, LABEL_NO_MIRROR, MAX_LABEL, RenderError, RenderResult, check_view,
                     load_quality, sky_radiance)

__all__ = ["render_povray", "run_povray", "povray_version", "povray_binary", "scene_text", "mesh2_text",
           "camera_vectors", "decode_label_pass", "remove_stale_workdirs"]

_HIT = 256  # green step per mirror hit in the 16-bit label pass


def povray_binary() -> str:
    """Path of the ``povray`` executable (``$CATADIOPTRIC_POVRAY`` or ``povray`` on PATH)."""
    exe = os.environ.get("CATADIOPTRIC_POVRAY") or shutil.which("povray")
    if not exe or not os.access(exe, os.X_OK):
        raise RenderError("povray: the POV-Ray binary was not found (looked for $CATADIOPTRIC_POVRAY and "
                          "'povray' on PATH); install it with `sudo apt-get install -y povray` "
                          "(tools/install-system-deps.sh does it), or use --renderer mitsuba")
    return exe


@functools.lru_cache(maxsize=4)
def _version_of(exe: str) -> str | None:
    try:
        out = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return None
    for line in (out.stdout + out.stderr).splitlines():
        if line.startswith("POV-Ray "):
            return line.split()[1]
    return None


def povray_version() -> str | None:
    """POV-Ray's version string (None when it is not installed)."""
    try:
        return _version_of(povray_binary())
    except RenderError:
        return None


# --------------------------------------------------------------------- writers
def _f(x) -> str:
    """A float as POV-Ray reads it: Python's shortest round-trip repr of a finite float."""
    x = float(x)
    if not np.isfinite(x):
        raise CatadioptricError(f"povray: cannot write the non-finite number {x!r}")
    return repr(x)


def _vec(v) -> str:
    return "<" + ", ".join(_f(x) for x in v) + ">"


def mesh2_text(vertices, faces, body: str) -> str:
    """A ``mesh2`` object (vertices as plain floats, faces as integers) with ``body`` appended."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if not np.isfinite(v).all():
        bad = np.argwhere(~np.isfinite(v))[0]
        raise CatadioptricError(f"vertices: expected finite values, got {v[tuple(bad)]!r} at index {tuple(bad)}")
    vs = ",\n".join("<%r, %r, %r>" % tuple(row) for row in v.tolist())
    fs = ",\n".join("<%d, %d, %d>" % tuple(row) for row in f.tolist())
    return (f"mesh2 {{\n vertex_vectors {{ {len(v)},\n{vs}\n }}\n face_indices {{ {len(f)},\n{fs}\n }}\n"
            f" {body}\n}}\n")


def _patch_radius(m) -> float:
    zs = [m.z_min, m.z_max]
    if m.A != 0 and m.z_min < -m.B / (2 * m.A) < m.z_max:
        zs.append(-m.B / (2 * m.A))
    return float(np.sqrt(max(max(float(m.radius_squared(z)) for z in zs), 0.0)))


def camera_vectors(cam, pose) -> dict:
    """POV-Ray camera vectors in W for the rig ``cam`` placed by ``pose`` (pixel centres at OpenCV (col, row))."""
    p = cam.pinhole
    K = p.K
    fx, s, cx, fy, cy = K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]
    W, H = p.width, p.height
    Rw = pose.R.T  # M -> W for directions
    x_c, y_c, z_c = (Rw @ cam.R_cam_from_mirror[i] for i in range(3))
    # ray(u, v) = x_c ((u - cx)/fx - s (v - cy)/(fx fy)) + y_c (v - cy)/fy + z_c, with
    # u = W x_s - 0.5 and v = H y_s - 0.5 for POV-Ray's screen coordinates x_s, y_s in [0, 1] (y_s down)
    du = ((W - 1) / 2 - cx) / fx - s * ((H - 1) / 2 - cy) / (fx * fy)
    dv = ((H - 1) / 2 - cy) / fy
    return {
        "location": pose.to_world(cam.center),
        "right": x_c * (W / fx),
        "up": -(y_c * (H / fy) - x_c * (s * H / (fx * fy))),
        "direction": z_c + x_c * du + y_c * dv,
    }


def scene_text(scene, cam, pose, quality: dict, labels: bool) -> str:
    """The whole ``.pov`` text of the beauty pass (``labels=False``) or the label pass."""
    m = cam.mirror
    R = pose.R
    org = pose.origin_in_world
    cv = camera_vectors(cam, pose)
    out = ["#version 3.7;\n"]
    if labels:
        out.append("global_settings { assumed_gamma 1.0 max_trace_level 4 adc_bailout 0 }\n"
                   "background { rgb 0 }\n")
    else:
        amb = sky_radiance(0.35)
        out.append(f"global_settings {{ assumed_gamma 1.0 max_trace_level {quality['max_depth']} "
                   f"ambient_light rgb {_vec(amb)} }}\n")
        # sky in W (z up): a colour map over 0.5 + 0.5 sin(elevation)
        stops = np.concatenate([[0.0, 0.4999], 0.5 + 0.5 * np.linspace(0, 1, 21) ** 2])
        cols = [sky_radiance(-1.0)] * 2 + [sky_radiance(2 * v - 1) for v in stops[2:]]
        cmap = " ".join(f"[{_f(v)} rgb {_vec(c)}]" for v, c in zip(stops, cols))
        out.append(f"sky_sphere {{ pigment {{ function {{ 0.5 + 0.5 * z }} color_map {{ {cmap} }} }} }}\n")
        sun = np.asarray(scene.sun, float)
        sun = sun / np.linalg.norm(sun)
        shadow = "" if quality["shadows"] else " shadowless"
        out.append(f"light_source {{ {_vec(org + 1e5 * sun)} color rgb 1 parallel point_at {_vec(org)}{shadow} }}\n")
    out.append("camera {{ perspective location {location} right {right} up {up} direction {direction} }}\n".format(
        **{k: _vec(v) for k, v in cv.items()}))
    # the mirror, M -> W: x_W = R^T x_M - R^T t; POV-Ray's matrix maps row vectors p -> p M + T
    r = _patch_radius(m) * 1.001 + 1e-9 * m.scale
    mat = ", ".join(_f(x) for x in list(R.reshape(-1)) + list(org))
    if labels:
        mfin = (f"pigment {{ rgb <0, {_HIT}/65535, 0> }} "
                "finish { ambient 0 diffuse 0 specular 0 emission 1 reflection { 1 } }")
    else:
        mfin = "pigment { rgb 0 } finish { ambient 0 diffuse 0 specular 0 reflection { 1 } }"
    box = f"box {{ <{_f(-r)}, {_f(-r)}, {_f(m.z_min)}>, <{_f(r)}, {_f(r)}, {_f(m.z_max)}> }}"
    out.append(f"quadric {{ <1, 1, {_f(m.A)}>, <0, 0, 0>, <0, 0, {_f(m.B)}>, {_f(-m.C)}\n"
               f"  clipped_by {{ {box} }} bounded_by {{ {box} }}\n  {mfin} no_shadow\n"
               f"  matrix <{mat}>\n}}\n")
    # shroud: camera rays that miss the mirror end on black; reflected rays and light ignore it
    far = np.linalg.norm(cam.center) + m.scale * 4 + 1.0
    out.append(f"sphere {{ {_vec(cv['location'])}, {_f(4 * far)} pigment {{ rgb 0 }} "
               "finish { ambient 0 diffuse 0 specular 0 emission 0 } no_reflection no_shadow }\n")
    for obj in scene.objects:
        if labels:
            body = (f"pigment {{ rgb <{int(obj.label)}/65535, 0, 0> }} "
                    "finish { ambient 0 diffuse 0 specular 0 emission 1 } no_image")
        else:
            body = (f"pigment {{ rgb {_vec(obj.color)} }} finish {{ ambient {_f(AMBIENT)} diffuse 0.75 "
                    "specular 0 } no_image")
        if len(obj.faces):
            out.append(f"// {int(obj.label)}\n")
            out.append(mesh2_text(obj.vertices, obj.faces, body))
    return "".join(out)


# ---------------------------------------------------------------------- running
def _error_lines(log: str, limit: int = 25) -> str:
    keys = ("error", "Error", "File:", "Line:", "Parse", "Fatal", "Possible", "Unable", "cannot", "denied")
    lines = [ln for ln in log.splitlines() if any(k in ln for k in keys) and "povray.conf" not in ln]
    if not lines:
        lines = [ln for ln in log.splitlines() if ln.strip()][-limit:]
    return "\n".join(lines[-limit:])


# Linux: the child gets SIGKILL when the thread that started it dies (however it dies: a killed CLI
# leaves no POV-Ray running): PR_SET_PDEATHSIG, set by a small program that then becomes POV-Ray (the
# setting survives the exec). Not by a preexec_fn: that makes subprocess fork() instead of vfork(),
# and fork() runs OpenBLAS's fork handler, which waits for a BLAS call running in another thread (the
# ground truth computed beside the render) and never returns: the render hung. A parent that died
# before the setting (the small program's start-up) has left it to init: then it does not start POV-Ray.
_DIE_WITH_PARENT = ("import ctypes, os, signal, sys; ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL); "
                    "os.getppid() == int(sys.argv[1]) or os._exit(128 + signal.SIGKILL); "
                    "os.execvp(sys.argv[2], sys.argv[2:])")


def _die_with_parent(cmd: list[str]) -> list[str]:
    """``cmd`` run so that it dies with the thread that started it (Linux; elsewhere ``cmd``)."""
    if not sys.platform.startswith("linux"):
        return cmd
    return [sys.executable, "-I", "-S", "-c", _DIE_WITH_PARENT, str(os.getpid()), *cmd]


class _TermAsExit:
    """While POV-Ray runs in the main thread, SIGTERM (and SIGHUP) raise SystemExit instead of ending
    the process at once, so that the child is killed and the temporary folder removed on the way
    out (an application's own handlers are left alone)."""

    SIGNALS = tuple(getattr(signal, n) for n in ("SIGTERM", "SIGHUP") if hasattr(signal, n))

    def __enter__(self):
        self.old = {}
        if threading.current_thread() is threading.main_thread():
            for sig in self.SIGNALS:
                if signal.getsignal(sig) in (signal.SIG_DFL, None):
                    self.old[sig] = signal.signal(sig, self._raise)
        return self

    @staticmethod
    def _raise(signum, _frame):
        raise SystemExit(128 + signum)

    def __exit__(self, *exc):
        for sig, h in self.old.items():
            signal.signal(sig, h)
        return False


def run_povray(workdir: str, pov_text: str, name: str, args: list[str], timeout: float = 600.0,
               keep_log: bool = True) -> tuple[str, float]:
    """Write ``name.pov`` in ``workdir``, render it to ``name.png`` with ``args``; return the PNG's
    path and the seconds taken. The log goes to ``name.log``; on failure a :class:`RenderError`
    shows its relevant lines and its last lines (and its path when ``keep_log``: the folder stays).

    POV-Ray runs in its own process group and, on Linux, dies with the thread that started it;
    an exception here (a timeout, Ctrl-C, SIGTERM in the main thread) kills it."""
    exe = povray_binary()
    with open(os.path.join(workdir, name + ".pov"), "w") as f:
        f.write(pov_text)
    cmd = [exe, f"+I{name}.pov", f"+O{name}.png", "-D", "-P", "+V"] + list(args)
    t0 = time.perf_counter()
    try:
        with _TermAsExit():
            proc = subprocess.run(_die_with_parent(cmd), cwd=workdir, capture_output=True, text=True,
                                  timeout=timeout, env={**os.environ, "HOME": workdir}, start_new_session=True)
    except subprocess.TimeoutExpired:
        raise RenderError(f"povray: rendering {name}.pov did not finish within timeout={timeout!r} s "
                          f"(command: {' '.join(cmd)})") from None
    log = proc.stdout + proc.stderr
    with open(os.path.join(workdir, name + ".log"), "w") as f:
        f.write(log)
    out = os.path.join(workdir, name + ".png")
    if proc.returncode != 0 or not os.path.exists(out):
        where = f" (the whole log: {os.path.join(workdir, name + '.log')})" if keep_log else ""
        tail = "\n".join([ln for ln in log.splitlines() if ln.strip()][-10:])
        raise RenderError(f"povray: rendering {name}.pov failed with exit code {proc.returncode}{where}; "
                          f"relevant lines of its log:\n{_error_lines(log)}\nits last lines:\n{tail}")
    return out, time.perf_counter() - t0


TMP_PREFIX = "catadioptric-povray-"


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def remove_stale_workdirs(root: str | None = None) -> list[str]:
    """Remove the temporary folders ``catadioptric-povray-<pid>-*`` of processes that no longer run
    (a render killed by SIGKILL cannot remove its own); returns the removed paths."""
    root = root or tempfile.gettempdir()
    removed = []
    try:
        names = os.listdir(root)
    except OSError:
        return removed
    for n in names:
        if not n.startswith(TMP_PREFIX):
            continue
        pid = n[len(TMP_PREFIX):].split("-", 1)[0]
        if pid.isdigit() and int(pid) != os.getpid() and not _pid_alive(int(pid)):
            shutil.rmtree(os.path.join(root, n), ignore_errors=True)
            removed.append(os.path.join(root, n))
    return removed


def decode_label_pass(img16: np.ndarray, known_labels) -> np.ndarray:
    """The 16-bit BGR label pass -> int32 labels (see the module docstring)."""
    red = img16[..., 2].astype(np.int64)
    green = img16[..., 1].astype(np.int64)
    hits, rem = np.divmod(green, _HIT)
    bad = (rem != 0) | (img16[..., 0] != 0)
    known = np.zeros(MAX_LABEL + 2, bool)
    known[np.asarray(list(known_labels), dtype=np.int64)] = True
    known[0] = True
    bad |= (hits == 1) & ~known[np.minimum(red, MAX_LABEL + 1)]
    if np.any(bad):
        r, c = np.argwhere(bad)[0]
        raise RenderError(f"povray: the label pass holds {int(bad.sum())} pixels that encode no label "
                          f"(first at row {r}, col {c}: BGR {img16[r, c].tolist()}); colours were blended")
    return np.where(hits == 0, LABEL_NO_MIRROR, np.where(hits == 1, red, LABEL_MIRROR_AGAIN)).astype(np.int32)


def render_povray(scene, cam, pose, quality="standard", *, beauty: bool = True, timeout: float = 600.0,
                  threads: int | None = None, keep_dir: str | None = None):
    """Render a view with POV-Ray: beauty RGB uint8 ``(H, W, 3)`` and labels int32 ``(H, W)``.

    ``keep_dir``: write the ``.pov`` files, PNGs and logs there instead of a temporary folder."""
    import cv2

    check_view(scene, cam, pose)
    q = load_quality(quality)
    povray_binary()
    W, H = cam.pinhole.width, cam.pinhole.height
    common = [f"+W{W}", f"+H{H}", "-J"]
    if threads:
        common.append(f"+WT{int(threads)}")
    info = {"renderer": "povray", "povray": povray_version(), "quality": q}
    if keep_dir is None:
        remove_stale_workdirs()
    ctx = tempfile.TemporaryDirectory(prefix=f"{TMP_PREFIX}{os.getpid()}-") if keep_dir is None else None
    workdir = ctx.name if ctx else keep_dir
    os.makedirs(workdir, exist_ok=True)
    keep = keep_dir is not None
    try:
        png, dt = run_povray(workdir, scene_text(scene, cam, pose, q, labels=True), "labels",
                             common + ["-A", "+FN16", "File_Gamma=1.0", "Output_Alpha=off"], timeout, keep)
        img = cv2.imread(png, cv2.IMREAD_UNCHANGED)
        if img is None or img.dtype != np.uint16 or img.shape != (H, W, 3):
            raise RenderError(f"povray: the label pass wrote an unexpected image {png!r} "
                              f"({None if img is None else (img.dtype, img.shape)}), expected 16-bit {H}x{W} RGB")
        labels = decode_label_pass(img, scene.labels)
        info["seconds_labels"] = dt
        if beauty:
            aa = (["+A" + _f(q["povray_antialias"]), "+AM2", f"+R{q['povray_aa_depth']}"]
                  if q["povray_antialias"] > 0 else ["-A"])
            png, dt = run_povray(workdir, scene_text(scene, cam, pose, q, labels=False), "beauty",
                                 common + aa + ["+FN8", "File_Gamma=sRGB", "Output_Alpha=off"], timeout, keep)
            img = cv2.imread(png, cv2.IMREAD_COLOR)
            if img is None or img.shape != (H, W, 3):
                raise RenderError(f"povray: the beauty pass wrote an unexpected image {png!r}")
            rgb = np.ascontiguousarray(img[..., ::-1])
            info["seconds_beauty"] = dt
        else:
            rgb = np.zeros((H, W, 3), np.uint8)
    finally:
        if ctx:
            ctx.cleanup()
    return RenderResult(rgb, labels, info)
