"""Detected lines scored against a rendered view's labels (the labels are used here only).

For a dataset view (:class:`catadioptric.DatasetView`): each labelled line's visible exact curve
(``view["curves"]`` where the label image shows the line, one point per pixel of arc length:
:func:`catadioptric.observations.curve_pixels`) is the truth.

* **Recovered** (per labelled line, and over all labelled pixels of the lines with at least
  ``min_label_pixels``): the fraction of its curve points within ``tolerance`` pixels of a pixel
  of some detected line.
* **Line precision**: a detected line matches the labelled line nearest most of its pixels when
  at least ``match_fraction`` of them lie within ``tolerance`` of that line's curve; precision
  is the fraction of detected lines that match one (any labelled line, short ones included):
  ``line_precision_labels`` against the curves where the label image shows the lines,
  ``line_precision`` also counting the visible curves whose tube covers no pixel centre (thinner
  than a pixel near the mirror's rim: real lines the label image misses). The lines matched to
  label-shown curves give the detector's accuracy (pixel distances: median, rms).
* **Families**: the true families of the view are those with at least two labelled lines of
  ``min_label_pixels``; a detected family matches a true one when the angle between their
  directions (either sign) is at most ``max(angle_deg, sigmas x its standard error)``
  (``true_family``: a test of its direction). It *is* the true family of more than half of its
  lines that match labelled lines (``members_family``, ``members_share``: a test of its lines,
  whatever its direction's bias), none if no family has that many; when fewer than two of its
  lines match labelled lines, its direction decides (``true_family``). Precision:
  detected families that match a true one; recall: true families matched by a detected one
  (``family_recall``; ``family_recall_3`` over the true families with three lines or more).
  Line assignment: the fraction of the detected lines assigned to a family whose matched true
  family is the family of the line's matched labelled line.
* **Why a true family is missed** (``families_missed``, one entry per true family no detected
  family matches): its labelled lines (of ``min_label_pixels``), how many a detected line matches,
  the detected families those lines went to (-1: unassigned), and the first cause that holds:
  ``"lines not detected"`` (fewer than two of its lines detected), ``"lines unassigned"`` (fewer
  than two of its detected lines in a family), ``"direction off"`` (a detected family is this
  family by its lines, ``members_family``, but its direction is beyond the tolerance),
  ``"blended"`` (its lines went to families that are other families, or none, by their lines).
* **Grouped by the labels** (:func:`grouped_by_labels`): the detection with its families made
  from the labels instead of its vote, each detected line in the family of the labelled line it
  matches (as line precision matches them), unmatched lines in none, each family's direction
  fitted on its lines' planes: the grouping's ceiling for those lines.
"""
from __future__ import annotations

import numpy as np

__all__ = ["label_curves", "visible_curves", "evaluate_view", "grouped_by_labels"]


def label_curves(view, min_points: int = 2) -> list[dict]:
    """The visible exact curve of every labelled line of ``view``: dicts with ``segment``,
    ``family``, ``label``, ``uv (M, 2)``."""
    from ..observations import curve_pixels

    labels, curves = view["labels"], view["curves"]
    out = []
    for ln in view["lines"]:
        lab = int(ln.get("label", 0) or 0)
        if lab <= 0:
            continue
        uv = curve_pixels(curves, labels, int(ln["index"]), lab)
        if len(uv) >= min_points:
            out.append({"segment": int(ln["index"]), "family": int(ln["family"]), "label": lab, "uv": uv})
    return out


def visible_curves(view) -> list[dict]:
    """The exact curve of every labelled line of ``view`` where it is visible (not hidden by
    another object) and on the image, whether or not its tube covers a pixel centre there (a
    tube thinner than a pixel, seen at a grazing angle near the mirror's rim, leaves no label):
    dicts with ``segment``, ``family``, ``uv``."""
    fam = {int(ln["index"]): int(ln["family"]) for ln in view["lines"] if int(ln.get("label", 0) or 0) > 0}
    out = []
    for c in view["curves"]:
        seg = int(c["segment"])
        ok = np.asarray(c["visible"], bool) & np.asarray(c["in_image"], bool)
        if seg in fam and ok.sum() >= 2:
            out.append({"segment": seg, "family": fam[seg], "uv": np.asarray(c["uv"])[ok]})
    return out


def _angle_deg(a, b) -> float:
    c = abs(float(np.dot(a, b)) / (np.linalg.norm(a) * np.linalg.norm(b)))
    return float(np.degrees(np.arccos(min(1.0, c))))


def _match_lines(det_uv, truth, tolerance, match_fraction):
    """Per detected line the index of the curve of ``truth`` that holds at least ``match_fraction``
    of its pixels within ``tolerance`` (-1 if none), and those pixels' distances to it."""
    from scipy.spatial import cKDTree

    match = np.full(len(det_uv), -1, dtype=np.int64)
    dists = []
    if not (det_uv and truth):
        return match, dists
    pts = np.concatenate([t["uv"] for t in truth])
    owner = np.concatenate([np.full(len(t["uv"]), k) for k, t in enumerate(truth)])
    tree = cKDTree(pts)
    for i, u in enumerate(det_uv):
        d, j = tree.query(u, distance_upper_bound=tolerance + 1e-9)
        near = np.isfinite(d)
        if not near.any():
            continue
        k = int(np.bincount(owner[j[near]]).argmax())
        # distance to that curve alone (the nearest point of another curve may be closer)
        dk, _ = cKDTree(truth[k]["uv"]).query(u)
        ok = dk <= tolerance
        if ok.mean() >= match_fraction:
            match[i] = k
            dists.append(dk[ok])
    return match, dists


def evaluate_view(det, view, *, tolerance: float = 1.5, min_label_pixels: int = 30, match_fraction: float = 0.5,
                  angle_deg: float = 1.0, sigmas: float = 3.0) -> dict:
    """Scores of ``det`` (:class:`~catadioptric.detect.DetectedLines`) against the labels of
    ``view`` (module docstring). Returns a JSON-ready dict."""
    from scipy.spatial import cKDTree

    truth = label_curves(view)
    long_ = [t for t in truth if len(t["uv"]) >= min_label_pixels]
    det_uv = [np.asarray(u) for u in det.uv]
    res = {"tolerance_px": tolerance, "min_label_pixels": min_label_pixels,
           "labelled_lines": len(long_), "labelled_pixels": int(sum(len(t["uv"]) for t in long_)),
           "detected_lines": len(det_uv), "detected_pixels": int(sum(len(u) for u in det_uv))}
    # recovered
    if det_uv and long_:
        tree = cKDTree(np.concatenate(det_uv))
        per_line = []
        hit_all = 0
        for t in long_:
            d, _ = tree.query(t["uv"], distance_upper_bound=tolerance + 1e-9)
            h = int(np.sum(np.isfinite(d)))
            hit_all += h
            per_line.append(h / len(t["uv"]))
        res["recovered_fraction"] = hit_all / res["labelled_pixels"]
        res["lines_recovered_half"] = float(np.mean(np.array(per_line) >= 0.5))
    else:
        res["recovered_fraction"] = 0.0 if long_ else None
        res["lines_recovered_half"] = 0.0 if long_ else None
    # line precision: against the label-shown curves, and against the visible exact curves
    match, dists = _match_lines(det_uv, truth, tolerance, match_fraction)
    res["line_precision_labels"] = float(np.mean(match >= 0)) if len(det_uv) else None
    vis = visible_curves(view)
    vmatch, _ = _match_lines(det_uv, vis, tolerance, match_fraction)
    res["line_precision"] = float(np.mean((vmatch >= 0) | (match >= 0))) if len(det_uv) else None
    res["matched_lines"] = int(np.sum(match >= 0))
    res["matched_segments"] = len({truth[k]["segment"] for k in match if k >= 0})
    if dists:
        allx = np.concatenate(dists)
        res["distance_median_px"] = float(np.median(allx))
        res["distance_rms_px"] = float(np.sqrt(np.mean(allx**2)))
    # families
    fam_dirs = {int(f["index"]): np.asarray(f["direction_M"], float) for f in view["families"]}
    count = {}
    for t in long_:
        count[t["family"]] = count.get(t["family"], 0) + 1
    present = sorted(f for f, n in count.items() if n >= 2)
    det_match = []
    for fam in det.families:
        best, best_a = None, np.inf
        for f, s in fam_dirs.items():
            a = _angle_deg(fam.direction, s)
            if a < best_a:
                best, best_a = f, a
        tol = max(angle_deg, sigmas * fam.std_deg)
        det_match.append({"true_family": best if best_a <= tol else None, "angle_deg": best_a, "tolerance_deg": tol,
                          "lines": len(fam.lines), "pixels": fam.pixels})
    # which family each detected family is, by its lines: the true family of most of its lines that
    # match a labelled line (a family whose direction is biased beyond the tolerance is still that
    # family; one whose lines come from several families, e.g. the horizon's, is none)
    for fam, m in zip(det.families, det_match):
        fams = [truth[match[i]]["family"] for i in fam.lines if match[i] >= 0]
        top = np.bincount(fams).argmax() if fams else None
        share = fams.count(top) / len(fams) if fams else 0.0
        if len(fams) >= 2:
            m["members_family"] = int(top) if share > 0.5 else None
        else:  # its lines match no labelled line (markings thinner than a pixel): its direction decides
            m["members_family"] = m["true_family"]
        m["members_share"] = share
    matched_true = {m["true_family"] for m in det_match if m["true_family"] is not None}
    res["families_true"] = present
    res["families_detected"] = det_match
    res["family_precision"] = (float(np.mean([m["true_family"] is not None for m in det_match]))
                               if det_match else None)
    res["family_recall"] = (len(matched_true & set(present)) / len(present)) if present else None
    big = [f for f in present if count[f] >= 3]
    res["families_true_3"] = big
    res["family_recall_3"] = (len(matched_true & set(big)) / len(big)) if big else None
    res["families_missed"] = _missed(present, long_, truth, match, det, det_match, matched_true)
    # line assignment: a detected line's family against its labelled line's family
    assigned = [(i, int(det.family[i])) for i in range(len(det_uv)) if det.family[i] >= 0 and match[i] >= 0]
    if assigned:
        good = [det_match[f]["true_family"] == truth[match[i]]["family"] for i, f in assigned]
        res["assignment_accuracy"] = float(np.mean(good))
    else:
        res["assignment_accuracy"] = None
    res["assigned_fraction"] = float(np.mean(det.family >= 0)) if len(det_uv) else None
    return res


def _missed(present, long_, truth, match, det, det_match, matched_true) -> list[dict]:
    """Each true family that no detected family matches, with what became of its lines (module
    docstring, "Why a true family is missed")."""
    out = []
    for f in present:
        if f in matched_true:
            continue
        segs = {t["segment"] for t in long_ if t["family"] == f}
        found = [i for i in range(len(match)) if match[i] >= 0 and truth[match[i]]["segment"] in segs]
        detected = len({truth[match[i]]["segment"] for i in found})
        went = {}
        for i in found:
            went[int(det.family[i])] = went.get(int(det.family[i]), 0) + 1
        assigned = sum(n for k, n in went.items() if k >= 0)
        if detected < 2:
            cause = "lines not detected"
        elif assigned < 2:
            cause = "lines unassigned"
        elif any(k >= 0 and det_match[k].get("members_family") == f for k in went):
            cause = "direction off"
        else:
            cause = "blended"
        out.append({"family": int(f), "lines": len(segs), "lines_detected": detected,
                    "went_to": {str(k): n for k, n in sorted(went.items())}, "cause": cause})
    return out


def grouped_by_labels(det, view, *, tolerance: float = 1.5, match_fraction: float = 0.5, min_lines: int = 2):
    """A copy of the detection ``det`` grouped by the labels of ``view`` (module docstring): every
    true family with at least ``min_lines`` matched detected lines becomes a family of those lines
    (its direction fitted on their planes from the true one's, signed like it); every other line
    is unassigned. Its families are the view's in the order of their indices."""
    from dataclasses import replace

    from .families import Family, refine_direction

    truth = label_curves(view)
    match, _ = _match_lines([np.asarray(u) for u in det.uv], truth, tolerance, match_fraction)
    true_dirs = {int(f["index"]): np.asarray(f["direction_M"], float) for f in view["families"]}
    by_family = {}
    for i, k in enumerate(match):
        if k >= 0:
            by_family.setdefault(int(truth[k]["family"]), []).append(i)
    family = np.full(len(det.uv), -1, dtype=np.int64)
    families = []
    for f, lines in sorted(by_family.items()):
        if len(lines) < min_lines:
            continue
        s, cov = refine_direction(det.normal, det.normal_cov, np.array(lines), true_dirs[f])
        family[lines] = len(families)
        families.append(Family(direction=s, cov=cov, lines=lines,
                               pixels=int(sum(len(det.uv[i]) for i in lines))))
    return replace(det, family=family, families=families)
