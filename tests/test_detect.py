"""Lines and families from one image (catadioptric.detect): sub-pixel edges, band centres, line
curves and families on synthetic images drawn from the exact line images, and on real renders of
both renderers at a small size, scored against their labels; the CLI and the errors."""
from __future__ import annotations

import json
import os

import numpy as np
import pytest
from scipy.spatial import cKDTree

from catadioptric import Dataset
from catadioptric._checks import CatadioptricError
from catadioptric.cli import main
from catadioptric.detect import DetectedLines, detect_lines, evaluate_view, label_curves
from catadioptric.detect.centres import pair_edges
from catadioptric.detect.edges import subpixel_edges
from catadioptric.detect.region import mirror_region
from catadioptric.render.tracer import pixel_rays
from catadioptric.rigspec import load_rig


# --------------------------------------------------------------------------- synthetic images
def _coverage(signed_distance, half_width, n=8):
    """Area coverage of each pixel by the region ``signed_distance(u, v) <= 0`` (n x n samples)."""
    off = (np.arange(n) + 0.5) / n - 0.5
    return lambda H, W: np.mean([signed_distance(*np.meshgrid(np.arange(W) + du, np.arange(H) + dv)) <= half_width
                                 for du in off for dv in off], axis=0)


def _line_distance(theta, c):
    n = np.array([np.cos(theta), np.sin(theta)])
    return lambda u, v: u * n[0] + v * n[1] - c


@pytest.mark.parametrize("theta", [0.0, 0.35, 1.1])
def test_subpixel_edges_of_an_area_sampled_step_are_unbiased(theta):
    H, W, c = 40, 48, 24.37
    dist = _line_distance(theta, c + 20 * np.sin(theta))
    cov = np.mean([dist(*np.meshgrid(np.arange(W) + du, np.arange(H) + dv)) <= 0
                   for du in (np.arange(8) + 0.5) / 8 - 0.5 for dv in (np.arange(8) + 0.5) / 8 - 0.5], axis=0)
    img = 60.0 + 100.0 * cov
    inner = np.zeros((H, W), bool)
    inner[5:-5, 5:-5] = True
    e = subpixel_edges(img, inner, sigma=1.0)
    assert len(e) > 20
    off = np.abs(dist(e.uv[:, 0], e.uv[:, 1]))
    assert np.median(off) < 0.05 and off.max() < 0.1


@pytest.mark.parametrize("slope, tol", [(0.0, 0.02), (12.5, 0.2)])
def test_band_centre_is_the_midpoint_of_its_edges(slope, tol):
    H, W, theta = 40, 48, 0.4
    n = np.array([np.cos(theta), np.sin(theta)])
    c = 24.3 * n[0] + 20.0 * n[1]
    off = (np.arange(8) + 0.5) / 8 - 0.5
    img = np.zeros((H, W))
    for du in off:
        for dv in off:
            u, v = np.meshgrid(np.arange(W) + du, np.arange(H) + dv)
            s = u * n[0] + v * n[1] - c
            # a dark band 3.2 px wide, shaded across (slope > 0: lit from one side, its edges' contrasts
            # 110 and 70 grey levels: the darkest point 1.6 px off the centre, the edges' midpoint 0.15)
            img += np.where(np.abs(s) <= 1.6, 60.0 + slope * (s + 1.6), 170.0)
    img /= off.size**2
    inner = np.zeros((H, W), bool)
    inner[6:-6, 6:-6] = True
    centres, used = pair_edges(subpixel_edges(img, inner, sigma=1.0))
    assert len(centres) > 15 and used.mean() > 0.8
    assert np.all(centres.polarity == -1)
    s = centres.uv @ n - c
    assert np.abs(np.median(s)) < tol and np.ptp(s) < 0.1
    assert np.all(np.abs(centres.width - 3.2) < 0.3)


def _synthetic(cam, segments, width_px=2.0):
    """A grey image of dark bands along the exact images of ``segments`` (area coverage of a band
    ``width_px`` wide about each curve), black outside the mirror; and the curves (dense)."""
    H, W = cam.pinhole.height, cam.pinhole.width
    curves = []
    for k, (a, b) in enumerate(segments):
        for li in cam.segment_image(np.asarray(a, float), np.asarray(b, float)):
            for p in li.pieces:
                uv = p.uv[np.all(np.isfinite(p.uv), axis=1)]
                if len(uv) < 2:
                    continue
                s = np.r_[0, np.cumsum(np.linalg.norm(np.diff(uv, axis=0), axis=1))]
                t = np.arange(0, s[-1], 0.05)
                curves.append((k, np.stack([np.interp(t, s, uv[:, 0]), np.interp(t, s, uv[:, 1])], 1)))
    tree = cKDTree(np.concatenate([c for _, c in curves]))
    v, u = np.mgrid[0:H, 0:W]
    d, _ = tree.query(np.stack([u.ravel(), v.ravel()], 1).astype(float))
    cover = np.clip(width_px / 2 + 0.5 - d, 0, 1).reshape(H, W)
    img = np.where(np.asarray(pixel_rays(cam).valid), 170.0 - 80.0 * cover, 0.0)
    return np.repeat(img[..., None], 3, axis=2).round().astype(np.uint8), curves


def _scene():
    """Seven vertical segments around the rig and four along x, 3 m away."""
    segs = [((3 * np.cos(a), 3 * np.sin(a), -1.5), (3 * np.cos(a), 3 * np.sin(a), 1.5))
            for a in np.radians([10, 55, 100, 150, 200, 250, 300])]
    segs += [((-4, y, z), (4, y, z)) for y in (-2.5, 2.5) for z in (-1.0, 1.0)]
    return segs, {"z": np.array([0.0, 0.0, 1.0]), "x": np.array([1.0, 0.0, 0.0])}


@pytest.fixture(scope="module", params=["sphere", "hyperboloid_central"])
def synthetic(request):
    cam = load_rig(request.param, width=320, height=240)
    segs, dirs = _scene()
    img, curves = _synthetic(cam, segs)
    return cam, img, curves, dirs, detect_lines(img, cam)


def test_synthetic_lines_are_recovered_on_their_exact_curves(synthetic):
    cam, img, curves, dirs, det = synthetic
    pts = cKDTree(np.concatenate(det.uv))
    region = mirror_region(cam, 5)
    covered = []
    for _, c in curves:
        c = c[region[np.clip(np.rint(c[:, 1]).astype(int), 0, 239), np.clip(np.rint(c[:, 0]).astype(int), 0, 319)]]
        if len(c) > 400:  # 20 pixels or more inside the mirror's image
            covered.append(np.mean(pts.query(c)[0] <= 1.0))
    assert len(covered) >= 10
    # lines lose a few pixels where they cross (the bands' edges meet), and short stubs beyond
    assert np.median(covered) > 0.9 and np.mean(covered) > 0.8
    allc = cKDTree(np.concatenate([c for _, c in curves]))
    d = allc.query(np.concatenate(det.uv))[0]
    assert np.mean(d <= 0.25) > 0.9  # band centres on the curves, to a fraction of a pixel
    assert det.denoise == "none"


def test_synthetic_families_are_the_true_directions(synthetic):
    cam, img, curves, dirs, det = synthetic
    assert len(det.families) == 2
    for name, s in dirs.items():
        ang = [np.degrees(np.arccos(min(1.0, abs(f.direction @ s)))) for f in det.families]
        k = int(np.argmin(ang))
        assert ang[k] < 0.2, (name, ang)
        assert len(det.families[k].lines) >= (6 if name == "z" else 3)
        assert ang[k] < max(0.05, 5 * det.families[k].std_deg)
    # every assigned line's plane holds its family's direction, within 3 sigma (and 1 degree)
    for i, f in enumerate(det.family):
        if f >= 0:
            s = det.families[f].direction
            assert (det.normal[i] @ s) ** 2 <= 9.0 * (s @ det.normal_cov[i] @ s + np.radians(0.1) ** 2)
            assert abs(det.normal[i] @ s) < np.radians(1.0)


def test_16_bit_and_float_images_give_the_same_lines():
    cam = load_rig("hyperboloid_central", width=320, height=240)
    img, _ = _synthetic(cam, _scene()[0])
    ref = detect_lines(img, cam)
    for other in (img.astype(np.uint16) * 257, img / 255.0, img[..., 0]):
        det = detect_lines(other, cam)
        assert len(det) == len(ref) and len(det.families) == len(ref.families)
        assert all(np.allclose(a, b, atol=1e-6) for a, b in zip(det.uv, ref.uv))


def test_view_lines_feed_the_relative_pose_estimator():
    from catadioptric.pose import ViewLines, fit_view_families

    cam = load_rig("hyperboloid_central", width=320, height=240)
    segs, dirs = _scene()
    img, _ = _synthetic(cam, segs)
    det = detect_lines(img, cam)
    vl = det.to_view_lines(min_pixels=20)
    assert isinstance(vl, ViewLines)
    assert set(vl.family) == set(range(len(det.families)))
    assert len(vl.uv) == int(np.sum((det.family >= 0) & (det.n_pixels >= 20)))
    est, fail = fit_view_families(vl)
    assert not fail
    for f, e in est.items():
        ang = min(np.degrees(np.arccos(min(1.0, abs(e.direction @ s)))) for s in dirs.values())
        assert ang < 0.3
    everything = det.to_view_lines(unassigned=True)
    assert len(everything.uv) == len(det) and everything.family.count(None) == int(np.sum(det.family < 0))


# --------------------------------------------------------------------------- real renders
@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    out = {}
    for renderer in ("povray", "mitsuba"):
        path = str(tmp_path_factory.mktemp(renderer) / "tiny")
        assert main(["render", "tiny_street", "--renderer", renderer, "--resolution", "small", "--quality", "draft",
                     "--out", path, "--no-progress"]) == 0
        out[renderer] = path
    return out


@pytest.mark.parametrize("renderer, recovered", [("povray", 0.5), ("mitsuba", 0.3)])
def test_rendered_views_lines_and_vertical_family(renders, renderer, recovered):
    ds = Dataset(renders[renderer])
    for v in ds:
        det = detect_lines(v["beauty"], v["camera"])
        assert det.denoise == ("nlmeans" if renderer == "mitsuba" else "none")
        r = evaluate_view(det, v, min_label_pixels=20)
        assert r["recovered_fraction"] > recovered, r
        assert r["line_precision"] > 0.6, r
        assert r["distance_median_px"] < 1.0
        vertical = [m for m in r["families_detected"] if m["true_family"] == 2]  # the street's vertical lines
        assert vertical and vertical[0]["angle_deg"] < 1.0, r["families_detected"]


def test_evaluation_scores_the_truth_perfectly_and_a_shifted_copy_not_at_all(renders):
    v = Dataset(renders["povray"])[0]
    truth = [t for t in label_curves(v) if len(t["uv"]) >= 20]
    fams = sorted({t["family"] for t in truth})
    F = {int(f["index"]): np.asarray(f["direction_M"]) for f in v["families"]}
    from catadioptric.detect import Family

    def across(uv, d):  # each curve moved by d pixels along its normal
        t = np.gradient(uv, axis=0)
        t /= np.linalg.norm(t, axis=1)[:, None]
        return uv + d * np.stack([-t[:, 1], t[:, 0]], axis=1)

    def fake(shift):
        fam_of = {f: k for k, f in enumerate(fams)}
        return DetectedLines(cam=v["camera"], uv=[across(t["uv"], shift) for t in truth], normal=np.zeros((len(truth), 3)),
                             normal_cov=np.zeros((len(truth), 3, 3)), rms=np.zeros(len(truth)),
                             polarity=np.zeros(len(truth), int), width=np.zeros(len(truth)),
                             family=np.array([fam_of[t["family"]] for t in truth]),
                             families=[Family(F[f], np.eye(3) * 1e-8, [], 0) for f in fams], image_size=(320, 240))

    r = evaluate_view(fake(0.0), v, min_label_pixels=20)
    assert r["recovered_fraction"] == 1.0 and r["line_precision_labels"] == 1.0
    assert r["family_precision"] == 1.0 and r["family_recall"] == 1.0 and r["assignment_accuracy"] == 1.0
    assert r["distance_median_px"] == 0.0
    r = evaluate_view(fake(3.0), v, min_label_pixels=20)
    assert r["recovered_fraction"] < 0.3 and r["line_precision_labels"] < 0.4  # neighbours 3 px apart remain


def test_lines_grouped_by_the_labels_are_each_familys_own(renders):
    """The detection grouped by the labels (the grouping's ceiling): the same lines, each family
    made only of lines of one labelled family (every line's own), its direction signed like the
    true one; the lines left out are those no labelled line matches, or one alone of its family."""
    from catadioptric.detect.evaluate import grouped_by_labels

    v = Dataset(renders["povray"])[0]
    det = detect_lines(v["beauty"], v["camera"])
    g = grouped_by_labels(det, v)
    assert g.uv is det.uv and len(g.family) == len(det)
    F = {int(f["index"]): np.asarray(f["direction_M"]) for f in v["families"]}
    r = evaluate_view(g, v, min_label_pixels=20)
    assert len(g.families) >= 2 and len(r["families_detected"]) == len(g.families)
    for k, (fam, m) in enumerate(zip(g.families, r["families_detected"])):
        assert m["members_share"] == 1.0 and len(fam.lines) >= 2
        assert fam.direction @ F[m["members_family"]] > 0
        assert sorted(fam.lines) == fam.lines and np.flatnonzero(g.family == k).tolist() == fam.lines
    assigned = int(np.sum(g.family >= 0))
    assert r["matched_lines"] - len(F) <= assigned <= r["matched_lines"]
    # one family per labelled family, in the order of their indices
    own = [m["members_family"] for m in r["families_detected"]]
    assert own == sorted(set(own))


def test_a_missed_family_is_given_its_cause(renders):
    """Detections made from the labelled curves themselves, each spoiled for one family in one way:
    the family is reported missed with that cause, and nothing is missed when nothing is spoiled."""
    v = Dataset(renders["povray"])[0]
    truth = [t for t in label_curves(v) if len(t["uv"]) >= 20]
    count = {}
    for t in truth:
        count[t["family"]] = count.get(t["family"], 0) + 1
    fams = sorted(f for f, n in count.items() if n >= 2)
    assert len(fams) >= 2
    F = {int(f["index"]): np.asarray(f["direction_M"]) for f in v["families"]}
    from catadioptric.detect import Family

    def det(spoil=None, victim=None):
        keep = [t for t in truth if not (spoil == "not detected" and t["family"] == victim)]
        # the families detected: the victim's is gone unless only its direction is spoiled
        found = [f for f in fams if not (spoil not in (None, "direction off") and f == victim)]
        fam_of = {f: k for k, f in enumerate(found)}
        label = np.array([fam_of.get(t["family"], -1) for t in keep])
        if spoil == "unassigned":
            label[[t["family"] == victim for t in keep]] = -1
        if spoil == "blended":  # its lines joined to the largest family
            label[[t["family"] == victim for t in keep]] = fam_of[largest]
        families = []
        for f in found:
            d = F[f]
            if spoil == "direction off" and f == victim:  # 5 degrees off, its lines right
                a = np.cross(d, [0.0, 0.0, 1.0]) if abs(d[2]) < 0.9 else np.cross(d, [1.0, 0.0, 0.0])
                d = np.cos(np.radians(5)) * d + np.sin(np.radians(5)) * a / np.linalg.norm(a)
            families.append(Family(d, np.eye(3) * 1e-8, np.flatnonzero(label == fam_of[f]).tolist(), 0))
        n = len(keep)
        return DetectedLines(cam=v["camera"], uv=[t["uv"] for t in keep], normal=np.zeros((n, 3)),
                             normal_cov=np.zeros((n, 3, 3)), rms=np.zeros(n), polarity=np.zeros(n, int),
                             width=np.zeros(n), family=label, families=families, image_size=(320, 240))

    assert evaluate_view(det(), v, min_label_pixels=20)["families_missed"] == []
    victim, largest = min(fams, key=lambda f: count[f]), max(fams, key=lambda f: count[f])
    assert count[victim] < count[largest]
    for spoil, cause in (("not detected", "lines not detected"), ("unassigned", "lines unassigned"),
                         ("direction off", "direction off"), ("blended", "blended")):
        missed = evaluate_view(det(spoil, victim), v, min_label_pixels=20)["families_missed"]
        assert [(m["family"], m["cause"]) for m in missed] == [(victim, cause)], (spoil, missed)
        assert missed[0]["lines"] == count[victim]


# --------------------------------------------------------------------------- CLI
def test_cli_image_and_dataset(renders, tmp_path, capsys):
    view = os.path.join(renders["povray"], "A")
    out = str(tmp_path / "one")
    assert main(["detect", os.path.join(view, "beauty.png"), "--rig", view, "--out", out]) == 0
    lines = json.load(open(os.path.join(out, "lines.json")))
    assert lines["format"] == "catadioptric-detected-lines/1" and len(lines["lines"]) > 10
    assert {ln["family"] for ln in lines["lines"]} >= {0}
    assert os.path.getsize(os.path.join(out, "overlay.png")) > 1000
    # a rig name gives the same camera as the dataset's (tiny_street's rig, at the image's size)
    out2 = str(tmp_path / "two")
    assert main(["detect", os.path.join(view, "beauty.png"), "--rig", "hyperboloid", "--out", out2]) == 0
    assert len(json.load(open(os.path.join(out2, "lines.json")))["lines"]) == len(lines["lines"])
    # a dataset: every view (here one) scored; a rerun reads the results back
    out3 = str(tmp_path / "ds")
    assert main(["detect", renders["povray"], "--views", "A", "--out", out3, "--no-progress"]) == 0
    rep = json.load(open(os.path.join(out3, "report.json")))
    assert [r["view"] for r in rep["views"]] == ["A"] and rep["summary"]["recovered_fraction"] > 0.5
    res = os.path.join(out3, "A", "result.json")
    t0 = os.stat(res).st_mtime_ns
    assert main(["detect", renders["povray"], "--views", "A", "--out", out3, "--no-progress"]) == 0
    assert os.stat(res).st_mtime_ns == t0
    assert "recovered" in open(os.path.join(out3, "report.md")).read()


def test_cli_preset_and_its_overrides(renders, tmp_path):
    """``--preset chessboard`` gives the preset's options (catadioptric.detect.PRESETS), a flag given
    beside it wins, and the lines.json records what was used."""
    from catadioptric.detect import PRESETS, preset_options

    png = os.path.join(renders["povray"], "A", "beauty.png")
    out = str(tmp_path / "p")
    assert main(["detect", png, "--rig", "hyperboloid", "--preset", "chessboard", "--threshold", "2",
                 "--out", out]) == 0
    used = json.load(open(os.path.join(out, "lines.json")))["options"]
    assert used["threshold"] == 2.0
    assert all(used[k] == v for k, v in PRESETS["chessboard"].items() if k != "threshold"), used
    assert preset_options(None, {"sigma": 2.0}) == {"sigma": 2.0}
    with pytest.raises(CatadioptricError, match=r"preset: expected one of \['chessboard'\], got 'wall'"):
        preset_options("wall")


@pytest.mark.parametrize("argv, message", [
    (["detect", "/nonexistent/x.png", "--rig", "sphere"], "IMAGE: expected an image file"),
    (["detect", "{png}"], "--rig: expected the rig of the image"),
    (["detect", "{png}", "--rig", "no_such_rig"], "--rig:"),
    (["detect", "{dataset}", "--rig", "sphere"], "--rig: a dataset's views are detected with their stored camera"),
    (["detect", "{dataset}", "--views", "Z"], "views: expected views of"),
    (["detect", "{png}", "--rig", "sphere", "--views", "A"], "--views: only for a dataset folder"),
    (["detect", "{png}", "--rig", "sphere", "--sigma", "-1"], "--sigma: expected a positive number"),
    (["detect", "{png}", "--rig", "sphere", "--denoise", "median"], "--denoise: invalid choice"),
])
def test_cli_errors_are_one_line(renders, tmp_path, capsys, argv, message):
    png = os.path.join(renders["povray"], "A", "beauty.png")
    argv = [a.format(png=png, dataset=renders["povray"]) for a in argv] + ["--out", str(tmp_path / "o")]
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and message in err and err.count("\n") == 1 and "Traceback" not in err


# --------------------------------------------------------------------------- errors
def test_bad_input_is_named():
    cam = load_rig("sphere", width=64, height=48)
    img = np.zeros((48, 64, 3), np.uint8)
    with pytest.raises(CatadioptricError, match=r"image: expected 64x48 pixels \(the camera's image size\), got 32x48"):
        detect_lines(img[:, :32], cam)
    with pytest.raises(CatadioptricError, match="image: expected uint8, uint16 or float pixels, got dtype bool"):
        detect_lines(img.astype(bool), cam)
    with pytest.raises(CatadioptricError, match="image: expected an .* array of at least 8 x 8 pixels"):
        detect_lines(np.zeros((48, 64, 5)), cam)
    with pytest.raises(CatadioptricError, match="image: expected finite values"):
        detect_lines(np.full((48, 64), np.nan), cam)
    with pytest.raises(CatadioptricError, match=r"options: expected some of .*, got unknown \['sigmaa'\]"):
        detect_lines(img, cam, sigmaa=1.0)
    with pytest.raises(CatadioptricError, match="denoise: expected one of"):
        detect_lines(img, cam, denoise="median")
    with pytest.raises(CatadioptricError, match="sigma: expected a positive number"):
        detect_lines(img, cam, sigma=0)
    with pytest.raises(CatadioptricError, match="cam: expected a CatadioptricCamera"):
        detect_lines(img, "sphere")
    with pytest.raises(CatadioptricError, match="min_pixels: expected an integer >= 0"):
        detect_lines(img, cam).to_view_lines(min_pixels=-1)
    # an empty image gives no lines, not an error
    det = detect_lines(img, cam)
    assert len(det) == 0 and det.families == [] and len(det.to_view_lines().uv) == 0


# --------------------------------------------------------------------------- memory (issue 39, item 3)
def test_detection_memory_does_not_grow_with_chains_times_centres(synthetic, monkeypatch):
    """A chain keeps a tangent of its own, not a row of an (N, 2) array of every centre (which kept
    the whole array alive per chain: chains x centres, 11 GB for a 2000x2000 image); the neighbour
    searches of the edge pairing and of the chain linking run in blocks of points, and each point's
    choice is its own: blocks of any size give the same lines."""
    import catadioptric.detect.centres as centres_mod
    import catadioptric.detect.chains as chains_mod
    from catadioptric.detect.chains import join_chains, link_chains

    cam, img, _, _, det = synthetic
    edges = subpixel_edges(img[..., 0].astype(float), mirror_region(cam, 3), sigma=1.0)
    centres, _ = pair_edges(edges)
    chains = link_chains(centres)
    assert chains and all(c["tangent"].base is None and c["tangent"].shape == (2,) for c in chains)
    assert all(c["tangent"].base is None for c in join_chains(chains))
    monkeypatch.setattr(centres_mod, "_BLOCK", 97)
    monkeypatch.setattr(chains_mod, "_BLOCK", 101)
    small = detect_lines(img, cam)
    assert len(small) == len(det) and len(small.chains) == len(det.chains)
    assert all(np.array_equal(a, b) for a, b in zip(small.uv, det.uv))
    assert all(np.array_equal(a, b) for a, b in zip(small.chains, det.chains))
    assert np.array_equal(small.family, det.family) and np.array_equal(small.normal, det.normal)


def test_the_image_size_limit_is_one_line():
    """MAX_PIXELS (docs/detect.md, "Image size"): 4096x4096 passes, a larger image is refused in
    one line naming what was given."""
    from catadioptric.detect.image import MAX_PIXELS, check_image_size

    assert MAX_PIXELS == 4096 * 4096
    check_image_size(4096, 4096, "IMAGE")
    check_image_size(16384, 1024, "IMAGE")
    with pytest.raises(CatadioptricError, match=r"^IMAGE: expected at most 16\.8 megapixels \(16777216 pixels, "
                                                r"e\.g\. 4096x4096: the memory limit of docs/detect\.md, "
                                                r"\"Image size\"\), got 20000x20000$"):
        check_image_size(20000, 20000, "IMAGE")
    with pytest.raises(CatadioptricError, match=r"got 4097x4096$"):
        check_image_size(4097, 4096, "IMAGE")
