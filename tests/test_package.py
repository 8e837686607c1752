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


def test_license_citation_and_extras_agree_with_pyproject():
    import tomllib
    from pathlib import Path

    import yaml

    from catadioptric._extras import EXTRAS

    root = Path(__file__).resolve().parents[1]
    meta = tomllib.loads((root / "pyproject.toml").read_text())["project"]
    assert meta["license"] == {"text": "BSD-3-Clause"}
    assert "BSD 3-Clause License" in (root / "LICENSE").read_text()
    assert "the catadioptric developers" in (root / "LICENSE").read_text()
    cff = yaml.safe_load((root / "CITATION.cff").read_text())
    assert cff["cff-version"] == "1.2.0" and cff["license"] == "BSD-3-Clause"
    assert cff["authors"] == [{"name": "the catadioptric developers"}]
    import catadioptric

    assert cff["version"] == catadioptric.__version__
    paper = cff["references"][0]
    assert paper["title"] == "Analytical Modeling of Vanishing Points and Curves in Catadioptric Cameras"
    assert [a["family-names"] for a in paper["authors"]] == ["Miraldo", "Eiras", "Ramalingam"] and paper["year"] == 2018
    assert (root / "catadioptric" / "py.typed").is_file()
    # every extra a missing-module message names exists, and brings that package
    extras = meta["optional-dependencies"]
    def brings(extra):  # the packages an extra installs, its self-references expanded
        out = set()
        for d in extras[extra]:
            if d.startswith("catadioptric["):
                for e in d[len("catadioptric["):-1].split(","):
                    out |= brings(e)
            else:
                out.add(d.split(">")[0].split("[")[0])
        return out

    for module, (package, extra) in EXTRAS.items():
        assert extra in extras, (module, extra)
        assert package.split("[")[0] in brings(extra), (module, extra)
    # one OpenCV wheel, the contrib one
    deps = [d for ds in extras.values() for d in ds] + meta["dependencies"]
    assert [d for d in deps if d.startswith("opencv")] == ["opencv-contrib-python-headless>=4.8"]
