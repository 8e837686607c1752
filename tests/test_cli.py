"""The command line: one meaning of --rig, errors in one line naming the flag (no traceback),
--version, defaults that never overwrite committed reports, missing extras named."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

import catadioptric
from catadioptric.cli import build_parser, main
from catadioptric.rigspec import RIG_DIR
from cli_errors import fails

ROOT = Path(__file__).resolve().parents[1]
RIG_FILE = str(RIG_DIR / "hyperboloid_9pct.toml")


def test_version(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    assert capsys.readouterr().out.strip() == f"catadioptric {catadioptric.__version__}"


def test_rigs_is_an_attribute_of_the_package():
    code = "import catadioptric; print(catadioptric.rigs.preset('sphere').mirror.kind)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "sphere"


@pytest.mark.parametrize("argv", [
    ["render", "tiny_street", "--out", "OUT"],
    ["centrality", "--out", "OUT"],
    ["demo", "--geometry", "--out", "OUT"],
    ["export", "--format", "opencv"],
])
def test_every_rig_flag_takes_a_name_or_a_file_and_names_the_flag(argv, capsys, tmp_path):
    argv = [str(tmp_path / "o") if a == "OUT" else a for a in argv]
    line = fails(argv + ["--rig", "no_such_rig"], capsys)
    assert line.startswith("catadioptric: error: --rig: expected a rig spec file or one of ['cone',")
    assert line.endswith("got 'no_such_rig'")
    line = fails(argv + ["--rig", str(tmp_path / "missing.toml")], capsys)
    assert line.startswith("catadioptric: error: --rig: no rig spec file at ")
    bad = tmp_path / "bad.toml"
    bad.write_text('[mirror]\nkind = "sphere"\nradius = -1\nz_min = 0\nz_max = 1\n[camera]\nfov_x_deg = 40\n'
                   'center = [0, 0, 1]\n')
    line = fails(argv + ["--rig", str(bad)], capsys)
    assert line == "catadioptric: error: --rig: rig.mirror.radius: expected a positive number, got -1"
    # and the file is accepted where the name is (parsing; the runs are tested elsewhere)
    args = build_parser().parse_args(argv + ["--rig", RIG_FILE])
    assert args.rig == RIG_FILE


def test_centrality_and_geometry_demo_accept_a_rig_file(tmp_path, capsys):
    out = tmp_path / "geo"
    assert main(["demo", "--geometry", "--rig", RIG_FILE, "--out", str(out)]) == 0
    assert (out / "line_images.png").is_file()
    assert main(["centrality", "--rig", RIG_FILE, "--out", str(tmp_path / "c"), "--width", "64", "--height", "48",
                 "--step", "4", "--fit-step", "4", "--n-directions", "4"]) == 0
    assert "rig " + RIG_FILE in capsys.readouterr().out


@pytest.mark.parametrize("argv, flag, expected", [
    (["centrality", "--width", "0"], "--width", "expected a positive integer, got '0'"),
    (["centrality", "--step", "x"], "--step", "expected a positive integer, got 'x'"),
    (["centrality", "--n-directions", "-3"], "--n-directions", "expected an integer >= 0, got '-3'"),
    (["demo", "--noise", "-1"], "--noise", "expected a number >= 0, got '-1'"),
    (["demo", "--noise", "nan"], "--noise", "expected a number >= 0, got 'nan'"),
    (["render", "tiny_street", "--out", "OUT", "--seed", "-1"], "--seed", "expected an integer >= 0, got '-1'"),
    (["render", "tiny_street", "--out", "OUT", "--workers", "0"], "--workers", "expected a positive integer, got '0'"),
])
def test_numeric_flags_are_checked_in_one_line(argv, flag, expected, capsys, tmp_path):
    argv = [str(tmp_path / "o") if a == "OUT" else a for a in argv]
    assert fails(argv, capsys) == f"catadioptric: error: {flag}: {expected}"


def test_defaults_never_overwrite_committed_reports():
    p = build_parser()
    assert p.parse_args(["centrality"]).out == "out/centrality"
    assert p.parse_args(["demo"]).out == "out/demo"
    ignored = (ROOT / ".gitignore").read_text().split()
    assert "/out/" in ignored


@pytest.mark.parametrize("value", ["80x60x3", "x60", "80x", "640 x 480", "-640x480", "huge"])
def test_resolution_forms(value, capsys, tmp_path):
    line = fails(["render", "tiny_street", "--out", str(tmp_path / "o"), f"--resolution={value}"], capsys)
    assert line == ("catadioptric: error: --resolution: expected one of ['hd', 'small', 'tiny', 'vga'] or "
                    f"WIDTHxHEIGHT (two positive integers, e.g. 640x480), got {value!r}")
    assert not (tmp_path / "o").exists()


def test_resolution_too_large_is_refused_before_rendering(capsys, tmp_path):
    line = fails(["render", "tiny_street", "--out", str(tmp_path / "o"), "--resolution", "16384x16384"], capsys)
    assert line == ("catadioptric: error: --resolution: expected at most 16777216 pixels (4096x4096; a view takes "
                    "about 200 bytes of memory per pixel), got 16384x16384 = 268435456")
    assert not (tmp_path / "o").exists()
    line = fails(["demo", "--out", str(tmp_path / "d"), "--resolution", "4097x4096"], capsys)
    assert "--resolution: expected at most 16777216 pixels" in line
    assert not (tmp_path / "d").exists()


def test_out_that_cannot_be_a_folder(capsys, tmp_path):
    f = tmp_path / "a_file"
    f.write_text("x")
    for cmd in (["render", "tiny_street", "--views", "A"], ["centrality"], ["demo", "--geometry"]):
        assert fails(cmd + ["--out", str(f)], capsys) == f"catadioptric: error: --out: expected a folder, got the file {str(f)!r}"
        assert fails(cmd + ["--out", str(f / "sub")], capsys) == (
            f"catadioptric: error: --out: expected a folder, got {str(f / 'sub')!r}, which lies under the file {str(f)!r}")
        assert fails(cmd + ["--out", ""], capsys) == "catadioptric: error: --out: expected a folder path, got ''"
    assert f.read_text() == "x"


def test_out_unwritable(capsys, tmp_path):
    if os.geteuid() == 0:  # root writes anywhere the file system allows: use a read-only one
        parent = Path("/proc/sys")
        assert not os.access(parent, os.W_OK)
    else:
        parent = tmp_path / "ro"
        parent.mkdir()
        parent.chmod(0o500)
    target = parent / "catadioptric-out"
    line = fails(["render", "tiny_street", "--views", "A", "--out", str(target)], capsys)
    assert line == (f"catadioptric: error: --out: expected a writable folder, got {str(target)!r} (cannot write "
                    f"in the folder {str(parent)!r} that would hold it)")


def test_scheduler_fails_fast(capsys, tmp_path):
    out = str(tmp_path / "o")
    line = fails(["render", "tiny_street", "--out", out, "--resolution", "tiny", "--scheduler", "hello"], capsys)
    assert line.startswith("catadioptric: error: --scheduler: cannot resolve the host 'hello' of 'hello' (")
    # a port on this machine that nobody listens on: bind one, keep it closed to connections
    import socket

    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    line = fails(["render", "tiny_street", "--out", out, "--resolution", "tiny", "--scheduler",
                   f"tcp://127.0.0.1:{port}"], capsys)
    assert line.startswith(f"catadioptric: error: --scheduler: cannot reach a Dask scheduler at "
                           f"'tcp://127.0.0.1:{port}' (")
    line = fails(["render", "tiny_street", "--out", out, "--scheduler", "tcp://127.0.0.1:99999"], capsys)
    assert line == "catadioptric: error: --scheduler: expected a port number in 1..65535 in 'tcp://127.0.0.1:99999', got '99999'"
    assert not os.path.exists(out)


def test_unavailable_mitsuba_variant_is_one_line(tmp_path):
    import mitsuba

    gpu = [v for v in mitsuba.variants() if v.startswith("cuda_")]
    assert gpu, "this mitsuba build has no cuda variant to try"
    env = dict(os.environ, CATADIOPTRIC_MITSUBA_VARIANT=gpu[0])
    p = subprocess.run([sys.executable, "-m", "catadioptric.cli", "render", "tiny_street", "--out",
                        str(tmp_path / "o"), "--resolution", "tiny", "--views", "A", "--no-progress"],
                       capture_output=True, text=True, env=env, timeout=300)
    assert p.returncode == 2, p.stderr
    assert "Traceback" not in p.stderr
    assert p.stderr.strip().startswith(f"catadioptric: error: CATADIOPTRIC_MITSUBA_VARIANT: the Mitsuba variant "
                                       f"{gpu[0]!r} does not run here (")
    assert len(p.stderr.strip().splitlines()) == 1


# a process in which an optional dependency cannot be imported, as when its extra is not installed
_WITHOUT = "import sys; sys.modules[{mod!r}] = None; from catadioptric.cli import main; sys.exit(main({argv!r}))"


@pytest.mark.parametrize("argv", [["centrality", "--width", "64", "--height", "48"], ["demo", "--geometry"]])
def test_missing_plot_extra_is_one_line_and_writes_nothing(argv, tmp_path):
    out = tmp_path / "o"
    code = _WITHOUT.format(mod="matplotlib", argv=argv + ["--out", str(out)])
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert p.returncode == 2, p.stderr
    assert "Traceback" not in p.stderr
    line = p.stderr.strip()
    assert line.startswith("catadioptric: error: ") and "\n" not in line
    assert line.endswith("needs matplotlib (extra 'plot'): pip install 'catadioptric[plot]'")
    assert not out.exists() or not any(out.iterdir())


def test_missing_extra_anywhere_in_a_command_is_named(tmp_path):
    """A missing module met deep inside a subcommand (here OpenCV in the renderer) is still one line."""
    code = _WITHOUT.format(mod="cv2", argv=["render", "tiny_street", "--out", str(tmp_path / "o"), "--resolution",
                                            "tiny", "--views", "A", "--renderer", "povray", "--no-progress"])
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert p.returncode == 2, p.stderr
    assert p.stderr.strip() == ("catadioptric: error: opencv-contrib-python-headless is not installed (extra "
                                "'opencv'): pip install 'catadioptric[opencv]'")


# ---------------------------------------------------------------- issue 39: IMAGE arguments that are not images
@pytest.mark.parametrize("kind", ["1-D npy", "folder", "device", "empty file", "missing"])
@pytest.mark.parametrize("command", ["detect", "relative-pose"])
def test_an_image_that_is_not_one_is_named_for_what_it_is(kind, command, capsys, tmp_path):
    import numpy as np

    if kind == "1-D npy":
        path = str(tmp_path / "x.npy")
        np.save(path, np.zeros(10))
        expected = (f"IMAGE: expected an image array of shape (H, W) or (H, W, 3), got {path!r}, an array of shape "
                    f"(10,), which is not an image")
    elif kind == "folder":
        path = str(tmp_path / "d")
        os.mkdir(path)
        expected = (f"IMAGE: expected an image file, got the folder {path!r}" if command == "relative-pose" else
                    f"IMAGE: expected an image file, a dataset view folder or a dataset folder, got the folder "
                    f"{path!r} (no manifest.json in it or its parent)")
    elif kind == "device":
        path = "/dev/null"
        expected = f"IMAGE: expected an image file, got {path!r}, which is not a regular file (a device, a pipe or a socket)"
    elif kind == "empty file":
        path = str(tmp_path / "e.png")
        open(path, "w").close()
        expected = f"IMAGE: expected an image file, got {path!r}, an empty file"
    else:
        path = str(tmp_path / "none.png")
        expected = f"IMAGE: expected an image file, a dataset view folder or a dataset folder, got {path!r}, which does not exist"
    images = [path] if command == "detect" else [path, path]
    line = fails([command, *images, "--rig", "hyperboloid", "--out", str(tmp_path / "o")], capsys)
    assert line == "catadioptric: error: " + expected
    assert not (tmp_path / "o").exists()


def test_an_out_folder_the_system_refuses_is_one_line_before_any_work(tmp_path, capsys):
    from catadioptric._checks import CatadioptricError
    from catadioptric.cliargs import check_out_dir

    with pytest.raises(CatadioptricError, match=r"^--out: cannot create the folder .*\(File name too long\)$"):
        check_out_dir(str(tmp_path / ("a" * 300)))
    # a folder that can be made is left as it was (not made by the check)
    assert check_out_dir(str(tmp_path / "new" / "deeper")) and not (tmp_path / "new").exists()
