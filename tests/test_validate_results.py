"""The subcommands that work on the benchmark's results (what the README's and the docs' figures
rest on): a committed report's results written back and the report written again from them, byte
for byte; two runs compared; the image path's covariance and matching bar; the family bound; a
subset of the pairs at another quality; the detector's pixel residuals."""
import json
import os
import shutil

import numpy as np
import pytest

from catadioptric._checks import CatadioptricError
from catadioptric.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
VALIDATE = os.path.join(ROOT, "validate")

TINY_SPEC = """name = "tiny"
scene = "urban_street"
resolution = "320x240"
quality = "draft"
seed = 2026
pairs = 2
noise_px = [0.0]
draws = 1

[[configs]]
name = "central"
rig = "hyperboloid_central"

[[configs]]
name = "hyperboloid"
rig = "hyperboloid"
"""


@pytest.fixture(scope="module")
def heldout(tmp_path_factory):
    """The committed held-out report's image-path results, written back into a working folder."""
    data = str(tmp_path_factory.mktemp("heldout"))
    assert main(["validate", "restore", os.path.join(VALIDATE, "relative_pose_heldout", "images.json"),
                 "--data", data]) == 0
    return os.path.join(data, "results_images")


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """One pair of a two-configuration spec, rendered small and evaluated by ``--only``."""
    root = tmp_path_factory.mktemp("tiny")
    spec = root / "tiny.toml"
    spec.write_text(TINY_SPEC)
    data = str(root / "data")
    assert main(["validate", "benchmark", "--spec", str(spec), "--only", "central:0", "--out", data,
                 "--no-progress"]) == 0
    return str(spec), data


def test_a_committed_report_is_restored_and_written_again_byte_for_byte(tmp_path, capsys):
    for name, spec, extra, md in (("relative_pose_wide", "relative_pose_wide.toml", [], "report.md"),
                                  ("relative_pose_heldout", "relative_pose_heldout.toml", ["--images-only"],
                                   "images.md"),
                                  ("relative_pose_blind", "relative_pose_blind.toml", ["--images-only"], "images.md")):
        committed = os.path.join(VALIDATE, name)
        data, out = str(tmp_path / name / "data"), tmp_path / name / "out"
        report = "images.json" if extra else "report.json"
        assert main(["validate", "restore", os.path.join(committed, report), "--data", data]) == 0
        printed = capsys.readouterr().out
        assert " pair results written to " in printed and "0 already there" in printed
        # the report folder as committed, its Markdown gone: written again from the results alone
        shutil.copytree(committed, out)
        os.remove(out / md)
        assert main(["validate", "benchmark", "--spec", os.path.join(VALIDATE, spec), "--out", str(out), "--data",
                     data, "--report-only", *extra]) == 0
        assert "(nothing computed)" in capsys.readouterr().out
        assert (out / md).read_text() == open(os.path.join(committed, md)).read()
        # a second restore keeps what is there; --force writes it again
        assert main(["validate", "restore", os.path.join(committed, report), "--data", data]) == 0
        assert " 0 pair results written" in capsys.readouterr().out
        assert main(["validate", "restore", os.path.join(committed, report), "--data", data, "--force"]) == 0
        assert "0 already there" in capsys.readouterr().out


def test_restore_and_report_only_errors_are_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"spec": {}}))
    for argv, msg in (
            (["validate", "restore", str(tmp_path / "none.json"), "--data", str(tmp_path)], "REPORT: no file"),
            (["validate", "restore", str(bad), "--data", str(tmp_path)], "REPORT: expected a benchmark's report.json"),
            (["validate", "benchmark", "--spec", os.path.join(VALIDATE, "relative_pose_wide.toml"), "--out",
              str(tmp_path / "o"), "--data", str(tmp_path / "d"), "--report-only"], "--data: no result for 30 of 30"),
            (["validate", "benchmark", "--out", str(tmp_path / "o"), "--only", "sphere:20"],
             "--only: expected CONFIG:PAIR with CONFIG one of"),
            (["validate", "benchmark", "--out", str(tmp_path / "o"), "--only", "cube"],
             "--only: expected CONFIG:PAIR, a configuration (sphere, ellipsoid"),
            (["validate", "benchmark", "--out", str(tmp_path / "o"), "--only", "sphere", "--report-only"],
             "--only: a report is of every pair"),
            (["validate", "benchmark", "--out", str(tmp_path / "o"), "--quality", "blender=high"],
             "--quality: expected PRESET or RENDERER=PRESET"),
            (["validate", "benchmark", "--out", str(tmp_path / "o"), "--quality", "best"],
             "--quality: expected one of ['draft', 'high', 'standard']")):
        capsys.readouterr()
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert msg in err and len(err.strip().splitlines()) == 1, err


def test_the_pairs_and_the_quality_of_a_subset():
    from catadioptric.validate.benchmark_spec import load_benchmark_spec, select_pairs, with_quality

    spec = load_benchmark_spec(os.path.join(VALIDATE, "relative_pose.toml"))
    assert select_pairs(spec, "ellipsoid:3,sphere:0") == [("sphere", 0), ("ellipsoid", 3)]
    assert len(select_pairs(spec, "sphere")) == 20
    mitsuba = select_pairs(spec, "mitsuba")
    assert len(mitsuba) == 50 and all(k % 2 == 0 for _, k in mitsuba)
    assert select_pairs(spec, "hyperboloid,hyperboloid:3") == select_pairs(spec, "hyperboloid")
    assert with_quality(spec, ["mitsuba=standard"])["quality"] == {"mitsuba": "standard", "povray": "standard"}
    assert with_quality(spec, ["draft"])["quality"] == {"mitsuba": "draft", "povray": "draft"}
    one = spec | {"quality": "standard"}
    assert with_quality(one, ["high"])["quality"] == "high"  # one preset stays one
    assert with_quality(one, ["povray=high"])["quality"] == {"mitsuba": "standard", "povray": "high"}


def _runs(folder, prior):
    from catadioptric.validate.benchmark import read_results

    return {k: next(r for r in res["runs"] if r["max_rotation_deg"] == prior) for k, res in
            read_results(folder).items()}


def test_two_runs_compared(heldout, tmp_path, capsys):
    """A run against itself changes nothing; against a copy with some pairs made worse, the counts
    and the paired test say so. The counts agree with the committed report's own aggregate."""
    agg = json.load(open(os.path.join(VALIDATE, "relative_pose_heldout", "images.json")))["images_aggregate"]
    e = [v["priors"]["60"] for k, v in agg.items() if k.endswith("/all")]
    ambiguous, failed = sum(x["ambiguous"] for x in e), sum(x["failed"] for x in e)
    assert main(["validate", "compare", heldout, heldout]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("| base:"))
    assert f"| 100 | {100 - ambiguous - failed} | {ambiguous} | {failed} | 0 |" in row
    assert "lower in 0 pairs and higher in 0 (no pair differs)" in out
    # a copy with the rotation of twelve answered pairs three times worse, one of them made ambiguous
    new = tmp_path / "new"
    shutil.copytree(heldout, new)
    runs = _runs(heldout, 60.0)
    changed = [k for k, r in sorted(runs.items()) if "error" not in r and not r["ambiguous"]][:12]
    for k in changed:
        path = new / k
        res = json.loads(path.read_text())
        for r in res["runs"]:
            if r["max_rotation_deg"] == 60.0:
                r["rotation_error_deg"] *= 3
                r["ambiguous"] = r["ambiguous"] or k == changed[0]
        path.write_text(json.dumps(res))
    assert main(["validate", "compare", heldout, str(new), "--prior", "60"]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("| new:"))
    assert f"| 100 | {100 - ambiguous - failed - 1} | {ambiguous + 1} | {failed} |" in row
    both = [(r["rotation_error_deg"], (3 if k in changed else 1) * r["rotation_error_deg"])
            for k, r in runs.items() if "error" not in r]
    x, y = np.array(both).T
    assert (f"median rotation error {np.median(x):.3f} -> {np.median(y):.3f} degrees, lower in 0 pairs and higher "
            f"in 12 (Wilcoxon signed-rank p = ") in out
    from catadioptric.validate.compare import compare_runs
    from catadioptric.validate.benchmark import read_results

    with pytest.raises(CatadioptricError, match="--prior: the results hold runs with the priors"):
        compare_runs(read_results(heldout), read_results(str(new)), 30.0)
    capsys.readouterr()
    assert main(["validate", "compare", heldout, str(tmp_path / "nowhere")]) == 2
    assert "NEW: expected a folder of per-pair results" in capsys.readouterr().err


def test_the_image_paths_covariance_and_matching_bar(heldout, capsys):
    from catadioptric.pose import MATCHING_BARS

    assert main(["validate", "image-runs", heldout]) == 0
    out = capsys.readouterr().out
    runs = [r for rs in (json.load(open(os.path.join(heldout, c, p)))["runs"] for c in os.listdir(heldout)
                         for p in os.listdir(os.path.join(heldout, c))) for r in rs if "error" not in r]
    answered = [r for r in runs if not r["ambiguous"]]
    m = [r["rotation_mahalanobis2"] for r in answered]
    assert (f"Covariance: {len(answered)} answered runs" in out
            and f"Mahalanobis square of the rotation error: median {np.median(m):.2f}" in out)
    (most, bar), _ = MATCHING_BARS
    def held(r):  # the verdict's margin: the matching's, or its margin by the RANSAC's matchings if smaller
        m = np.inf if r["margin"] is None else r["margin"]
        return m if r.get("margin_unordered") is None else min(m, r["margin_unordered"])

    wrong = [held(r) for r in runs if r["rotation_error_deg"] > 5 and r["candidates"] <= most]
    assert f"- 1-{most} assignments: bar {bar:g}; " in out and f"won by at most {max(wrong):.1f}" in out


def test_the_family_bound(tiny, tmp_path, capsys):
    """On a rendered pair: rows written (atomically, JSON), the tables printed; read back, the same
    tables; the committed rows print the docs' bound."""
    spec, data = tiny
    rows_path = str(tmp_path / "rows.json")
    assert main(["validate", "family-bound", "--spec", spec, "--data", data, "--configs", "central", "--pairs", "1",
                 "--out", rows_path]) == 0
    printed = capsys.readouterr().out
    rows = json.load(open(rows_path))
    assert [(r["config"], r["pair"]) for r in rows] == [("central", 0)]
    r = rows[0]
    assert set(r["identifiable"]) <= set(r["families_label"]) and set(r["families_label_3"]) <= set(r["families_label"])
    for pool in ("own", "seq"):
        assert set(r[f"significant_{pool}"]) | set(r[f"significant_joint_{pool}"]) <= set(r["families_label"])
    assert main(["validate", "family-bound", "--from-json", rows_path]) == 0
    assert capsys.readouterr().out == printed.replace(f"wrote {rows_path}\n", "")
    assert main(["validate", "family-bound", "--from-json",
                 os.path.join(VALIDATE, "relative_pose", "family_identifiability.json")]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last.startswith("| all | 100 | ") and last.endswith(" | 79 / 49 | 100 / 89 |")
    assert main(["validate", "family-bound", "--spec", spec, "--data", data, "--configs", "hyperboloid", "--out",
                 rows_path]) == 2
    assert "--data: pair 0 of hyperboloid is not rendered" in capsys.readouterr().err


def test_the_grouping_bound_through_the_pose(tiny, tmp_path, capsys):
    """The image path with its detected lines grouped by the labels, on a rendered pair: each run an
    answer (within 5 deg: families of the labels' own only) or the pose's own error (the small render
    may leave a view one family of lines of 30 px); rows written, the table printed from them and
    again from the file; the committed rows print the docs' figures; a grouping it does not know is
    named."""
    from catadioptric.validate.image_pairs import evaluate_image_pair

    spec, data = tiny
    rows_path = str(tmp_path / "grouped.json")
    assert main(["validate", "family-bound", "--through-pose", "--spec", spec, "--data", data, "--configs", "central",
                 "--pairs", "1", "--out", rows_path, "--no-progress"]) == 0
    printed = capsys.readouterr().out
    rows = json.load(open(rows_path))
    assert [(r["config"], r["pair"]) for r in rows] == [("central", 0)]
    runs = rows[0]["runs"]
    assert [x["max_rotation_deg"] for x in runs] == [None, 60.0]
    for x in runs:
        if "error" in x:
            assert x["error"].startswith("views: expected at least 2 families of two or more lines in each view")
        elif x["rotation_error_deg"] < 5.0:
            assert x["families_right"], x
    cells = ["0 / 0" if "error" in x else f"{int(not x['ambiguous'])} / {int(x['same_families_3'])}" for x in runs]
    assert f"| central | 1 | {cells[0]} | {cells[1]} |" in printed and printed.endswith(f"wrote {rows_path}\n")
    assert main(["validate", "family-bound", "--from-json", rows_path]) == 0
    assert capsys.readouterr().out == printed.replace(f"wrote {rows_path}\n", "")
    for name, last in (("relative_pose", "| all | 100 | 82 / 69 | 99 / 82 |"),
                       ("relative_pose_heldout", "| all | 100 | 80 / 62 | 98 / 74 |")):
        assert main(["validate", "family-bound", "--from-json", os.path.join(VALIDATE, name, "grouping_bound.json")]) == 0
        assert capsys.readouterr().out.strip().splitlines()[-1] == last
    # the pair's families are the labels' (every label family with two detected lines or more)
    from catadioptric import Dataset
    from catadioptric.detect import detect_lines
    from catadioptric.detect.evaluate import grouped_by_labels

    folder = os.path.join(data, "datasets", "central_mitsuba")
    res = evaluate_image_pair(folder, ("p00A", "p00B"), priors=(60.0,), grouping="labels")
    views = [Dataset(folder)[n] for n in ("p00A", "p00B")]
    own = [grouped_by_labels(detect_lines(v["beauty"], v["camera"]), v) for v in views]
    assert res["grouping"] == "labels"
    assert [d["families_detected"] for d in res["detection"]] == [len(g.families) for g in own]
    with pytest.raises(CatadioptricError, match=r"^grouping: expected 'detector' or 'labels', got 'oracle'$"):
        evaluate_image_pair(folder, ("p00A", "p00B"), grouping="oracle")


def test_a_subset_renders_and_evaluates_its_pairs_only(tiny):
    spec, data = tiny
    assert sorted(os.listdir(os.path.join(data, "datasets"))) == ["central_mitsuba"]
    views = [v for v in os.listdir(os.path.join(data, "datasets", "central_mitsuba")) if v.startswith("p")]
    assert sorted(views) == ["p00A", "p00B"]
    assert os.listdir(os.path.join(data, "results")) == ["central"]
    assert not os.path.exists(os.path.join(data, "report.md"))


def test_the_detectors_pixel_residuals(tiny, capsys):
    _, data = tiny
    ds = os.path.join(data, "datasets", "central_mitsuba")
    assert main(["validate", "pixel-residuals", ds, "p00A", "--min-pixels", "30", "--lags", "3"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("p00A: ") and "residual rms median" in out and "autocorrelation at lags 1..3:" in out
    assert main(["validate", "pixel-residuals", ds, "p09A"]) == 2
    assert "VIEW: expected views of the dataset (p00A, p00B), got ['p09A']" in capsys.readouterr().err


def test_the_translation_columns_count_the_answered_runs(heldout):
    """The images table's translation figures, aggregated from the committed held-out records: per
    configuration and prior, the answered runs whose translation is more than 90 degrees off, those
    whose translation the look decided, and the median of the look's direction error over the same
    runs."""
    from catadioptric.validate.benchmark import read_results
    from catadioptric.validate.benchmark_report import aggregate_images

    spec = json.load(open(os.path.join(VALIDATE, "relative_pose_heldout", "images.json")))["spec"]
    results = list(read_results(heldout).values())
    agg = aggregate_images(spec, [], results)
    total = taken = 0
    for config in spec["configs"]:
        for prior, key in ((None, "none"), (60.0, "60")):
            runs = [r for res in results if res["config"] == config["name"] for r in res["runs"]
                    if r["max_rotation_deg"] == prior and "error" not in r and not r["ambiguous"]]
            q = agg[f"{config['name']}/all"]["priors"][key]
            off = [r["translation_direction_error_deg"] for r in runs]
            assert q["translation_reversed"] == sum(e > 90.0 for e in off if e is not None)
            assert q["translation_from_look"] == sum(r["look_translation_taken"] is not None for r in runs)
            assert q["translation_direction_look_deg"]["median"] == pytest.approx(
                float(np.median([r["translation_direction_error_look_deg"] for r in runs])), abs=1e-12)
            total += q["translation_reversed"] if key == "60" else 0
            taken += q["translation_from_look"] if key == "60" else 0
    assert (total, taken) == (0, 21)  # docs/relative_pose.md, "From the images alone"
