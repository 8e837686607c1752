"""Installable anywhere: a wheel built from this checkout, installed with its extras into a fresh
virtual environment outside the checkout, runs the README's main job on a small size.

The main job is the command of the Makefile's ``demo`` target (what ``make demo`` runs, the
README's first command), read from the Makefile so that this test follows it; ``SMALL`` is what
makes it small and ``EXTRAS`` what it needs installed: the two places to change with it.
"""
import os
import re
import shlex
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXTRAS = "mitsuba,plot"                            # pip install 'catadioptric[EXTRAS]'
SMALL = ["--resolution", "small"]                  # appended to the main job: 320x240
PACKAGE_DATA = ["catadioptric/py.typed", "catadioptric/data/quality.toml", "catadioptric/data/resolution.toml",
                "catadioptric/data/rigs/hyperboloid.toml", "catadioptric/data/scenes/urban_street.toml"]


def main_job_args(out: str) -> list[str]:
    """The arguments of ``catadioptric`` in the Makefile's ``demo`` target, its ``--out`` set to ``out``."""
    text = (ROOT / "Makefile").read_text()
    block = re.search(r"^demo:.*\n((?:\t.*\n)+)", text, re.M)
    assert block, "the Makefile has no demo target"
    line = next(ln for ln in block.group(1).splitlines() if "bin/catadioptric " in ln)
    args = shlex.split(line.split("bin/catadioptric ", 1)[1])
    if "--out" in args:
        i = args.index("--out")
        del args[i:i + 2]
    return args + ["--out", out] + SMALL


def _run(cmd, cwd, env, timeout):
    p = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert p.returncode == 0, f"{cmd} failed ({p.returncode}):\n{p.stdout[-3000:]}\n{p.stderr[-3000:]}"
    return p


@pytest.mark.slow
def test_wheel_in_a_fresh_venv_runs_the_main_job(tmp_path_factory):
    work = tmp_path_factory.mktemp("install")  # outside the checkout
    assert ROOT not in work.parents
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}
    wheels = work / "wheels"
    _run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", str(wheels), str(ROOT)], work, env, 600)
    [wheel] = wheels.glob("catadioptric-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    assert set(PACKAGE_DATA) <= names, sorted(set(PACKAGE_DATA) - names)
    venv = work / "venv"
    _run([sys.executable, "-m", "venv", str(venv)], work, env, 300)
    py = str(venv / "bin" / "python")
    # --no-compile: the installed packages' sources are not all byte-compiled up front (measured: the
    # install's 24 s of CPU -> 12 s, the main job's +3 s); what the main job imports is compiled as imported
    _run([py, "-m", "pip", "install", "--quiet", "--no-compile", "--disable-pip-version-check", f"{wheel}[{EXTRAS}]"],
         work, env, 900)
    # the venv's package, not the checkout
    where = _run([py, "-c", "import catadioptric, cv2; print(catadioptric.__file__); print(hasattr(cv2, 'omnidir'))"],
                 work, env, 120).stdout.split()
    assert str(venv) in where[0] and str(ROOT) not in where[0] and where[1] == "True"
    exe = str(venv / "bin" / "catadioptric")
    out = work / "main-job"
    p = _run([exe] + main_job_args(str(out)), work, env, 900)
    assert "Traceback" not in p.stderr
    written = sorted(str(q.relative_to(out)) for q in out.rglob("*") if q.is_file())
    assert any(w.endswith("manifest.json") for w in written), written
    assert any(w.endswith("report.md") for w in written), written
