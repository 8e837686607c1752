"""Relative pose when nothing is matched across the views (each image's own detections): the
family assignments a rotation allows, the lines matched by where they meet and what they look
like, the best assignment's margin over the next different answer held to a bar that grows with
the number of assignments tried, and the answer through the labelled path
(:func:`~catadioptric.pose.labelled.labelled_pose`) with its lines matched (docs/relative_pose.md,
"Without labels"). The front door is :func:`~catadioptric.pose.relative.relative_pose`.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .._checks import CatadioptricError
from . import matching
from .central import Parallax
from .families import ViewLines, fit_view_families, is_central
from .labelled import SAME_ANSWER_DEG, Candidate, PoseOptions, RelativePose, RivalInputs, labelled_pose
from .rotation import rotation_angle_deg
from .static import static_rotation

__all__ = ["unlabelled_pose", "matching_bar", "MATCHING_BARS"]

#: an ambiguous answer without labels: this many of its rivals (the cheapest, each a different answer
#: within the bar of the best) are refined as the best is (the labelled path with their own assignment
#: and lines), so that every answer the user must choose between is an estimate with a covariance. On
#: the real board pair 001-002 of validate/real the right motion listed second goes from 1.60 deg (the
#: assignment's rotation from the directions alone) to 1.30
_REFINED_RIVALS = 3
#: The margin an answer matched without labels needs over the next different answer when
#: ``decisive_matching`` is None (:func:`matching_bar`): ``(most assignments, bar)`` pairs, the first
#: that holds. The matching's cost counts meeting points that agree by chance, and the largest chance
#: margin grows with the number of rival assignments (docs/relative_pose.md, "The bar on the matching").
#: The margin held to it is the smaller of the matching's and its margin by the RANSAC's matchings alone:
#: so counted, wrong answers won by at most 10.2 and 29.7 on the benchmark (at most 24 assignments, and
#: more), 9.3 and 22.6 on its held-out pairs (code d8cd35b, bars 35 and 60 then). 25 is the two-view
#: bar ``decisive`` the verdict never goes below.
MATCHING_BARS = ((24, 25.0), (None, 40.0))

def matching_bar(n_assignments: int) -> float:
    """The margin (chi-square units) that an answer matched without labels needs over the next
    different answer, when ``n_assignments`` family assignments were tried (:data:`MATCHING_BARS`:
    25 for at most 24, 40 beyond: a Manhattan scene without a motion prior gives up to 48)."""
    if isinstance(n_assignments, bool) or not isinstance(n_assignments, (int, np.integer)) or n_assignments < 1:
        raise CatadioptricError(f"n_assignments: expected a positive integer, got {n_assignments!r}")
    for most, bar in MATCHING_BARS:
        if most is None or n_assignments <= most:
            return bar
    raise AssertionError("MATCHING_BARS ends with (None, bar)")

def unlabelled_pose(view_a: ViewLines, view_b: ViewLines, opts: PoseOptions) -> RelativePose:
    """Relative pose when nothing is matched across the views (lines from each image alone): the
    family assignments a rotation allows (:func:`~catadioptric.pose.matching.family_matches`), for
    each the lines matched by where they meet (:func:`~catadioptric.pose.matching.match_lines`),
    ranked by direction cost plus the meeting rays' cost (the same rays of A for every
    assignment); the best goes through the labelled path with its ends known."""
    # the lines left unmatched are mostly seen in both views: the refinement keeps them
    opts = replace(opts, one_view_lines=True)
    seed, f_scale, pixel_sigma, decisive = opts.seed, opts.f_scale, opts.pixel_sigma, opts.decisive
    max_pixels, min_families, max_rotation_deg = opts.max_pixels, opts.min_families, opts.max_rotation_deg
    model_error_px, decisive_matching = opts.model_error_px, opts.decisive_matching

    ea, fail_a = fit_view_families(view_a, seed=seed, f_scale=f_scale, pixel_sigma=pixel_sigma,
                                   max_pixels=max_pixels, exact=False, model_error_px=model_error_px,
                                   calibration_rms_px=opts.calibration_rms_px)
    eb, fail_b = fit_view_families(view_b, seed=seed, f_scale=f_scale, pixel_sigma=pixel_sigma,
                                   max_pixels=max_pixels, exact=False, model_error_px=model_error_px,
                                   calibration_rms_px=opts.calibration_rms_px)
    if len(ea) < min_families or len(eb) < min_families:
        raise CatadioptricError(f"views: expected at least {min_families} families of two or more lines in each "
                                f"view, got {len(ea)} in A and {len(eb)} in B")
    sigmas = [e.sigma for e in list(ea.values()) + list(eb.values()) if np.isfinite(e.sigma)]
    sigma = pixel_sigma if pixel_sigma is not None else max(float(np.median(sigmas)) if sigmas else f_scale,
                                                            0.1 * f_scale)
    matches = matching.family_matches(ea, eb, max_rotation_deg=max_rotation_deg)
    if not matches:
        raise CatadioptricError(f"views: no assignment of the {len(eb)} families of B to the {len(ea)} of A fits a "
                                "rotation" + ("" if max_rotation_deg is None else
                                              f" that turns by at most max_rotation_deg = {max_rotation_deg} degrees"))
    seen = view_a.appearance is not None and view_b.appearance is not None
    scored, geometry = [], {}
    for m in matches:
        lm = matching.match_lines(view_a, view_b, ea, eb, m, sigma_px=sigma, seed=seed)
        scored.append((m.cost + lm.cost, m, lm))
        if seen:  # the same assignment scored by the geometry alone (the evidence reported with the answer)
            geometry[id(m)] = matching.match_lines(view_a, view_b, ea, eb, m, sigma_px=sigma, seed=seed, appearance=False,
                                                   ordered=lm.ordered)
    scored.sort(key=lambda x: x[0] if np.isfinite(x[0]) else np.inf)
    best_score, best, lines = scored[0]
    others = [s for s, m, _ in scored[1:] if rotation_angle_deg(m.R @ best.R.T) > SAME_ANSWER_DEG]
    margin = (min(others) - best_score) if others else float("inf")
    # a rival that cannot be scored is no evidence for the winner: the answer is then ambiguous
    # (match_lines scores an assignment whose lines match nothing at its cost's ceiling, so this
    # holds only for costs that are not numbers at all; an infinite margin from unscored rivals
    # read as certainty: a grey and a colour image of one scene came out decisive, 118 degrees off)
    unscored = [s for s, m, _ in scored[1:] if not np.isfinite(s) and rotation_angle_deg(m.R @ best.R.T) > SAME_ANSWER_DEG]
    why_unscored = None
    if not np.isfinite(best_score):
        why_unscored = "no family assignment could be scored (its cost is not finite)"
    elif unscored:
        why_unscored = f"{len(unscored)} rival assignments could not be scored (their cost is not finite)"
    if why_unscored is not None:
        finite = [s for s in others if np.isfinite(s)]
        margin = max(0.0, min(finite) - best_score) if finite and np.isfinite(best_score) else 0.0
    no_lines = sum(1 for _, _, lm in scored if lm.t is None and lm.n_crossings > 0)
    bar = max(decisive, matching_bar(len(scored)) if decisive_matching is None else decisive_matching)
    # the lines matched in their order (LinesInOrder) choose their pairs by the cost that scores them:
    # they may rank an answer first, never make it decisive alone (docs/relative_pose.md, step 3)
    margin_unordered = _margin_unordered(scored)
    unordered_conflict = None
    if margin >= bar and margin_unordered < bar:
        unordered_conflict = (f"ambiguous: the lines matched in their order decide it (margin {margin:.1f}); the "
                              f"RANSAC's matchings alone give it {margin_unordered:.1f} against the bar of {bar:g}")
    static, conflict = None, None
    if is_central(view_a.cam) and why_unscored is None:
        static = static_rotation(view_a, view_b, ea, eb, [m.R for _, m, _ in scored], same_deg=SAME_ANSWER_DEG)
    if static is not None and margin >= bar and rotation_angle_deg(static.R @ best.R.T) > SAME_ANSWER_DEG:
        conflict = (f"ambiguous: the matching's answer (margin {margin:.1f}) and the rotation that shows "
                    f"{len(static.twins)} lines again unchanged (a camera turned in place) are "
                    f"{rotation_angle_deg(static.R @ best.R.T):.1f} deg apart")
        static = None
    if static is not None:  # the camera turned in place: its assignment goes through the labelled path
        scored.insert(0, scored.pop(static.index))
        best_score, best, lines = scored[0]
    va, vb, ends = _relabelled(view_a, view_b, ea, eb, best, lines)
    # the labelled path's families are these, B's under A's keys: not fitted again
    fitted = (ea, {a: replace(eb[b], key=a) for b, (a, _) in best.mapping.items()})
    res = labelled_pose(va, vb, ends, opts, fitted=fitted)
    res.candidates = [Candidate({str(b): (str(a), int(s)) for b, (a, s) in m.mapping.items()}, m.R,
                                None if lm.t is None else lm.t, score, m.cost, None, lm) for score, m, lm in scored]
    res.candidates[0] = Candidate(res.candidates[0].signs, res.R, res.t, best_score, best.cost, res.cov, lines)
    res.margin = float(margin)
    if static is not None:  # the lines seen again decide, not the matching
        unordered_conflict = None
    res.ambiguous = bool(margin < bar) or why_unscored is not None or conflict is not None or \
        unordered_conflict is not None
    res.evidence = _evidence(scored, geometry, margin, bar, static is not None)
    extra = [x for x in (conflict, unordered_conflict) if x is not None]
    if static is not None:
        res.ambiguous = False
        extra.append(_turned_in_place(res, static))
    # what left the answer ambiguous, for a later cue that may settle it (catadioptric.twoview)
    res.evidence["ambiguous_by"] = [] if not res.ambiguous else \
        [why for why, on in (("margin", margin < bar), ("unscored", why_unscored is not None),
                             ("turned_in_place", conflict is not None),
                             ("lines_in_order", unordered_conflict is not None)) if on]
    if res.ambiguous:
        refined = _refine_rivals(res, scored, bar, (view_a, view_b, ea, eb), opts)
        if refined:
            extra.append(f"ambiguous: {refined} rival answers within the bar refined as the best was (their lines "
                         f"and assignment through the labelled path): every candidate listed is an estimate")
    prior = "" if max_rotation_deg is None else f" (within the prior max_rotation_deg = {max_rotation_deg})"
    if no_lines:
        extra.append(f"{no_lines} of the {len(scored)} assignments matched no lines (no two meeting points of A near "
                     f"one of B under their rotation): scored as finding none of A's meeting points in B")
    if why_unscored is not None:
        extra.append(f"ambiguous: {why_unscored}, and an unscored rival is no evidence for the best answer")
    res.notes = [(f"families and lines matched without labels: {len(best.mapping)} families, {len(lines.pairs)} "
                  f"lines ({lines.n_inliers} of {lines.n_crossings} meeting points of A found in B); "
                  f"{len(scored)} family assignments tried{prior}; margin {margin:.1f} over the next answer "
                  f"against a bar of {bar:g}; "
                  + ("lines matched only where their brighter sides agree (appearance)"
                     if view_a.appearance is not None and view_b.appearance is not None else
                     "no appearance (lines matched by the geometry alone)")), *extra, *res.notes]
    res.notes += [f"family {k} of A not used: {v}" for k, v in fail_a.items()]
    res.notes += [f"family {k} of B not used: {v}" for k, v in fail_b.items()]
    return res

def _margin_unordered(scored) -> float:
    """The margin of the first of ``scored`` (``[(score, FamilyMatch, LineMatch)]``, best first) over
    the next different answer when every assignment is scored by the RANSAC's matchings alone
    (:attr:`~catadioptric.pose.matching.LineMatch.cost_unordered`); negative when they rank another
    answer first, inf when there is none."""
    costs = [m.cost + (lm.cost if lm.cost_unordered is None else lm.cost_unordered) for _, m, lm in scored]
    return _margin_over_next(costs, scored) if np.isfinite(costs[0]) else float("inf")


def _margin_over_next(costs: list, scored) -> float:
    """``costs`` (one per assignment of ``scored``, in its order): the first's margin over the
    cheapest finite one whose rotation is a different answer (more than ``SAME_ANSWER_DEG`` from the
    first's); inf when there is none."""
    best_R = scored[0][1].R
    others = [c for c, (_, m, _) in zip(costs[1:], scored[1:])
              if rotation_angle_deg(m.R @ best_R.T) > SAME_ANSWER_DEG and np.isfinite(c)]
    return float(min(others) - costs[0]) if others else float("inf")


def _refine_rivals(res, scored, bar: float, views: tuple, opts: PoseOptions) -> int:
    """An ambiguous answer's rivals within ``bar`` of the best (at most ``_REFINED_RIVALS``, each a
    different answer) refined through the labelled path with their own assignment and matched lines;
    their candidates in ``res`` take the refined ``R``, ``t`` and covariance (their cost stays the
    matching's, so the ranking does not change) and ``res.rivals`` each refined pose. The rivals
    within the bar beyond those keep what refining them takes (``res.rival_inputs``), for a later cue
    that ranks one of them first (:meth:`~catadioptric.pose.labelled.RelativePose.refine_rival`).
    A rival is one however few lines its matching found: with fewer than two, the labelled path
    gives it a rotation from its families' directions, as it gives the answer. Returns how many
    were refined."""
    view_a, view_b, ea, eb = views
    best_score, done = scored[0][0], [res.R]
    for k in range(1, len(scored)):
        score, m, lm = scored[k]
        if not np.isfinite(score) or score - best_score >= bar:
            continue
        if any(rotation_angle_deg(m.R @ R.T) <= SAME_ANSWER_DEG for R in done):
            continue
        va, vb, ends = _relabelled(view_a, view_b, ea, eb, m, lm)
        fitted = (ea, {a: replace(eb[b], key=a) for b, (a, _) in m.mapping.items()})
        res.rival_inputs[k] = RivalInputs(va, vb, ends, fitted, opts)
        if len(done) <= _REFINED_RIVALS and res.refine_rival(k):
            done.append(res.rivals[k].R)
    return len(done) - 1


def _evidence(scored, geometry: dict, margin: float, bar: float, turned_in_place: bool) -> dict:
    """What decided an answer without labels (:class:`RelativePose`'s ``evidence``): the margin of
    the matching and its bar, and the margin by the RANSAC's matchings alone (:func:`_margin_unordered`);
    with appearance, the margins the geometry alone gives the same answer over the next different
    one (negative when it ranks another first), and each candidate's cost by the geometry alone (in
    the candidates' order)."""
    out = {"margin": float(margin), "bar": float(bar), "appearance": bool(geometry),
           "margin_unordered": _margin_unordered(scored), "margin_geometry_alone": None,
           "margin_geometry_alone_unordered": None, "cost_geometry_alone": None, "turned_in_place": turned_in_place}
    if geometry:
        alone = [(m.cost + geometry[id(m)].cost, m, geometry[id(m)]) for _, m, _ in scored]
        costs = [c for c, _, _ in alone]
        out["margin_geometry_alone"] = _margin_over_next(costs, scored)
        out["margin_geometry_alone_unordered"] = _margin_unordered(alone)
        out["cost_geometry_alone"] = [float(c) for c in costs]
    return out

def _relabelled(view_a, view_b, ea, eb, match, lines):
    """The two views relabelled by a family assignment ``match`` and its matched ``lines``: B's
    families as A's (with the assignment's signs), matched lines with one id, the others an id of
    their own view (seen in one view only); and the families' matched ends."""
    a_id = [f"a{i}" for i in range(len(view_a.uv))]
    b_id = [f"b{j}" for j in range(len(view_b.uv))]
    for a_line, b_line in lines.pairs:
        a_id[a_line] = b_id[b_line] = f"line{a_line}"
    fam_b = [match.mapping[f][0] if f in match.mapping else ("unmatched", f) for f in view_b.family]
    va = ViewLines(view_a.cam, view_a.uv, view_a.family, a_id)
    vb = ViewLines(view_b.cam, view_b.uv, fam_b, b_id)
    ends = {a: (ea[a].direction, eb[b].direction * sign) for b, (a, sign) in match.mapping.items()}
    return va, vb, ends

def _turned_in_place(res, static) -> str:
    """``res`` as the pose of a camera turned in place (:func:`~catadioptric.pose.static.static_rotation`):
    the rotation from the lines seen again unchanged, and ``t`` zero, unless the answer's meeting
    points show a translation that matched more lines than the rotation alone shows unchanged (a
    camera that moved, seeing far lines: its rotation and translation stand). Returns the note."""
    res.turned_in_place = static
    if res.translation_observable and res.t is not None and res.lines_matched > len(static.twins):
        return (f"decisive by the lines seen again unchanged: {len(static.twins)} under its rotation, the "
                f"{static.rivals} rival rotations at most {static.rival_twins}; the translation matched more "
                f"lines ({res.lines_matched}) and stands")
    res.R = static.R
    res.t = np.zeros(3)
    res.cov = np.full((6, 6), np.nan)
    res.cov[:3, :3] = static.cov
    res.parallax = Parallax(float("nan"), 0, float("nan"), False, 0, float("nan"))
    res.candidates[0] = Candidate(res.candidates[0].signs, res.R, res.t, res.candidates[0].cost,
                                  res.candidates[0].direction_cost, res.cov, res.candidates[0].fit)
    return static.note()
