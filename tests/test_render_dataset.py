"""Datasets: files and manifest, resume after corruption or a killed run, process pool and Dask
(LocalCluster) outputs byte-identical to an in-process run, the ``catadioptric render`` command."""
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import cv2
import numpy as np
import pytest

from catadioptric.cli import main
from catadioptric.render.common import RenderError, decode_labels_png
from catadioptric.render.dataset import FILES, render_dataset, view_status
from catadioptric.render.testscene import street_scene, street_views
from catadioptric.render.tracer import trace_labels
from catadioptric.rigspec import load_rig

RIG = "hyperboloid_9pct"
W, H = 96, 72


def _setup():
    return street_scene(0), street_views(RIG), load_rig(RIG, width=W, height=H)


def _differ(a, b):
    """Names of the files that differ between two dataset folders (empty: byte-identical)."""
    fa, fb = _files(a), _files(b)
    return sorted(k for k in set(fa) | set(fb) if fa.get(k) != fb.get(k))


def _files(root):
    """Every file of a dataset folder (relative path -> bytes), the manifest without its run record."""
    out = {}
    for d, _, names in os.walk(root):
        for n in names:
            p = os.path.join(d, n)
            rel = os.path.relpath(p, root)
            with open(p, "rb") as f:
                data = f.read()
            if rel == "manifest.json":
                m = json.loads(data)
                m.pop("run")
                data = json.dumps(m, sort_keys=True).encode()
            out[rel] = data
    return out


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The three views rendered in this process with Mitsuba."""
    scene, views, cam = _setup()
    out = str(tmp_path_factory.mktemp("ref") / "ds")
    m = render_dataset(scene, views, cam, out, renderer="mitsuba", quality="draft", progress=False)
    return out, m


def test_files_manifest_and_labels(reference):
    out, m = reference
    scene, views, cam = _setup()
    assert m["format"] == "catadioptric-dataset/1" and [v["name"] for v in m["views"]] == [n for n, _ in views]
    for key in ("python", "numpy", "mitsuba", "povray", "opencv", "catadioptric"):
        assert m["versions"][key], key
    assert m["versions"]["mitsuba_variant"] == "llvm_ad_rgb"
    assert m["scene"]["seed"] == 0 and m["scene"]["spec"]["generator"].endswith("street_scene")
    assert m["rig"]["camera"] == cam.to_dict() and len(m["commit"] or "") in (0, 40)
    assert m["run"]["rendered"] == ["view_00", "view_01", "view_02"] and m["run"]["skipped"] == []
    assert m["label_agreement"]["differing_pixels"] == 0
    for (name, pose), entry in zip(views, m["views"]):
        folder = os.path.join(out, name)
        assert sorted(os.listdir(folder)) == sorted(FILES + ("done.json",))
        assert view_status(folder, entry["fingerprint"]) == "done"
        lab = decode_labels_png(cv2.imread(os.path.join(folder, "labels.png"), cv2.IMREAD_UNCHANGED))
        assert np.array_equal(lab, trace_labels(scene, cam, pose))
        beauty = cv2.imread(os.path.join(folder, "beauty.png"), cv2.IMREAD_UNCHANGED)
        assert beauty.shape == (H, W, 3) and beauty.dtype == np.uint8
        with open(os.path.join(folder, "groundtruth.json")) as f:
            gt = json.loads(f.read(), parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))
        assert gt["view"] == name and gt["pose"] == pose.to_dict() and gt["renderer"]["variant"] == "llvm_ad_rgb"
        with np.load(os.path.join(folder, "groundtruth.npz")) as z:
            assert z["label_ambiguous"].shape == (H, W) and len(z["line_uv"]) == z["line_curve_offsets"][-1]


def test_rerun_skips_and_resume_redoes_only_broken_views(reference, tmp_path):
    ref, _ = reference
    scene, views, cam = _setup()
    out = str(tmp_path / "ds")
    shutil.copytree(ref, out)
    stamp = {n: os.stat(os.path.join(out, n, "beauty.png")).st_mtime_ns for n, _ in views}
    m = render_dataset(scene, views, cam, out, renderer="mitsuba", quality="draft", progress=False)
    assert m["run"]["rendered"] == [] and m["run"]["skipped"] == ["view_00", "view_01", "view_02"]
    # view_01: a file corrupted; view_02: killed before its marker (a partial temporary file left over)
    with open(os.path.join(out, "view_01", "beauty.png"), "ab") as f:
        f.write(b"\0")
    os.unlink(os.path.join(out, "view_02", "done.json"))
    with open(os.path.join(out, "view_02", ".preview.png.abc123.tmp"), "wb") as f:
        f.write(b"partial")
    m = render_dataset(scene, views, cam, out, renderer="mitsuba", quality="draft", progress=False)
    assert m["run"]["status_before"] == {"view_00": "done", "view_01": "broken", "view_02": "broken"}
    assert m["run"]["rendered"] == ["view_01", "view_02"] and m["run"]["skipped"] == ["view_00"]
    assert os.stat(os.path.join(out, "view_00", "beauty.png")).st_mtime_ns == stamp["view_00"]
    assert _differ(out, ref) == []  # byte-identical to the first run
    # a run on some of the views keeps the others in the manifest (their folders are done)
    m = render_dataset(scene, views[1:2], cam, out, renderer="mitsuba", quality="draft", progress=False)
    assert m["run"]["rendered"] == [] and [e["name"] for e in m["views"]] == ["view_00", "view_01", "view_02"]
    assert _differ(out, ref) == []
    # other parameters: every view is stale and redone; those not asked for leave the manifest
    m = render_dataset(scene, views[:1], cam, out, renderer="mitsuba", quality="standard", progress=False)
    assert m["run"]["status_before"] == {"view_00": "stale"} and m["run"]["rendered"] == ["view_00"]
    assert [e["name"] for e in m["views"]] == ["view_00"]


def test_killed_run_resumes(tmp_path):
    out = str(tmp_path / "ds")
    args = ["render", "builtin:test_street", "--renderer", "povray", "--rig", RIG, "--resolution", f"{W}x{H}",
            "--quality", "draft", "--out", out, "--no-progress"]
    code = f"import sys; from catadioptric.cli import main; sys.exit(main({args!r}))"
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    marker = os.path.join(out, "view_00", "done.json")
    t0 = time.time()
    while not os.path.exists(marker) and p.poll() is None and time.time() - t0 < 120:
        time.sleep(0.02)
    p.send_signal(signal.SIGKILL)
    p.wait()
    assert os.path.exists(marker), p.stderr.read().decode()[-2000:]
    assert main(args) == 0
    with open(os.path.join(out, "manifest.json")) as f:
        m = json.load(f)
    assert "view_00" in m["run"]["skipped"] and "view_02" in m["run"]["rendered"]
    for v in m["views"]:
        assert view_status(os.path.join(out, v["name"]), v["fingerprint"]) == "done"
    assert m["label_agreement"]["differing_pixels"] == 0


def test_process_pool_output_equals_in_process(reference, tmp_path):
    ref, _ = reference
    scene, views, cam = _setup()
    out = str(tmp_path / "ds")
    m = render_dataset(scene, views, cam, out, renderer="mitsuba", quality="draft", workers=2, progress=False)
    assert m["run"]["workers"] == 2 and len(m["run"]["rendered"]) == 3
    assert _differ(out, ref) == []


def test_dask_local_cluster_output_equals_local(reference, tmp_path):
    from dask.distributed import LocalCluster

    ref, _ = reference
    scene, views, cam = _setup()
    out = str(tmp_path / "ds")
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        m = render_dataset(scene, views, cam, out, renderer="mitsuba", quality="draft",
                           scheduler=cluster.scheduler_address, progress=False)
    assert m["run"]["scheduler"] == cluster.scheduler_address and len(m["run"]["rendered"]) == 3
    assert _differ(out, ref) == []


def test_command_on_a_scene_spec(tmp_path, capsys):
    out = str(tmp_path / "ds")
    assert main(["render", "tiny_street", "--out", out, "--resolution", "tiny", "--views", "A", "--quality", "draft",
                 "--line-images", "sampled", "--no-progress"]) == 0
    assert "1 views (1 rendered, 0 already done)" in capsys.readouterr().out
    with open(os.path.join(out, "manifest.json")) as f:
        m = json.load(f)
    assert m["scene"]["name"] == "tiny_street" and m["rig"]["name"] == "hyperboloid"
    assert m["line_images"] == "sampled"
    assert m["rig"]["camera"]["pinhole"]["width"] == 160 and [v["name"] for v in m["views"]] == ["A"]


def test_command_errors(tmp_path, capsys):
    out = str(tmp_path / "ds")
    assert main(["render", "builtin:test_street", "--out", out, "--views", "view_00,nope"]) == 2
    assert "catadioptric: error: --views: expected names among ['view_00', 'view_01', 'view_02'], got unknown " \
           "['nope']" in capsys.readouterr().err
    assert main(["render", "builtin:test_street", "--out", out, "--quality", "ultra"]) == 2
    assert "quality: expected one of ['draft', 'high', 'standard'] or a .toml file, got 'ultra'" in \
           capsys.readouterr().err
    assert main(["render", "no_such_scene", "--out", out]) == 2
    assert "catadioptric: error: SPEC: expected a scene spec file or one of" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["render", "builtin:test_street", "--out", out, "--workers", "0"])
    assert "--workers: expected a positive integer, got '0'" in capsys.readouterr().err
    scene, views, cam = _setup()
    with pytest.raises(ValueError, match=r"views\[0\]: expected a view name of letters, digits, '_', '.', '-' "
                                         r"\(a folder name\), got '../x'"):
        render_dataset(scene, [("../x", views[0][1])], cam, out)
    with pytest.raises(ValueError, match=r"views\[1\]: the view name 'a' is used twice"):
        render_dataset(scene, [("a", views[0][1]), ("a", views[1][1])], cam, out)
    with pytest.raises(ValueError, match=r"renderer: expected one of \['mitsuba', 'povray'\], got 'blender'"):
        render_dataset(scene, views, cam, out, renderer="blender")
    with pytest.raises(ValueError, match=r"line_images: expected one of \['core', 'sampled'\], got 'fast'"):
        render_dataset(scene, views, cam, out, line_images="fast")


# ---------------------------------------------------------------- integrity (issue 12, item 11)
def test_view_names_that_are_the_datasets_own_files(tmp_path):
    scene, views, cam = _setup()
    for bad in ("manifest.json", "Manifest.JSON", "scene.ply"):
        with pytest.raises(ValueError, match=r"views\[1\]: expected a view name other than the dataset's own files "
                                             r"\['manifest.json', 'scene.ply'\] \(in any case\), got " + repr(bad)):
            render_dataset(scene, [views[0], (bad, views[1][1])], cam, str(tmp_path / "ds"))
    with pytest.raises(ValueError, match=r"views\[1\]: the view name 'VIEW_00' is used twice \(folder names are compared"):
        render_dataset(scene, [views[0], ("VIEW_00", views[1][1])], cam, str(tmp_path / "ds"))


def test_rerun_repairs_malformed_markers_swapped_files_and_links(reference, tmp_path):
    """A done.json that is a list or has "files": null, a file replaced by a folder, a view folder
    replaced by a file or by a link to another view's folder: the rerun redoes those views (it
    crashed, or wrote one view into another's folder) and the dataset is byte-identical again."""
    ref, _ = reference
    scene, views, cam = _setup()
    out = str(tmp_path / "ds")
    shutil.copytree(ref, out)
    with open(os.path.join(out, "view_00", "done.json"), "w") as f:
        json.dump([1, 2], f)
    with open(os.path.join(out, "view_01", "done.json")) as f:
        marker = json.load(f)
    with open(os.path.join(out, "view_01", "done.json"), "w") as f:
        json.dump({**marker, "files": None}, f)
    os.unlink(os.path.join(out, "view_01", "preview.png"))
    os.mkdir(os.path.join(out, "view_01", "preview.png"))
    shutil.rmtree(os.path.join(out, "view_02"))
    os.symlink("view_00", os.path.join(out, "view_02"))
    m = render_dataset(scene, views, cam, out, renderer="mitsuba", quality="draft", progress=False)
    assert m["run"]["status_before"] == {"view_00": "broken", "view_01": "broken", "view_02": "broken"}
    assert not os.path.islink(os.path.join(out, "view_02"))
    assert _differ(out, ref) == []
    shutil.rmtree(os.path.join(out, "view_02"))
    with open(os.path.join(out, "view_02"), "w") as f:
        f.write("not a folder")
    with open(os.path.join(out, "view_01", "done.json"), "w") as f:
        json.dump({**marker, "files": {k: 5 for k in marker["files"]}}, f)
    m = render_dataset(scene, views, cam, out, renderer="mitsuba", quality="draft", progress=False)
    assert m["run"]["rendered"] == ["view_01", "view_02"] and _differ(out, ref) == []


def test_a_second_run_on_the_same_folder_stops_at_once(reference, tmp_path):
    from catadioptric.render.dataset import _dataset_lock

    ref, _ = reference
    scene, views, cam = _setup()
    out = str(tmp_path / "ds")
    shutil.copytree(ref, out)
    with _dataset_lock(out):  # (another open file description: as another process would hold it)
        with pytest.raises(ValueError, match=r"out_dir: another run is writing the dataset .* \(it holds .*"
                                             r"\.catadioptric-lock\); wait for it to finish or write to another folder"):
            render_dataset(scene, views, cam, out, renderer="mitsuba", quality="draft", progress=False)
    assert _differ(out, ref) == []


def test_the_mitsuba_variant_is_in_the_fingerprint(reference, tmp_path, monkeypatch):
    """Views rendered with another Mitsuba variant (llvm or the scalar fallback) are stale, and a
    worker running another variant than the fingerprint's refuses the view."""
    import catadioptric.render.dataset as ds

    ref, m0 = reference
    scene, views, cam = _setup()
    out = str(tmp_path / "ds")
    shutil.copytree(ref, out)
    real = ds._versions
    monkeypatch.setattr(ds, "_versions", lambda r: {**real(r), "mitsuba_variant": "scalar_rgb"})
    with pytest.raises(RenderError, match=r"mitsuba: this worker runs the variant 'llvm_ad_rgb', the dataset's "
                                          r"fingerprint says 'scalar_rgb'"):
        render_dataset(scene, views[:1], cam, out, renderer="mitsuba", quality="draft", progress=False)
    monkeypatch.setattr(ds, "_versions", real)
    m = render_dataset(scene, views, cam, out, renderer="mitsuba", quality="draft", progress=False)
    assert m["run"]["status_before"]["view_00"] == "broken" and m["run"]["skipped"] == ["view_01", "view_02"]


def test_a_missing_povray_leaves_no_output_folder(tmp_path, monkeypatch):
    scene, views, cam = _setup()
    monkeypatch.setenv("CATADIOPTRIC_POVRAY", str(tmp_path / "no-such-povray"))
    with pytest.raises(RenderError, match=r"povray: the POV-Ray binary was not found"):
        render_dataset(scene, views, cam, str(tmp_path / "ds"), renderer="povray", progress=False)
    assert not os.path.exists(tmp_path / "ds")


def test_out_folders_that_cannot_be_made_or_hold_a_folder_manifest(tmp_path, capsys):
    """One line naming --out, before any view is rendered (issue 39): a folder the file system
    refuses (/proc, a name over its 255-byte limit) and a dataset whose manifest.json is a folder."""
    def fails(out):
        try:
            code = main(["render", "builtin:test_street", "--out", out, "--views", "view_00", "--resolution", "tiny",
                         "--quality", "draft", "--no-progress"])
        except SystemExit as exc:
            code = exc.code
        err = capsys.readouterr().err
        assert code == 2 and "Traceback" not in err and err.count("\n") == 1, err
        assert err.startswith("catadioptric: error: --out: "), err
        return err.strip()

    fails("/proc/catadioptric-x")
    long = str(tmp_path / ("a" * 300))
    assert fails(long) == f"catadioptric: error: --out: cannot create the folder {long!r} (File name too long)"
    with pytest.raises(ValueError, match=r"out_dir: cannot create the folder '/proc/catadioptric-x' \("):
        render_dataset(*_setup(), "/proc/catadioptric-x")
    ds = tmp_path / "ds"
    (ds / "manifest.json").mkdir(parents=True)
    assert fails(str(ds)) == (f"catadioptric: error: --out: the dataset's file {str(ds / 'manifest.json')!r} is a "
                              f"folder; remove or rename it (the run writes its manifest.json there)")
    assert sorted(os.listdir(ds)) == ["manifest.json"]  # nothing rendered
