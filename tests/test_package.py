"""Packaging facts the README states."""
import subprocess
import sys


def test_import_loads_numpy_and_scipy_only():
    code = ("import sys, catadioptric; heavy = {'matplotlib', 'mitsuba', 'drjit', 'trimesh', 'cv2', 'dask', 'sympy',"
            " 'tqdm', 'distributed'}; print(sorted(heavy & {m.split('.')[0] for m in sys.modules}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "[]"


def test_cli_lists_its_subcommands():
    out = subprocess.run([sys.executable, "-m", "catadioptric.cli", "--help"], capture_output=True, text=True,
                         check=True).stdout
    for cmd in ("demo", "render", "validate", "centrality"):
        assert cmd in out
