"""The Markdown reports of a relative pose read as a user reads them: no ``None``, no internal
names, and a translation whose length is not observable given as a direction with its length
marked not observable (its deviation given), not as a metric error."""
import numpy as np

from catadioptric.twoview import image_pair_markdown
from catadioptric.validate.relative_pose import length_observable, pair_markdown, translation_text


def _draw(noise, k, *, t, std, err_m, dir_deg, metric=True, ambiguous=False):
    return {"noise_px": noise, "draw": k, "t": t, "translation_std": std, "metric": metric, "ambiguous": ambiguous,
            "rotation_error_deg": 0.21, "frobenius_error": 0.005, "translation_error_m": err_m,
            "translation_direction_error_deg": dir_deg,
            "central": {"rotation_error_deg": 0.17, "translation_direction_error_deg": 0.6, "ambiguous": False},
            "selected": {"model": "central", "rotation_error_deg": 0.17, "ambiguous": False}}


def _result(max_pixels=None):
    return {"views": ["A", "B"], "baseline_m": 7.34, "pixels": "curve", "min_pixels": 30, "max_pixels": max_pixels,
            "ends": "unknown", "families_in_both": 5,
            "seen": {"A": {"families": 6, "lines": 40, "pixels": 4000, "short_lines": 3},
                     "B": {"families": 5, "lines": 38, "pixels": 3900, "short_lines": 2}},
            "draws": [
                # the demo's case: 6.94 m off a 7.34 m baseline, the length's deviation 94 m
                _draw(2.0, 0, t=[0.4, 0.1, 0.2], std=94.0, err_m=6.94, dir_deg=0.55),
                # exact pixels: the length is told (1 cm off)
                _draw(0.0, 0, t=[7.0, 2.0, 0.5], std=0.02, err_m=0.012, dir_deg=0.01),
                # the deviation not estimated: no length is claimed either
                _draw(1.0, 0, t=[7.0, 2.0, 0.5], std=None, err_m=0.5, dir_deg=0.2),
                # a central answer has a direction only
                _draw(1.0, 1, t=[0.9, 0.3, 0.1], std=0.01, err_m=None, dir_deg=0.3, metric=False, ambiguous=True)
                | {"selected": None, "central": {"error": "fewer than 2 families seen in both views"}},
                {"noise_px": 3.0, "draw": 0, "error": "fewer than 2 families seen in both views", "central": {}},
            ]}


def test_the_pair_report_marks_a_length_it_cannot_observe():
    md = pair_markdown(_result(), "catadioptric validate relative-pose D --out R")
    assert "None" not in md and "nan" not in md
    assert "every pixel of each line used" in md
    rows = {tuple(c.strip() for c in line.split("|")[1:3]): line for line in md.splitlines()
            if line.startswith("| ") and line.split("|")[1].strip()[:1].isdigit()}
    demo = rows["2", "0"]
    assert "6.94" not in demo and "not observable (std 94 m, length 0.458 m)" in demo and "| 0.55 |" in demo
    assert "| 0.012 |" in rows["0", "0"]
    assert "| not known (its deviation was not estimated) |" in rows["1", "0"]
    assert "AMBIGUOUS" in rows["1", "1"]
    assert "failed: fewer than 2 families" in rows["3", "0"]
    assert "its length is *not observable*" in md
    assert "at most 60 per line used" in pair_markdown(_result(60), "c")


def test_which_lengths_are_observable():
    d = _result()["draws"]
    assert [length_observable(x) for x in d[:4]] == [False, True, False, False]
    assert translation_text(d[3]) == "-" and translation_text(d[1]) == "0.012"
    assert translation_text(d[2]) == "not known (its deviation was not estimated)"


def _summary(**kw):
    s = {"R": np.eye(3), "t": np.array([0.3, 0.1, 0.05]), "metric": True, "translation_observable": True,
         "translation_std": 94.0, "rotation_std_deg": 0.2, "ambiguous": False, "margin": float("inf"),
         "lines_matched": 31, "sigma_px": None, "notes": ["families found in both views at once: none"],
         "matched_families": [{"family_a": 0, "family_b": 1, "sign": -1, "lines_a": 9, "lines_b": 7}]}
    return s | kw


def test_the_image_pair_report_reads_without_none():
    md = image_pair_markdown(_summary(), "catadioptric relative-pose a.png b.png --rig hyperboloid --out R")
    assert "None" not in md and "inf" not in md and "nan" not in md
    assert "no rival answer" in md
    assert "translation direction:" in md and "length is not observable" in md and "std 94 m" in md
    assert "pixel noise estimate" not in md
    told = image_pair_markdown(_summary(translation_std=0.05, margin=41.2, sigma_px=0.08), "c")
    assert "translation (metres, metric)" in told and "std 0.050 m" in told and "margin 41.2" in told
    assert "pixel noise estimate 0.08 px" in told
    unknown = image_pair_markdown(_summary(rotation_std_deg=None, translation_std=None), "c")
    assert "None" not in unknown and "its deviation not estimated" in unknown
    assert "std not estimated" in unknown


def test_the_image_pair_report_says_what_the_look_decided():
    ev = {"margin": 12.0, "bar": 40.0, "appearance": False, "margin_geometry_alone": None, "turned_in_place": False,
          "look": {"margin": 0.183, "bar": 0.1, "decided": True}}
    md = image_pair_markdown(_summary(margin=12.0, evidence=ev), "c")
    assert "margin 12.0 against a bar of 40; decided by the images' look (agreement margin 0.183 against 0.1)" in md
    ev["look"] = {"margin": float("nan"), "bar": 0.1, "decided": False}
    md = image_pair_markdown(_summary(margin=12.0, ambiguous=True, evidence=ev), "c")
    assert "the images' look did not decide it (a rival it cannot score)" in md and "nan" not in md


def test_the_image_pair_report_says_what_the_look_checked():
    """An answer the geometry decided, checked by the images' look: the verdict says whether the
    look contradicted it, and by how many standard errors another answer agrees better."""
    ev = {"margin": 45.3, "bar": 40.0, "appearance": False, "margin_geometry_alone": None, "turned_in_place": False,
          "look_check": {"margin": 0.547, "margin_se": 0.161, "bar": 0.1, "sigmas": 2.0, "contradicts": True}}
    md = image_pair_markdown(_summary(margin=45.3, ambiguous=True, evidence=ev), "c")
    assert "**ambiguous**: the images' look contradicts the lines' answer" in md
    assert "the images' look contradicts it (another answer agrees better by 0.547, 3.4 standard errors)" in md
    ev["look_check"] = {"margin": -0.21, "margin_se": float("nan"), "bar": 0.1, "sigmas": 2.0, "contradicts": False}
    md = image_pair_markdown(_summary(margin=45.3, evidence=ev), "c")
    assert "verdict: decisive" in md and "checked by the images' look (every other answer agrees less, by 0.210" in md
    assert "nan" not in md
    ev.pop("look_check")
    ev["look"] = {"margin": 0.183, "bar": 0.1, "decided": True, "candidates": [0, 3], "agreement": [0.6, 0.417],
                  "best": 0, "agreement_se": 0.1}
    md = image_pair_markdown(_summary(margin=12.0, evidence=ev), "c")
    assert "decided by the images' look (agreement margin 0.183 against 0.1); its agreement 0.600, 6.0 standard errors" in md
