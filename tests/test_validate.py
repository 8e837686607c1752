"""The relative-pose experiment end to end on rendered views: line pixels from the labels, one
pair from the command line (report, exit codes), the benchmark at its CI size; noise sweeps."""
import json
import os

import numpy as np
import pytest

from catadioptric._checks import CatadioptricError
from catadioptric.cli import main
from catadioptric.dataset import Dataset
from catadioptric.observations import curve_pixels, line_pixels, ridge_pixels


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("pair") / "tiny_street")
    assert main(["render", "tiny_street", "--out", out, "--quality", "draft", "--no-progress"]) == 0
    return out


def test_curve_pixels_lie_on_the_exact_curve_where_the_label_shows_the_line(pair):
    v = Dataset(pair)[0]
    lp = line_pixels(v, pixels="curve", min_pixels=10)
    assert len(lp.uv) >= 5 and set(lp.counts) == set(lp.family)
    curves = v["curves"]
    for uv, seg, lab in zip(lp.uv[:5], lp.segment, lp.label):
        exact = np.concatenate([c["uv"] for c in curves if c["segment"] == seg])
        d = np.min(np.linalg.norm(uv[:, None, :] - exact[None], axis=-1), axis=1)
        assert d.max() < 1e-9  # vertices of the exact curve, not interpolated between them
        steps = np.linalg.norm(np.diff(uv, axis=0), axis=1)
        assert np.median(steps) < 1.5  # about one point per pixel of arc length
        near = np.rint(uv).astype(int)
        labels = v["labels"]
        win = [labels[max(y - 1, 0):y + 2, max(x - 1, 0):x + 2] for x, y in near]
        assert all((w == lab).any() for w in win)  # the label image shows the line there
    # the ridge pixels are integer pixel centres carrying the label
    lab = lp.label[0]
    r = ridge_pixels(v["labels"], lab)
    assert len(r) > 0 and np.all(v["labels"][r[:, 1].astype(int), r[:, 0].astype(int)] == lab)
    assert len(curve_pixels(curves, v["labels"], lp.segment[0], lab)) == len(
        line_pixels(v, pixels="curve", min_pixels=10).uv[0])


def test_relative_pose_of_a_rendered_pair(pair, tmp_path):
    rep = str(tmp_path / "report")
    code = main(["validate", "relative-pose", pair, "--views", "A", "B", "--out", rep, "--noise", "0", "1",
                 "--draws", "2", "--min-pixels", "15"])
    res = json.load(open(os.path.join(rep, "report.json")))
    assert code == (3 if any(d["ambiguous"] for d in res["draws"]) else 0)
    assert res["views"] == ["A", "B"]
    # two draws at 1 px, one at 0 px (the same pixels in every draw)
    assert [(d["noise_px"], d["draw"]) for d in res["draws"]] == [(0.0, 0), (1.0, 0), (1.0, 1)]
    R_gt = np.array(res["R_gt"])
    assert np.allclose(R_gt @ R_gt.T, np.eye(3), atol=1e-12)
    d0 = res["draws"][0]
    for key in ("seed", "R", "t", "ambiguous", "rotation_error_deg", "translation_error_m",
                "translation_direction_error_deg", "families_used", "lines_used", "central"):
        assert key in d0
    assert not d0["ambiguous"] and d0["rotation_error_deg"] < 0.05  # no added noise: exact pixels
    assert d0["families_used"] >= 3 and d0["lines_used"] >= 5
    assert os.path.getsize(os.path.join(rep, "lines.png")) > 10_000
    md = open(os.path.join(rep, "report.md")).read()
    assert "Reproduce:" in md and "| selected rotation (deg) |" in md
    # the exact and the central answer of each draw, and the one whose covariance claims less
    for d in res["draws"]:
        if "error" in d or "error" in d["central"]:
            continue
        sel = d["selected"]
        assert sel["model"] in ("exact", "central") and sel["reason"]
        chosen = d if sel["model"] == "exact" else d["central"]
        assert sel["rotation_error_deg"] == chosen["rotation_error_deg"]
        if sel["model"] == "central":
            assert d["central"]["rotation_std_deg"] < d["rotation_std_deg"]
        assert f"{sel['rotation_error_deg']:.3g} ({sel['model']})" in md or sel["ambiguous"]


def test_relative_pose_errors_name_the_flag(pair, tmp_path, capsys):
    out = str(tmp_path / "r")
    assert main(["validate", "relative-pose", pair, "--views", "A", "nope", "--out", out]) == 2
    assert "views: expected names among ['A', 'B'], got unknown ['nope']" in capsys.readouterr().err
    # the same view twice: no baseline, a NaN direction and a numpy warning before (issue 39)
    assert main(["validate", "relative-pose", pair, "--views", "A", "A", "--out", out]) == 2
    err = capsys.readouterr().err
    assert err == "catadioptric: error: --views: expected two different views, got 'A' twice\n", err
    from catadioptric.validate.relative_pose import evaluate_pair

    with pytest.raises(CatadioptricError, match=r"views: expected two different views, got 'A' twice"):
        evaluate_pair(pair, ["A", "A"])
    assert not os.path.exists(out)
    assert main(["validate", "relative-pose", pair, "--out", out, "--min-pixels", "90", "--max-pixels", "60"]) == 2
    assert "--min-pixels: expected at most --max-pixels (60), got 90" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["validate", "relative-pose", pair, "--out", out, "--noise", "-1"])
    assert "--noise: expected" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["validate", "relative-pose", pair, "--out", out, "--draws", "0"])
    assert "--draws: expected a positive integer, got '0'" in capsys.readouterr().err
    assert main(["validate", "relative-pose", str(tmp_path / "none"), "--out", out]) == 2
    assert "DATASET:" in capsys.readouterr().err


def test_benchmark_at_its_ci_size(tmp_path, capsys):
    """The benchmark of validate/relative_pose.toml at its [quick] size, rendered and evaluated for real;
    a rerun resumes (nothing rendered or evaluated again)."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    spec = os.path.join(root, "validate", "relative_pose.toml")
    out = str(tmp_path / "bench")
    assert main(["validate", "benchmark", "--spec", spec, "--quick", "--out", out, "--no-progress"]) == 0
    rep = json.load(open(os.path.join(out, "report.json")))
    # written on one line (the full benchmark's is 4.1 MB so, 5.3 MB indented)
    assert len(open(os.path.join(out, "report.json")).read().splitlines()) == 1
    assert set(rep["aggregate"]) == set(rep["spec"]["quick"]["configs"])
    for name, a in rep["aggregate"].items():
        assert a["pairs"] == 1
        for e in a["noise"].values():
            ex = e["exact"]
            assert ex["draws"] == 1 and ex["failed"] == 0 and ex["over_10deg_unflagged"] == 0
    for png in ("rotation.png", "translation.png"):
        assert os.path.getsize(os.path.join(out, png)) > 5_000
    results = sorted(os.listdir(os.path.join(out, "results")))
    stamp = {r: os.path.getmtime(os.path.join(out, "results", r, "p00.json")) for r in results}
    # the rerun adds the image-only path (labels only score it); the label results are read back
    assert main(["validate", "benchmark", "--spec", spec, "--quick", "--out", out, "--no-progress", "--images"]) == 0
    assert stamp == {r: os.path.getmtime(os.path.join(out, "results", r, "p00.json")) for r in results}
    rep = json.load(open(os.path.join(out, "report.json")))
    assert len(rep["images_pairs"]) == len(results)
    for p in rep["images_pairs"]:
        assert [r["max_rotation_deg"] for r in p["runs"]] == [None, *rep["spec"]["images"]["max_rotation_deg"]]
        assert len(p["detection"]) == 2 and all(0 <= d["recovered_fraction"] <= 1 for d in p["detection"])
    for e in rep["images_aggregate"].values():
        assert all(q["over_10deg_unflagged"] == 0 for q in e["priors"].values())
    md = open(os.path.join(out, "report.md")).read()
    assert "## From the images alone (no labels)" in md and "labels, 1 px" in md
    from catadioptric.validate.benchmark import code_digest

    for what in ("label path", "image path"):  # which code made the figures
        assert (f"The {what}'s per-pair results were computed by the package code of digest "
                f"`{code_digest()[:8]}` ({len(results)} pairs)") in md
    # the image path alone reads its results back, prints their summary and writes its own report
    # beside the full one, which it leaves alone
    images = {r: os.path.getmtime(os.path.join(out, "results_images", r, "p00.json")) for r in results}
    report_time = os.path.getmtime(os.path.join(out, "report.json"))
    capsys.readouterr()
    assert main(["validate", "benchmark", "--spec", spec, "--quick", "--out", out, "--no-progress",
                 "--images-only"]) == 0
    printed = capsys.readouterr().out
    assert images == {r: os.path.getmtime(os.path.join(out, "results_images", r, "p00.json")) for r in results}
    assert os.path.getmtime(os.path.join(out, "report.json")) == report_time
    for name in results:
        e = rep["images_aggregate"][f"{name}/all"]["priors"]["60"]
        assert (f"{name:22s} prior   60: 1 pairs, ambiguous {e['ambiguous']}, failed {e['failed']}, wrong and "
                f"unflagged 0") in printed
    assert f"wrote {os.path.join(out, 'images.md')}" in printed
    alone = open(os.path.join(out, "images.md")).read()
    assert "## From the images alone (no labels)" in alone and "labels, 1 px" not in alone
    assert "Reproduce: `catadioptric validate benchmark" in alone and "--images-only" in alone
    def images_part(agg):
        return {k: {f: v for f, v in e.items() if f != "labels_rotation_deg"} for k, e in agg.items()}

    assert images_part(json.load(open(os.path.join(out, "images.json")))["images_aggregate"]) == images_part(
        rep["images_aggregate"])
    # each section's own table: the draws' counts per model, the selected model per noise level
    draws_table = md.split("## Draws: failures, ambiguous answers, wrong answers")[1].split("\n## ")[0]
    assert "| configuration | model | draws | failed |" in draws_table and "| exact | 1 |" in draws_table
    chosen = md.split("## Selected model")[1].split("\n## ")[0]
    assert "| configuration | 1 px |" in chosen
    assert "| selected |" in md.split("## Rotation error (degrees)")[1].split("\n## ")[0]


def test_noise_sweep_grows_with_noise(tmp_path):
    from catadioptric.validate import noise_sweep as ns

    res = ns.run(rigs=["hyperboloid", "sphere"], trials=20, seed=1)
    for r in res["rigs"].values():
        assert r["vp_error_mm"][0] < 1e-9 and r["direction_error_deg"][0] < 1e-9 and r["rotation_error_deg"][0] < 1e-6
        assert r["vp_error_mm"][-1] > r["vp_error_mm"][1] > 0
        assert r["direction_error_deg"][-1] > r["direction_error_deg"][1] > 0
    assert "Reproduce" in ns.markdown(res, "cmd")


def test_paired_comparison_of_exact_and_central():
    """The report's draw-by-draw comparison: counts, median difference and a Wilcoxon p-value that
    is small for a consistent difference and absent for identical answers; answered draws only."""
    from catadioptric.validate.benchmark_report import _paired

    rng = np.random.default_rng(3)
    c = rng.uniform(0.2, 0.4, 12)

    def draw(e, ce, amb=False):
        return {"rotation_error_deg": e, "rotation_std_deg": 0.1, "ambiguous": amb,
                "central": {"rotation_error_deg": ce, "rotation_std_deg": 0.2, "ambiguous": False}}

    draws = [draw(x - 0.1, x) for x in c] + [draw(50.0, 0.1, amb=True), {"error": "failed", "central": {}}]
    p = _paired(draws)
    assert p["n"] == 12 and p["exact_better"] == 12
    assert np.isclose(p["median_difference_deg"], -0.1)
    assert p["wilcoxon_p"] < 0.01
    assert np.isclose(p["exact_error_over_predicted"]["median"], np.median((c - 0.1) / 0.1))
    # each model over its own answered draws (the central answer of the draw the exact model left ambiguous too)
    assert np.isclose(p["central_error_over_predicted"]["median"], np.median(np.r_[c, 0.1] / 0.2))
    same = _paired([draw(x, x) for x in c])
    assert same["exact_better"] == 0 and same["wilcoxon_p"] is None
    mixed = _paired([draw(x + (0.01 if i % 2 else -0.01), x) for i, x in enumerate(c)])
    assert mixed["wilcoxon_p"] > 0.3


def test_benchmark_results_are_kept_by_the_code_that_made_them(tmp_path):
    """A pair's result is reused only while the package's Python sources are unchanged: the digest
    follows every .py file (name and bytes), not other files, and enters the pair's fingerprint."""
    from catadioptric.validate.benchmark import _fingerprint, code_digest
    from catadioptric.validate.benchmark_spec import load_benchmark_spec, pairs_of

    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "a.py").write_text("x = 1\n")
    (pkg / "sub" / "b.py").write_text("y = 2\n")
    d0 = code_digest(str(pkg))
    (pkg / "notes.txt").write_text("not code")
    assert code_digest(str(pkg)) == d0
    (pkg / "sub" / "b.py").write_text("y = 3\n")
    d1 = code_digest(str(pkg))
    assert d1 != d0
    (pkg / "sub" / "b.py").rename(pkg / "b.py")  # same bytes, another file
    assert code_digest(str(pkg)) not in (d0, d1)
    assert len(code_digest()) == 64
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    spec = load_benchmark_spec(os.path.join(root, "validate", "relative_pose.toml"))
    config = spec["configs"][0]
    pair = pairs_of(spec, config)[0]
    for kind in ("labels", "images"):
        assert _fingerprint(spec, config, pair, kind, d0) != _fingerprint(spec, config, pair, kind, d1)
        assert _fingerprint(spec, config, pair, kind) == _fingerprint(spec, config, pair, kind, code_digest())


def test_the_quality_of_each_renderer():
    """``quality`` is one preset or a table of one per renderer (the benchmark renders Mitsuba at
    high, POV-Ray at standard); an unknown preset is named when the spec is read; the quality keys
    the image path's results, not the label path's (labels are exact at every preset)."""
    import tomllib

    from catadioptric.validate.benchmark import _fingerprint
    from catadioptric.validate.benchmark_spec import (load_benchmark_spec, pairs_of, quality_of, quality_text,
                                                      quick_spec, read_benchmark_spec)

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    path = os.path.join(root, "validate", "relative_pose.toml")
    spec = load_benchmark_spec(path)
    assert (quality_of(spec, "mitsuba"), quality_of(spec, "povray")) == ("high", "standard")
    assert quality_text(spec) == "mitsuba `high`, povray `standard`"
    quick = quick_spec(spec)
    assert quality_of(quick, "mitsuba") == quality_of(quick, "povray") == "draft" and quality_text(quick) == "`draft`"
    with open(path, "rb") as f:
        data = tomllib.load(f)
    one = read_benchmark_spec(data | {"quality": "standard"})
    assert quality_of(one, "mitsuba") == "standard"
    partial = read_benchmark_spec(data | {"quality": {"mitsuba": "high"}})
    assert partial["quality"] == {"mitsuba": "high", "povray": "standard"}
    for bad, msg in ((
            {"mitsuba": "hig"}, "benchmark.quality.mitsuba: expected one of ['draft', 'high', 'standard'] or a .toml "
                                "file, got 'hig'"),
            ({"blender": "high"}, "benchmark.quality.blender: unknown key"),
            ("best", "benchmark.quality: expected one of ['draft', 'high', 'standard'] or a .toml file, got 'best'")):
        with pytest.raises(CatadioptricError) as e:
            read_benchmark_spec(data | {"quality": bad})
        assert str(e.value).startswith(msg)
    config = spec["configs"][0]
    pair = pairs_of(spec, config)[0]
    assert _fingerprint(spec, config, pair, "labels", "c") == _fingerprint(one, config, pair, "labels", "c")
    assert _fingerprint(spec, config, pair, "images", "c") != _fingerprint(one, config, pair, "images", "c")


def test_evaluating_some_pairs_names_the_ones_the_spec_does_not_have(tmp_path):
    from catadioptric.validate.benchmark import evaluate_benchmark, results_folder
    from catadioptric.validate.benchmark_spec import load_benchmark_spec

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    spec = load_benchmark_spec(os.path.join(root, "validate", "relative_pose.toml"))
    with pytest.raises(CatadioptricError) as e:
        evaluate_benchmark(spec, str(tmp_path), only=[("sphere", 3), ("sphere", 20), ("cube", 0)], kind="images")
    assert str(e.value) == ("only: expected pairs of the spec (configurations ['sphere', 'ellipsoid', 'hyperboloid', "
                            "'hyperboloid_central', 'hyperboloid_9pct'], indices below 20), got [('cube', 0), "
                            "('sphere', 20)]")
    assert evaluate_benchmark(spec, str(tmp_path), only=[], kind="images") == []
    assert results_folder("D", "images") == os.path.join("D", "results_images")
    with pytest.raises(CatadioptricError, match="kind: expected one of"):
        results_folder("D", "image")


def test_what_the_geometry_alone_would_have_answered():
    """The report's appearance table: a run counts as answered by the geometry alone when its margin
    without appearance reaches the same bar, or the lines seen again decided (their answer then);
    wrong when the candidate the geometry alone ranks first is more than 10 degrees off."""
    from catadioptric.validate.benchmark_report import _geometry_alone

    def run(m, err_geo, err=0.1, static=False, bar=35.0, unordered=float("inf")):
        return {"margin_geometry_alone": m, "margin_geometry_alone_unordered": unordered, "matching_bar": bar,
                "turned_in_place": static, "rotation_error_geometry_alone_deg": err_geo, "rotation_error_deg": err}

    ok = [run(40.0, 0.2), run(34.9, 0.2), run(50.0, 179.0), run(-3.0, 90.0, static=True), run(float("inf"), 0.3),
          run(80.0, 179.0, unordered=20.0),  # decided by the lines matched in their order alone
          run(None, 0.1, unordered=None)]  # one assignment: no rival, its margins infinite (null in JSON)
    assert _geometry_alone(ok) == {"answered_geometry_alone": 5, "over_10deg_unflagged_geometry_alone": 1}
    # results without the geometry alone's record (no appearance, or computed before it was recorded): no figure
    assert _geometry_alone(ok + [run(None, None)]) == {"answered_geometry_alone": None,
                                                       "over_10deg_unflagged_geometry_alone": None}
    assert _geometry_alone([])["answered_geometry_alone"] is None


def test_the_image_path_is_set_beside_the_label_path_at_its_own_pixel_noise():
    """The ratio of the report's image section: against the label path at the smallest noise level
    at least the detected pixels' own (median distance / 0.6745), none when no level is."""
    from catadioptric.validate.benchmark_report import _comparable_level

    def entry(dist, im=0.2):
        return {"pixel_distance_px": {"median": dist}, "priors": {"60": {"rotation_deg": {"median": im}}},
                "labels_rotation_deg": {"0.5": {"median": 0.05}, "1": {"median": 0.1}, "2": {"median": 0.2}}}

    noises = [0.5, 1, 2]
    assert _comparable_level(entry(0.30), "60", noises) == (0.5, pytest.approx(4.0))  # 0.30 px: sigma 0.445
    assert _comparable_level(entry(0.55), "60", noises) == (1, pytest.approx(2.0))  # sigma 0.815
    assert _comparable_level(entry(0.70), "60", noises) == (2, pytest.approx(1.0))  # sigma 1.04
    assert _comparable_level(entry(1.40), "60", noises) == (None, None)  # sigma 2.08: beyond every level
    assert _comparable_level(entry(None), "60", noises) == (None, None)
    assert _comparable_level(entry(0.55, None), "60", noises) == (None, None)


def test_the_central_approximations_own_error():
    """central_model_error_px: 0 for a central rig (its exact unified model), a fraction of a pixel
    for the hyperboloid off its focus (docs/relative_pose.md, 'The fair central baseline')."""
    from catadioptric.rigspec import load_rig
    from catadioptric.validate.relative_pose import central_approximation, central_model_error_px

    assert central_model_error_px(load_rig("hyperboloid_central", width=640, height=480)) == 0.0
    e = central_model_error_px(load_rig("hyperboloid", width=640, height=480))
    assert 0.1 < e < 0.4  # 0.204 px when measured
    assert central_approximation(load_rig("hyperboloid", width=640, height=480)).viewpoint.shape == (3,)


def test_the_medians_interval_resamples_pairs_not_draws():
    """``median_interval`` resamples pairs with all their draws: three identical draws per pair
    give the interval of one draw per pair (resampling draws one by one would narrow it by about
    sqrt(3)); it is seeded, holds the median, and ignores missing values."""
    from catadioptric.validate.benchmark_report import median_interval

    rng = np.random.default_rng(7)
    one = [[float(v)] for v in rng.lognormal(-1.5, 0.5, 20)]
    three = [[g[0]] * 3 for g in one]
    a, b = median_interval(one), median_interval(three)
    assert a["pairs"] == b["pairs"] == 20
    assert a["median"] == pytest.approx(float(np.median([g[0] for g in one])), rel=1e-15)
    assert (a["lo"], a["hi"]) == pytest.approx((b["lo"], b["hi"]), rel=1e-12)
    assert a["lo"] < a["median"] < a["hi"]
    flat = [[v] for g in three for v in g]  # the same 60 values as 60 independent "pairs"
    c = median_interval(flat)
    assert c["hi"] - c["lo"] < 0.8 * (a["hi"] - a["lo"])
    assert median_interval(three) == b
    with_missing = three + [[None, float("nan")]]
    assert median_interval(with_missing) == b
    assert median_interval([[None]])["median"] is None


def test_two_methods_medians_are_told_apart_by_resampling_pairs():
    """``median_difference_interval``: the difference of two methods' medians on the same pairs, its
    interval from resampling pairs with both methods' draws on them: half the errors is "lower", the
    same values "unresolved" (difference 0), 2 % more on every draw "higher" (the pairs are shared),
    other draws of the same spread "unresolved"; pairs one method has no value on are left out; seeded."""
    from catadioptric.validate.benchmark_report import median_difference_interval

    rng = np.random.default_rng(3)
    base = [list(rng.lognormal(np.log(0.2) + rng.normal(0, 0.3), 0.3, 3)) for _ in range(20)]
    same = median_difference_interval(base, base)
    assert same["difference"] == 0.0 and same["lo"] <= 0.0 <= same["hi"] and same["verdict"] == "unresolved"
    half = [[0.5 * v for v in g] for g in base]
    d = median_difference_interval(half, base)
    everything = np.concatenate(base)
    assert d["difference"] == pytest.approx(-0.5 * np.median(everything), rel=1e-12)
    assert d["verdict"] == "lower" and d["hi"] < 0 and d["lo"] < d["difference"] < d["hi"]
    assert median_difference_interval(base, half)["verdict"] == "higher"
    # both methods on the same pairs: 2 % more on every draw is told (the pairs' own spread cancels) ...
    assert median_difference_interval([[1.02 * v for v in g] for g in base], base)["verdict"] == "higher"
    # ... draws of the same spread on the same pairs are not
    again = [list(np.median(g) * rng.lognormal(0.0, 0.3, 3)) for g in base]
    assert median_difference_interval(again, base)["verdict"] == "unresolved"
    missing = median_difference_interval(half + [[None]], base + [[0.1]])
    assert missing == d and missing["pairs"] == 20
    assert median_difference_interval(half, base) == d
    assert median_difference_interval([[None]], [[1.0]])["verdict"] is None
    with pytest.raises(ValueError):
        median_difference_interval(half, base[:-1])


def test_the_angle_of_a_zero_translation_is_nan_without_a_warning():
    """A translation found zero (a camera turned in place) has no direction to compare: nan, and no
    RuntimeWarning in the benchmark's output."""
    import warnings

    from catadioptric.validate.relative_pose import angle_between_deg

    assert abs(angle_between_deg([1.0, 0.0, 0.0], [0.0, 2.0, 0.0]) - 90.0) < 1e-12
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.isnan(angle_between_deg([0.0, 0.0, 0.0], [0.0, 2.0, 0.0]))
