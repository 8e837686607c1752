"""The README's Python code runs as written (its quick look), and the main jobs' front doors
(catadioptric.jobs) return what they say. The dataset `make demo` renders (urban_street through
Mitsuba at 640x480) is replaced by a small POV-Ray render of tiny_street: the README's code is run
with that one path changed."""
import json
import re
from pathlib import Path

import numpy as np
import pytest

import catadioptric as cd
from catadioptric._io import jsonable
from catadioptric.cli import main

ROOT = Path(__file__).resolve().parents[1]
DEMO = "out/demo/urban_street_mitsuba"


def _python_blocks():
    return re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("readme") / "tiny_street")
    assert main(["render", "tiny_street", "--renderer", "povray", "--resolution", "small", "--out", out,
                 "--no-progress"]) == 0
    return out


def test_the_readme_has_its_quick_look():
    blocks = _python_blocks()
    assert len(blocks) >= 2 and any(DEMO in b for b in blocks)


@pytest.mark.slow
def test_the_readmes_python_runs_as_written(tiny, monkeypatch):
    monkeypatch.chdir(ROOT)  # the README's paths are from the repository's root
    for block in _python_blocks():
        ns = {}
        exec(compile(block.replace(DEMO, tiny), "README.md", "exec"), ns)
    # the last block's results: the front doors' objects
    assert len(ns["lines"].families) >= 2
    assert ns["res"].pose.R.shape == (3, 3) and isinstance(ns["res"].pose.ambiguous, bool)
    assert np.isfinite(ns["labelled"].rotation_error_deg)
    assert ns["cam"].model == "ocamcalib"
    for obj in (ns["lines"], ns["res"], ns["labelled"]):
        json.dumps(jsonable(obj.to_dict()))  # JSON-ready


def test_a_camera_by_name_must_exist():
    with pytest.raises(cd.CatadioptricError, match="camera"):
        cd.detect_lines(np.zeros((48, 64), np.uint8), "no_such_rig")
    with pytest.raises(cd.CatadioptricError, match="image: expected an image array or an image file, got list"):
        cd.detect_lines([[0, 1]], "hyperboloid")
