"""The image-only relative pose (:mod:`catadioptric.twoview`) scored on a rendered view pair: the
labels are used here only, to score.

Per pair: each view's detection scores (:func:`catadioptric.detect.evaluate_view`: labelled
pixels recovered, families found against the true ones), the families matched across the two
views against the truth, and the rotation and translation errors, for each motion prior of
``priors`` (``None``: no prior; a number: ``max_rotation_deg``).

Families: the label path uses every family with two or more labelled lines of ``min_pixels`` in
both views (``families_label``). A matched family (B's detected family ``b`` to A's ``a`` with
sign ``s``) is right when both detected families are the same true family and the answer's
rotation turns A's direction to the same end of B's as the true rotation does (the right sign).
Which true family a detected family is: that of most of its lines (``members_family`` of
:func:`catadioptric.detect.evaluate_view`); the keys ending in ``_direction`` ask also that its
direction be within the detection's direction tolerance (``true_family``).
``families_right``: every matched family is right;
``families_recall``: the fraction of ``families_label`` matched right; ``same_families``: both;
``same_families_3``: every matched family right and every family with three or more labelled lines
of ``min_pixels`` in each view (``families_label_3``: those one image can single out) matched.
``families_lost``: each family of ``families_label`` not matched right, with where it was lost: in
each view ``"in a family"`` (a detected family is it, by its lines) or the cause the detection's
scores give (``families_missed`` of :func:`catadioptric.detect.evaluate_view`: lines not detected,
lines unassigned, blended), and ``cause``: ``"A: ..."`` or ``"B: ..."`` when a view has no family
of it (A's first), else ``"matched wrong"`` (in a matched family that is not right) or ``"not
matched"`` (in a family in both views, left out of the assignment).
"""
from __future__ import annotations

import time

import numpy as np

from .._checks import CatadioptricError
from .relative_pose import angle_between_deg

__all__ = ["evaluate_image_pair"]


def _families_check(family_map, dets, scores, R, R_gt, label_families, label_families_3=()):
    out = {}
    # identity by the family's lines (``members_family``), and, stricter, by its direction too
    # (``true_family``: within the direction tolerance of evaluate_view)
    for suffix, key in (("", "members_family"), ("_direction", "true_family")):
        true_a = [m[key] for m in scores[0]["families_detected"]]
        true_b = [m[key] for m in scores[1]["families_detected"]]
        rows, right_true = [], set()
        for b, (a, s) in sorted(family_map.items()):
            ta, tb = true_a[a], true_b[b]
            # the estimator refits the directions (their signs are its own): the sign of the answer is
            # the one its rotation gives to the detected directions
            da, db = dets[0].families[a].direction, dets[1].families[b].direction
            sign_ok = bool(((R @ da) @ db) * ((R_gt @ da) @ db) > 0)
            ok = ta is not None and ta == tb and sign_ok
            if ok:
                right_true.add(ta)
            rows.append({"family_a": a, "family_b": b, "sign": s, "true_a": ta, "true_b": tb, "sign_right": sign_ok,
                         "right": ok})
        recall = len(right_true & set(label_families)) / len(label_families) if label_families else None
        right = all(r["right"] for r in rows) and bool(rows)
        out |= {"matched" + suffix: rows, "families_right" + suffix: right, "families_recall" + suffix: recall,
                "same_families" + suffix: bool(right and recall == 1.0),
                "same_families_3" + suffix: bool(right and set(label_families_3) <= right_true)}
    out["families_lost"] = _lost(scores, label_families, out["matched"])
    return out


def _geometry_alone(res, R_gt) -> dict:
    """Without the lines' appearance: the margin of the answer by the geometry alone and how far off
    the candidate the geometry alone ranks first is (its assignment's rotation; None without appearance)."""
    from ..pose import rotation_angle_deg

    ev = res.evidence or {}
    costs = ev.get("cost_geometry_alone")
    out = {"matching_bar": ev.get("bar"), "turned_in_place": bool(ev.get("turned_in_place")),
           "margin_unordered": ev.get("margin_unordered"), "margin_geometry_alone": None,
           "margin_geometry_alone_unordered": None, "rotation_error_geometry_alone_deg": None}
    if costs:
        first = res.candidates[int(np.argmin(np.where(np.isfinite(costs), costs, np.inf)))]
        out |= {"margin_geometry_alone": ev["margin_geometry_alone"],
                "margin_geometry_alone_unordered": ev["margin_geometry_alone_unordered"],
                "rotation_error_geometry_alone_deg": rotation_angle_deg(first.R @ R_gt.T)}
    return out


def _look(res, R_gt) -> dict:
    """What the images' look said of an answer the geometry left ambiguous by its margin
    (:func:`catadioptric.look.settle_by_look`; None where it was not asked): whether it decided;
    the answer it takes (the geometry's first of those within ``LOOK_SAME_DEG`` of the one that
    agrees best), its rotation error, the best agreement's margin over every other answer,
    whether the geometry keeps it within its bar of the best, and how much better a rotation near it
    agrees (None where that was not looked for), the agreement of the answer it takes and its
    standard error (None where not measured); and whether the look, asked of an answer the
    geometry decided, contradicted it and left it ambiguous (:func:`catadioptric.look.check_by_look`;
    None where it was not asked), with the margin by which the best other answer beyond
    ``LOOK_SAME_DEG`` agrees better than the answer (negative: worse) and that margin's standard error
    (None where not measured)."""
    from .._io import jsonable
    from ..pose import rotation_angle_deg

    lk = (res.evidence or {}).get("look")
    check = (res.evidence or {}).get("look_check")
    out = {"look_decided": None, "look_margin": None, "look_best_error_deg": None, "look_best_within_bar": None,
           "look_nearby_gain": None, "look_agreement": None, "look_agreement_se": None, "look_contradicts": None,
           "look_check_margin": None, "look_check_se": None}
    if check is not None:
        out |= {"look_contradicts": bool(check["contradicts"]), "look_check_margin": jsonable(check["margin"]),
                "look_check_se": jsonable(check["margin_se"])}
    if not lk:
        return out
    out |= {"look_decided": bool(lk["decided"]), "look_margin": float(lk["margin"]),
            "look_agreement_se": jsonable(lk.get("agreement_se"))}
    if lk["best"] is not None:
        first = res.candidates[0] if lk["decided"] else None  # a decided answer is the look's best, first
        best = first if first is not None else res.candidates[lk["best"]]
        cost0 = min(c.cost for c in res.candidates)
        out |= {"look_agreement": jsonable(lk["agreement"][lk["candidates"].index(lk["best"])]),
                "look_best_error_deg": rotation_angle_deg(best.R @ R_gt.T),
                "look_best_within_bar": bool(best.cost - cost0 < res.evidence["bar"])}
        if lk["nearby"] is not None:
            out["look_nearby_gain"] = float(lk["nearby"]["agreement"] - lk["agreement"][lk["candidates"].index(lk["best"])])
    return out


def _look_translation(res, t_true) -> dict:
    """The images' look's direction of the translation (:func:`catadioptric.look.translation_by_look`)
    against the true one, ``t_true`` (B's frame, from A's centre to B's, as the central model's
    translation is scored): ``translation_direction_error_look_deg`` and the parallax it found
    (``look_parallax``, the baseline over the scene's distance); None where it was not measured or no
    parallax agreed better than the scene at infinity; ``look_translation_taken``: what of the answer's
    translation the look decided, ``"sign"`` (a central direction turned round), ``"direction"`` (a
    metric one replaced by the look's) or None."""
    lt = (res.evidence or {}).get("look_translation")
    taken = None if not lt else "sign" if lt["sign_from_look"] else \
        "direction" if lt.get("translation_from_look") else None
    if not lt or lt["direction"] is None:
        return {"translation_direction_error_look_deg": None, "look_parallax": None if not lt else lt["parallax"],
                "look_translation_taken": taken}
    return {"translation_direction_error_look_deg": angle_between_deg(np.asarray(lt["direction"]), t_true),
            "look_parallax": lt["parallax"], "look_translation_taken": taken}


def _mahalanobis(res, R_gt, t_gt) -> dict:
    """The errors against the answer's own covariance: ``rotation_mahalanobis2``, ``w^T C_w^-1 w`` for
    the error rotation ``exp(w) = R R_gt^T`` (left, as the covariance), and
    ``translation_mahalanobis2`` for a metric translation; a chi-square of 3 degrees of freedom
    (median 2.366) for a right covariance. None where the covariance is not known."""
    from scipy.spatial.transform import Rotation

    out = {"rotation_mahalanobis2": None, "translation_mahalanobis2": None}
    cov = None if res.cov is None else np.asarray(res.cov, float)
    if cov is None or not np.all(np.isfinite(cov[:3, :3])):
        return out
    w = Rotation.from_matrix(res.R @ R_gt.T).as_rotvec()
    try:
        out["rotation_mahalanobis2"] = float(w @ np.linalg.solve(cov[:3, :3], w))
        if res.metric and res.t is not None and np.all(np.isfinite(cov[3:, 3:])):
            e = np.asarray(res.t, float) - t_gt
            out["translation_mahalanobis2"] = float(e @ np.linalg.solve(cov[3:, 3:], e))
    except np.linalg.LinAlgError:
        pass
    return out


def _lost(scores, label_families, rows) -> list[dict]:
    """Each label family not matched right, and where it was lost (module docstring)."""
    right = {r["true_a"] for r in rows if r["right"]}
    out = []
    for f in label_families:
        if f in right:
            continue
        rec = {"family": int(f)}
        for side, sc in zip("AB", scores):
            if any(m.get("members_family") == f for m in sc["families_detected"]):
                rec[side] = "in a family"
            else:
                why = [m["cause"] for m in sc.get("families_missed", []) if m["family"] == f]
                # not missed by direction, yet no family is it by its lines: the family of its
                # direction holds mostly other lines
                rec[side] = why[0] if why else "blended"
        gone = [f"{side}: {rec[side]}" for side in "AB" if rec[side] != "in a family"]
        if gone:
            rec["cause"] = gone[0]
        else:
            rec["cause"] = "matched wrong" if any(f in (r["true_a"], r["true_b"]) for r in rows) else "not matched"
        out.append(rec)
    return out


def evaluate_image_pair(dataset, names, *, priors=(None, 60.0), min_pixels: int = 30, detect_options=None,
                        overlay: str | None = None, joint: bool = True, look: bool = True, threads: int = 2,
                        grouping: str = "detector") -> dict:
    """Score the image-only path on the view pair ``names = (A, B)`` of ``dataset`` (a folder or a
    :class:`catadioptric.Dataset`) for each motion prior. ``overlay``: a PNG path for the pair's
    overlay (the answer of the last prior). ``joint``: see
    :func:`catadioptric.twoview.pose_from_detections`; ``look``: an answer left ambiguous by its
    margin decided by the images' look where it can be (:func:`catadioptric.look.settle_by_look`);
    ``threads``: as :func:`catadioptric.pose.relative_pose`'s. ``grouping``: ``"detector"`` (the
    detector's families) or ``"labels"`` (the detected lines grouped by the labels instead of the
    detector's vote, :func:`catadioptric.detect.evaluate.grouped_by_labels`; the rest of the path as
    it is, the families found in both views at once included: the one-view grouping's ceiling).
    Returns a JSON-ready dict (with ``"grouping": "labels"`` when so grouped)."""
    from threadpoolctl import threadpool_limits

    if grouping not in ("detector", "labels"):
        raise CatadioptricError(f"grouping: expected 'detector' or 'labels', got {grouping!r}")
    with threadpool_limits(1):
        out = _evaluate(dataset, names, priors, min_pixels, detect_options, overlay,
                        (joint, look, threads, grouping == "labels"))
    return out if grouping == "detector" else out | {"grouping": grouping}


def _evaluate(dataset, names, priors, min_pixels, detect_options, overlay, steps):
    from ..dataset import Dataset
    from ..detect import detect_lines, evaluate_view
    from ..detect.evaluate import grouped_by_labels
    from ..pose import rotation_angle_deg
    from ..pose.families import rays_centre
    from ..look import settle_by_look, translation_by_look
    from ..twoview import pair_overlay, pose_from_detections

    ds = dataset if isinstance(dataset, Dataset) else Dataset(dataset)
    if len(names) != 2 or any(n not in ds.names for n in names):
        raise CatadioptricError(f"views: expected two view names among {ds.names}, got {list(names)}")
    va, vb = ds[names[0]], ds[names[1]]
    R_gt = vb["pose"].R @ va["pose"].R.T
    t_gt = vb["pose"].t - R_gt @ va["pose"].t
    joint, look, threads, by_labels = steps
    t0 = time.perf_counter()
    dets = [detect_lines(v["beauty"], v["camera"], **(detect_options or {})) for v in (va, vb)]
    if by_labels:
        dets = [grouped_by_labels(d, v) for d, v in zip(dets, (va, vb))]
    t_detect = time.perf_counter() - t0
    scores = [evaluate_view(d, v, min_label_pixels=min_pixels) for d, v in zip(dets, (va, vb))]
    label_families = sorted(set(scores[0]["families_true"]) & set(scores[1]["families_true"]))
    label_families_3 = sorted(set(scores[0]["families_true_3"]) & set(scores[1]["families_true_3"]))
    out = {"views": list(names), "R_gt": R_gt, "t_gt": t_gt, "baseline_m": float(np.linalg.norm(t_gt)),
           "turn_deg": rotation_angle_deg(R_gt), "detect_seconds": t_detect,
           "detection": [{k: s[k] for k in ("recovered_fraction", "line_precision", "family_precision",
                                            "family_recall", "family_recall_3", "distance_median_px",
                                            "detected_lines") if k in s}
                         | {"families_detected": len(d.families), "denoise": d.denoise}
                         for s, d in zip(scores, dets)],
           "families_label": label_families, "families_label_3": label_families_3, "runs": []}
    centres = [rays_centre(c) for c in (va["camera"], vb["camera"])]
    last = None
    looked = {}  # the look's translation under each rotation met (the priors often give the same answer)
    for prior in priors:
        rec = {"max_rotation_deg": prior}
        t1 = time.perf_counter()
        try:
            pair = pose_from_detections(dets[0], dets[1], min_pixels=min_pixels, max_rotation_deg=prior, joint=joint,
                                        threads=threads)
        except CatadioptricError as exc:
            rec.update({"error": str(exc), "seconds": time.perf_counter() - t1})
            out["runs"].append(rec)
            continue
        if look:
            settle_by_look(pair, (va["beauty"], vb["beauty"]), (va["camera"], vb["camera"]))
            key = pair.pose.R.tobytes()
            found = translation_by_look(pair, (va["beauty"], vb["beauty"]), (va["camera"], vb["camera"]),
                                        known=looked.get(key))
            if found is not None:
                looked[key] = found
        res, fmap = pair.pose, pair.family_map
        # the families found in both views at once are scored as the detected ones are
        fdets = pair.detections
        fscores = scores if fdets[0] is dets[0] and fdets[1] is dets[1] else \
            [evaluate_view(d, v, min_label_pixels=min_pixels) for d, v in zip(fdets, (va, vb))]
        rec.update({"rotation_error_deg": rotation_angle_deg(res.R @ R_gt.T), "ambiguous": res.ambiguous,
                    "margin": res.margin, "metric": res.metric, "lines_matched": res.lines_matched,
                    "rotation_std_deg": res.rotation_std_deg, "translation_error_m": None,
                    "translation_direction_error_deg": None, "seconds": time.perf_counter() - t1,
                    "candidates": len(res.candidates), "notes": res.notes})
        rec.update(_geometry_alone(res, R_gt))
        rec.update(_look(res, R_gt))
        if res.t is not None:
            if res.metric:
                rec["translation_error_m"] = float(np.linalg.norm(res.t - t_gt))
                rec["translation_direction_error_deg"] = angle_between_deg(res.t, t_gt)
            else:
                rec["translation_direction_error_deg"] = angle_between_deg(res.t, R_gt @ centres[0] + t_gt - centres[1])
        rec.update(_look_translation(res, R_gt @ centres[0] + t_gt - centres[1]))
        rec.update(_mahalanobis(res, R_gt, t_gt))
        rec.update(_families_check(fmap, fdets, fscores, res.R, R_gt, label_families, label_families_3))
        out["runs"].append(rec)
        last = pair
    if overlay is not None and last is not None:
        from ..detect.report import write_png

        write_png(overlay, pair_overlay(va["beauty"], vb["beauty"], last))
    return out
