"""POV-Ray and Mitsuba 3 against our float64 tracer: label images, camera conventions,
determinism, the label values -1/-2, errors. Real renders (small views, 160x120)."""
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import catadioptric as cd
from catadioptric.render import render
from catadioptric.render.common import (RenderError, decode_labels_png, encode_labels_png, load_quality,
                                        load_resolution, rescale_camera)
from catadioptric.render.mitsuba import mitsuba_variant, render_mitsuba
from catadioptric.render.povray import render_povray, run_povray
from catadioptric.render.testscene import street_scene, street_views
from catadioptric.render.tracer import LABEL_MIRROR_AGAIN, LABEL_NO_MIRROR, trace_rays
from catadioptric.rigspec import load_rig
from catadioptric.scenes import build_scene, scene_rig, views

W, H = 160, 120
# at most 0.01 % of the pixels of a view may differ from the tracer: 1 of 19200
MAX_DIFF = int(1e-4 * W * H)


def _views():
    street = street_scene(0)
    out = []
    for rig, i in (("hyperboloid_9pct", 1), ("sphere", 0), ("ellipsoid", 2), ("cone", 1)):
        name, pose = street_views(rig)[i]
        out.append((f"street-{rig}-{name}", street, load_rig(rig, width=W, height=H), pose))
    for spec, v in (("tiny_street", "A"), ("chessboard", "B")):
        s = build_scene(spec)
        out.append((f"{spec}-{v}", s, scene_rig(s.spec, width=W, height=H), dict(views(s.spec))[v]))
    return out


@pytest.fixture(scope="module")
def cases():
    return [(n, s, c, p, trace_rays(s, c, p)) for n, s, c, p in _views()]


@pytest.fixture(scope="module")
def rendered(cases):
    out = {}
    for n, s, c, p, _ in cases:
        out[n, "povray"] = render_povray(s, c, p, "draft", beauty=False).labels
        out[n, "mitsuba"] = render_mitsuba(s, c, p, "draft", beauty=False).labels
    return out


@pytest.mark.parametrize("renderer", ["povray", "mitsuba"])
def test_labels_equal_the_tracer(cases, rendered, renderer):
    for n, s, c, p, tr in cases:
        lab = rendered[n, renderer]
        diff = lab != tr.labels
        assert diff.sum() <= MAX_DIFF, (n, np.argwhere(diff)[:5].tolist())
        # where a renderer differs, the first surface is a tie between two labels (coplanar faces)
        assert not (diff & ~tr.ambiguous).any(), (n, np.argwhere(diff & ~tr.ambiguous)[:5].tolist())
        assert (lab > 0).sum() > 1000 and (lab == LABEL_NO_MIRROR).sum() > 1000, n


def test_renderers_agree(cases, rendered):
    for n, *_ in cases:
        diff = rendered[n, "povray"] != rendered[n, "mitsuba"]
        assert diff.sum() <= MAX_DIFF, (n, np.argwhere(diff)[:5].tolist())


def test_off_centre_principal_point_skew_and_rectangular_pixels():
    # pixel centres are OpenCV's (u, v) = (col, row) in both backends, whatever K
    street = street_scene(0)
    base = load_rig("hyperboloid_9pct", width=W, height=H)
    K = np.array([[150.0, 4.0, 70.3], [0.0, 162.5, 66.8], [0.0, 0.0, 1.0]])
    cam = cd.CatadioptricCamera(base.mirror, cd.PinholeCamera(K, W, H), base.center, base.R_cam_from_mirror)
    pose = street_views("hyperboloid_9pct")[2][1]
    tr = trace_rays(street, cam, pose)
    for fn in (render_povray, render_mitsuba):
        lab = fn(street, cam, pose, "draft", beauty=False).labels
        assert (lab != tr.labels).sum() == 0, fn.__name__


def test_reflected_ray_meeting_the_mirror_again():
    # inside a sphere: POV-Ray counts the mirror hits of each path in the label pass's green channel
    m = cd.QuadricMirror.sphere(0.05, z_min=-0.05, z_max=0.03)
    cam = cd.CatadioptricCamera.looking_at_mirror(m, cd.PinholeCamera.from_fov(80, 60, 100.0), [0.0, 0.01, 0.0],
                                                  target=(0, 0, -0.05))
    pose = cd.RigPose.from_mirror_in_world(np.diag([1.0, -1, -1]), [0, 0, 2.0])
    street = street_scene(0)
    tr = trace_rays(street, cam, pose)
    assert (tr.labels == LABEL_MIRROR_AGAIN).sum() > 500
    for fn in (render_povray, render_mitsuba):
        assert np.array_equal(fn(street, cam, pose, "draft", beauty=False).labels, tr.labels), fn.__name__


def test_beauty_is_deterministic_and_black_off_the_mirror():
    street = street_scene(0)
    cam = load_rig("paraboloid", width=W, height=H)
    pose = street_views("paraboloid")[0][1]
    lab = trace_rays(street, cam, pose, ties=False).labels
    a = render_mitsuba(street, cam, pose, "draft", seed=7)
    b = render_mitsuba(street, cam, pose, "draft", seed=7)
    c = render_mitsuba(street, cam, pose, "draft", seed=8)
    assert np.array_equal(a.beauty, b.beauty) and not np.array_equal(a.beauty, c.beauty)
    p1 = render_povray(street, cam, pose, "standard")
    p2 = render_povray(street, cam, pose, "standard")
    assert np.array_equal(p1.beauty, p2.beauty) and np.array_equal(p1.labels, p2.labels)
    # well inside / outside the mirror's image (3x3 neighbourhoods): black off the mirror, lit on it
    pad = np.pad(lab, 1, mode="edge")
    nb = np.stack([pad[i:i + H, j:j + W] for i in range(3) for j in range(3)])
    off = (nb == LABEL_NO_MIRROR).all(axis=0)
    on = (nb > 0).all(axis=0)
    for img in (a.beauty, p1.beauty):
        assert img.shape == (H, W, 3) and img.dtype == np.uint8
        assert (img[off] == 0).all()
        assert (img[on].max(axis=1) > 0).mean() > 0.99


def test_povray_errors(tmp_path, monkeypatch):
    with pytest.raises(RenderError, match=r"povray: rendering bad.pov failed with exit code 1 \(the whole log: .*bad.log\); "
                                          r"relevant lines of its log:\n(.|\n)*Parse Error(.|\n)*its last lines:\n"):
        run_povray(str(tmp_path), "camera { location <0, 0, -1> }\nsphere { <0, 0, 0>, }\n", "bad", ["+W8", "+H8"])
    slow = "camera { location <0,0,-3> look_at 0 }\nsphere { 0, 1 pigment { granite } finish { reflection 0.5 } }\n"
    with pytest.raises(RenderError, match=r"povray: rendering slow.pov did not finish within timeout=0.01 s"):
        run_povray(str(tmp_path), slow, "slow", ["+W2000", "+H2000", "+A0.0", "+R9"], timeout=0.01)
    monkeypatch.setenv("CATADIOPTRIC_POVRAY", str(tmp_path / "no-such-povray"))
    with pytest.raises(RenderError, match=r"povray: the POV-Ray binary was not found .* apt-get install -y povray"):
        render_povray(street_scene(0), load_rig("sphere", width=W, height=H), street_views("sphere")[0][1])


def _children(pid: int) -> list[int]:
    """Processes whose parent is ``pid`` (Linux /proc)."""
    out = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as f:
                    if int(f.read().rsplit(")", 1)[1].split()[1]) == pid:
                        out.append(int(d))
            except (OSError, IndexError, ValueError):
                pass
    return out


def test_povray_failure_keeps_its_message_not_a_dead_path(monkeypatch, tmp_path):
    """On failure the temporary folder goes, so the message carries the log's relevant and last lines
    instead of pointing to a log that no longer exists."""
    import tempfile

    import catadioptric.render.povray as pov

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    monkeypatch.setattr(pov, "scene_text", lambda *a, **k: "camera { location <0, 0, -1> }\nsphere { <0, 0, 0>, }\n")
    with pytest.raises(RenderError) as e:
        render_povray(street_scene(0), load_rig("sphere", width=W, height=H), street_views("sphere")[0][1], "draft")
    msg = str(e.value)
    assert "Parse Error" in msg and "its last lines:" in msg and pov.TMP_PREFIX not in msg
    assert os.listdir(tmp_path) == []


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc and PR_SET_PDEATHSIG")
@pytest.mark.parametrize("how", ["SIGTERM", "SIGKILL"])
def test_a_killed_render_leaves_no_povray_and_no_folder(tmp_path, how):
    """Killing the process that renders: POV-Ray dies with it (SIGTERM: on the way out, with the
    temporary folder; SIGKILL: by PR_SET_PDEATHSIG, and the next render removes the folder left)."""
    import signal
    import time

    from catadioptric.render.povray import TMP_PREFIX, remove_stale_workdirs

    code = textwrap.dedent("""
        from catadioptric.render.povray import render_povray
        from catadioptric.render.testscene import street_scene, street_views
        from catadioptric.rigspec import load_rig
        render_povray(street_scene(0), load_rig("sphere", width=1600, height=1200), street_views("sphere")[0][1], "high")
    """)
    p = subprocess.Popen([sys.executable, "-c", code], env={**os.environ, "TMPDIR": str(tmp_path)},
                         stderr=subprocess.PIPE)
    t0 = time.time()
    mine = lambda: [n for n in os.listdir(tmp_path) if n.startswith(f"{TMP_PREFIX}{p.pid}-")]  # noqa: E731
    # the label pass runs: the work folder exists and POV-Ray is a child (not `povray --version`)
    while not (mine() and os.listdir(tmp_path / mine()[0]) and _children(p.pid)) and p.poll() is None \
            and time.time() - t0 < 120:
        time.sleep(0.05)
    time.sleep(0.3)
    kids = _children(p.pid)
    assert kids and mine(), p.stderr.read().decode()[-2000:]
    p.send_signal(getattr(signal, how))
    p.wait(timeout=60)
    t0 = time.time()
    while any(os.path.exists(f"/proc/{k}") and open(f"/proc/{k}/stat").read().split()[2] != "Z" for k in kids) \
            and time.time() - t0 < 30:
        time.sleep(0.05)
    assert not [k for k in kids if os.path.exists(f"/proc/{k}") and open(f"/proc/{k}/stat").read().split()[2] != "Z"]
    left = [n for n in os.listdir(tmp_path) if n.startswith(TMP_PREFIX)]
    if how == "SIGTERM":
        assert p.returncode == 128 + signal.SIGTERM and left == []
    else:
        assert len(left) == 1 and remove_stale_workdirs(str(tmp_path)) == [str(tmp_path / left[0])]
        assert os.listdir(tmp_path) == []


def test_bad_inputs():
    street = street_scene(0)
    cam = load_rig("sphere", width=W, height=H)
    pose = street_views("sphere")[0][1]
    with pytest.raises(cd.CatadioptricError, match=r"quality: expected one of \['draft', 'high', 'standard'\] or a "
                                                   r"\.toml file, got 'ultra'"):
        render_mitsuba(street, cam, pose, "ultra")
    with pytest.raises(cd.CatadioptricError, match=r"quality.mitsuba_spp: expected an integer >= 1, got 0"):
        load_quality({"povray_antialias": 0.1, "povray_aa_depth": 2, "mitsuba_spp": 0, "max_depth": 3,
                      "shadows": True})
    with pytest.raises(cd.CatadioptricError, match=r"pose: expected a RigPose \(x_M = R x_W \+ t\), got ndarray"):
        render_povray(street, cam, np.eye(4))
    street.objects[3].color = (1.2, 0.0, 0.0)
    with pytest.raises(cd.CatadioptricError, match=r"scene.objects\[3\].color: expected RGB in \[0, 1\], got "
                                                   r"\(1.2, 0.0, 0.0\)"):
        render_mitsuba(street, cam, pose)
    with pytest.raises(cd.CatadioptricError, match=r"resolution: expected one of .* or WIDTHxHEIGHT \(two positive "
                                                   r"integers, e.g. 640x480\), got 'huge'"):
        load_resolution("huge")
    with pytest.raises(cd.CatadioptricError, match=r"renderer: expected 'mitsuba' or 'povray', got 'blender'"):
        render(street, cam, pose, "blender")


def test_label_png_encoding_and_rescaled_camera():
    lab = np.array([[-2, -1, 0, 1], [7, 300, 65533, 12]], dtype=np.int32)
    png = encode_labels_png(lab)
    assert png.dtype == np.uint16 and png[0, 0] == 65534 and png[0, 1] == 65535
    assert np.array_equal(decode_labels_png(png), lab)
    with pytest.raises(cd.CatadioptricError, match=r"labels: expected values in \[-2, 65533\], got \[0, 65534\]"):
        encode_labels_png(np.array([0, 65534]))
    cam = load_rig("hyperboloid", width=640, height=480)
    small = rescale_camera(cam, 160, 120)
    # the corner of the image and its centre keep their rays
    for uv, uv2 in (([-0.5, -0.5], [-0.5, -0.5]), ([319.5, 239.5], [79.5, 59.5])):
        d1 = cam.pinhole.pixel_rays(np.array(uv))
        d2 = small.pinhole.pixel_rays(np.array(uv2))
        assert np.allclose(d1 / np.linalg.norm(d1), d2 / np.linalg.norm(d2), atol=1e-15)


def test_mitsuba_falls_back_to_scalar_without_a_working_llvm(tmp_path):
    # a libLLVM that cannot load: the probe fails in its subprocess, this one warns and runs scalar_rgb
    code = textwrap.dedent("""
        import warnings, numpy as np
        from catadioptric.render.mitsuba import mitsuba_variant, render_mitsuba
        from catadioptric.render.testscene import street_scene, street_views
        from catadioptric.render.tracer import trace_labels
        from catadioptric.rigspec import load_rig
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            v = mitsuba_variant()
        assert v == "scalar_rgb", v
        assert any("falling back to scalar_rgb" in str(x.message) for x in w), [str(x.message) for x in w]
        s, cam = street_scene(0), load_rig("hyperboloid_9pct", width=24, height=18)
        pose = street_views("hyperboloid_9pct")[0][1]
        q = {"povray_antialias": 0.0, "povray_aa_depth": 1, "mitsuba_spp": 1, "max_depth": 2, "shadows": True}
        r = render_mitsuba(s, cam, pose, q)
        assert (r.labels != trace_labels(s, cam, pose)).sum() == 0
        assert r.beauty.max() > 0
        print("FALLBACK OK")
    """)
    env = {k: v for k, v in os.environ.items() if k != "CATADIOPTRIC_MITSUBA_VARIANT"}
    env["DRJIT_LIBLLVM_PATH"] = str(tmp_path / "libLLVM-missing.so")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert p.returncode == 0 and "FALLBACK OK" in p.stdout, p.stderr[-2000:]


def test_llvm_variant_runs_here():
    # CI installs libllvm19 (tools/install-system-deps.sh): the fast variant must be the one in use
    assert mitsuba_variant() == "llvm_ad_rgb"
