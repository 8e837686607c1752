"""The images' look: which of the answers a pose from two images' lines allows agrees with the
pictures themselves (:func:`settle_by_look`), and whether an answer the lines decided does
(:func:`check_by_look`).

Each answer's rotation turns image A onto image B; their agreement is the correlation of B with A
so turned (:class:`catadioptric.photometric.RotationAgreement`, a scene at infinity), with its
jackknife standard error over blocks of B. The rules, their bars and how they were measured:
docs/relative_pose.md ("The images' look").
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .twoview import ImagePairPose

__all__ = ["LOOK_BAR", "LOOK_SAME_DEG", "LOOK_SIGMAS", "PARALLAX_STEP", "TRANSLATION_APART_DEG", "settle_by_look",
           "check_by_look", "translation_by_look", "look_choice", "LookChoice", "ranked_agreement", "look_figure"]


#: the agreement of the images (:func:`catadioptric.photometric.rotation_agreement`, a correlation) by
#: which an answer other than the geometry's first must beat every other answer its directions allow
#: that the geometry does not rule out (its cost within the matching's bar of the answer's), for
#: :func:`settle_by_look` to decide an answer left ambiguous (the geometry's first needs only to lead)
LOOK_BAR = 0.1

#: answers whose rotations lie closer than this (degrees) are one answer to the images' look
#: (:func:`settle_by_look`): it compares the views as if the scene were at infinity, and the
#: translation it leaves out moves the rotation where they agree best 3-7 degrees from the true one on
#: the rendered street pairs (:meth:`catadioptric.photometric.RotationAgreement.best_near`), by a
#: few hundredths of agreement; among such answers (their agreements within the bar) the geometry decides
LOOK_SAME_DEG = 10.0

#: standard errors (the jackknife over blocks of image B,
#: :meth:`catadioptric.photometric.RotationAgreement.margin` and ``.agreement``): by this many the
#: images' look must prefer another answer to the one the geometry decided for that answer to be left
#: ambiguous (:func:`check_by_look`; and by the look's bar), and image B must agree with image A
#: turned by an answer for the look to decide it (:func:`settle_by_look`: a look that does not see
#: the scene under the answer, as at wide baselines, confirms nothing)
LOOK_SIGMAS = 2.0

#: :func:`translation_by_look` reads every ``PARALLAX_STEP``-th row and column of image B (the
#: agreements' own: every :data:`catadioptric.photometric.STEP`-th): its search's few hundred
#: agreements at a quarter of the cost
PARALLAX_STEP = 8

#: :func:`translation_by_look` notes when the look's direction of the translation and the lines' lie
#: more than this far apart (degrees): one of them is off by half of it or more (how far each has
#: been off on rendered pairs: docs/relative_pose.md, "The translation's direction by the look")
TRANSLATION_APART_DEG = 45.0


def settle_by_look(res: ImagePairPose, images: tuple, cams: tuple, masks=(None, None), *, bar: float = LOOK_BAR) -> bool:
    """Decide an answer that the geometry left ambiguous by its margin alone (no other reason:
    ``pose.evidence["ambiguous_by"]``) by how the images look under each of its candidates; an
    answer the geometry decided is checked by the look instead (:func:`check_by_look`).

    Each different answer among ``res.pose.candidates`` (rotations more than
    :data:`~catadioptric.pose.labelled.SAME_ANSWER_DEG` apart, the cheapest of each) is scored by
    the agreement of image B with image A turned by its rotation
    (:func:`catadioptric.photometric.rotation_agreement`); an answer under which too little of B is
    seen in A to compare contradicts the lines it matched in both views and ranks last (agreement
    taken as -1), unless a mask is given (the mask may be what hides the view: then no answer is
    chosen). The answers within :data:`LOOK_SAME_DEG` of the one that agrees best, their agreement
    within ``bar`` of its, are one answer to the look, and the geometry's first of them is taken
    when the geometry tells it from the others (:func:`look_choice`). It is the answer when
    the look ranks every other answer below it, and each of them is ruled out by one cue: it agrees
    less by at least ``bar`` (by any margin when the answer is the geometry's own first: the two
    cues then agree, and only an answer that overturns the lines' ranking needs the bar), or it
    costs the matching's bar more than the answer (the geometry rules it out); the geometry keeps
    it (its cost within the matching's bar of the best: one of the answers the geometry could not
    tell apart, refined as the best was), no rotation near it agrees better by ``bar``
    (:meth:`~catadioptric.photometric.RotationAgreement.best_near`: the answer is where the images
    agree, not only the best of the answers), and image B agrees with image A turned by it by
    :data:`LOOK_SIGMAS` standard errors of that agreement
    (:meth:`~catadioptric.photometric.RotationAgreement.agreement`: the look sees the scene under
    it). ``res`` then holds it, decisive, its candidates first; its ``margin`` stays the geometry's
    (negative when the geometry ranked another first). What was measured goes to
    ``pose.evidence["look"]`` (each answer's candidate index and agreement, the one it ranks first,
    the answer taken, its margin, the best agreement near it and how far, the standard error of its
    own agreement, the bar, whether it decided) and the notes. Returns whether it decided."""
    from .pose import rotation_angle_deg

    p = res.pose
    ev = p.evidence
    if ev is not None and not p.ambiguous:
        check_by_look(res, images, cams, masks, bar=bar)
        return False
    why = ev.get("ambiguous_by") if ev else None
    if not p.ambiguous or not why or not set(why) <= {"margin", "lines_in_order"}:
        return False
    scored = _scored(p, images, cams, masks)
    if scored is None:
        return False
    answers, judge, agree = scored
    unseen = ~np.isfinite(agree)
    look = {"candidates": answers, "agreement": [float(a) for a in agree], "best": None, "ranked_first": None,
            "margin": float("nan"), "nearby": None, "agreement_se": float("nan"), "bar": float(bar),
            "same_deg": LOOK_SAME_DEG, "decided": False}
    ev["look"] = look
    masked = any(m is not None for m in masks)

    def choose():
        score = ranked_agreement(agree, masked=masked)
        if score is None:
            return None
        ch = look_choice(score, [p.candidates[k].R for k in answers], [p.candidates[k].cost for k in answers], bar,
                         ev["bar"])
        look.update(best=answers[ch.taken], ranked_first=answers[ch.first], margin=ch.margin)
        return ch

    ch = choose()
    if ch is None:
        p.notes = [*p.notes, "the images' look did not decide it: some answers' rotations leave too little of B "
                             "seen in A to compare" + (" (under the masks)" if masked else "")]
        return False
    k = answers[ch.taken]
    kept = p.candidates[k].cost - p.candidates[0].cost < ev["bar"]
    refined = k == 0 or k in p.rivals
    if kept and not refined and ch.decides and p.refine_rival(k):
        # a rival beyond those refined with the answer, refined now that the look takes it: its
        # refined rotation is scored again, and the look must take it again
        refined = True
        agree[ch.taken] = judge(p.candidates[k].R[None])[0]
        look["agreement"][ch.taken] = float(agree[ch.taken])
        look["refined_now"] = k
        ch = choose()
        if ch is None:
            p.notes = [*p.notes, f"the images' look did not decide it: its best answer (candidate {k}), refined, "
                                 "leaves too little of B seen in A to compare"]
            return False
        if answers[ch.taken] != k:
            p.notes = [*p.notes, f"the images' look did not decide it: its best answer (candidate {k}), refined, "
                                 f"no longer leads (candidate {answers[ch.taken]} does)"]
            return False
    gain = apart = float("nan")
    if ch.decides and kept and refined:
        R_near, a_near = judge.best_near(p.candidates[k].R)
        gain, apart = a_near - float(agree[ch.taken]), rotation_angle_deg(R_near @ p.candidates[k].R.T)
        look["nearby"] = {"agreement": a_near, "apart_deg": apart}
    seen, seen_se = float("nan"), float("nan")
    if ch.decides and kept and refined and gain < bar:
        seen, seen_se = judge.agreement(p.candidates[k].R)
        look["agreement_se"] = seen_se
    if not ch.decides or not kept or not refined or not gain < bar or not seen >= LOOK_SIGMAS * seen_se:
        lost = (_short_note(ch, answers, bar) if not ch.decides else
                f"its best answer (candidate {k}) is beyond the matching's bar" if not kept else
                f"its best answer (candidate {k}) was not refined" if not refined else
                f"a rotation {apart:.1f} deg from its best answer agrees better by {gain:.3f} (bar {bar:g}): that "
                f"answer is not where the images agree" if not gain < bar else
                f"image B agrees with image A turned by its best answer (candidate {k}) by {seen:.3f}, "
                f"{seen / seen_se:.1f} standard errors of that agreement (needed: {LOOK_SIGMAS:g}): the look does "
                f"not see the scene under it")
        p.notes = [*p.notes, f"the images' look did not decide it: {lost}"]
        return False
    look["decided"] = True
    note = _decided_note(ch, answers, ranked_agreement(agree, masked=masked), unseen, bar)
    if k != 0:
        p = _take_rival(res, k)
    p.ambiguous = False
    p.notes = [note, *p.notes]
    return True


def _scored(p, images, cams, masks):
    """The different answers among ``p.candidates`` (indices: rotations more than
    :data:`~catadioptric.pose.labelled.SAME_ANSWER_DEG` apart, the cheapest of each, finite costs
    only), the images' judge and each answer's agreement: ``(answers, judge, agreement)``; None when
    there are fewer than two answers or the geometry's first is not one of them."""
    from .photometric import RotationAgreement
    from .pose import rotation_angle_deg
    from .pose.labelled import SAME_ANSWER_DEG

    answers = []
    for k, c in enumerate(p.candidates):
        if np.isfinite(c.cost) and all(rotation_angle_deg(c.R @ p.candidates[j].R.T) > SAME_ANSWER_DEG for j in answers):
            answers.append(k)
    if len(answers) < 2 or answers[0] != 0:
        return None
    judge = RotationAgreement(images[0], images[1], cams[0], cams[1], masks=masks)
    return answers, judge, judge(np.stack([p.candidates[k].R for k in answers]))


def check_by_look(res: ImagePairPose, images: tuple, cams: tuple, masks=(None, None), *, bar: float = LOOK_BAR) -> bool:
    """Ask the images' look of an answer the geometry decided: when image B agrees with image A
    turned by another answer (one more than :data:`LOOK_SAME_DEG` from it) better than by the answer
    itself, by the bar and by :data:`LOOK_SIGMAS` standard errors of that margin
    (:meth:`~catadioptric.photometric.RotationAgreement.margin`), the two cues contradict each other
    and the answer is left ambiguous (``pose.evidence["ambiguous_by"]`` gains ``"look"``; a note
    says by how much). The lines' matching was measured at baselines of 2-8 m (its bar, docs/relative_pose.md);
    at wider ones it has decided half-turns that the images plainly deny. What was measured goes to
    ``pose.evidence["look_check"]`` (the answers' candidate indices and agreements, the one that
    agrees best beyond :data:`LOOK_SAME_DEG`, its margin over the answer and that margin's standard
    error, the bar, whether it contradicts). Returns whether the answer was left ambiguous; answers
    already ambiguous, of the label path, or with no other answer are left alone."""
    from .pose import rotation_angle_deg

    p = res.pose
    ev = p.evidence
    if ev is None or p.ambiguous:
        return False
    scored = _scored(p, images, cams, masks)
    if scored is None:
        return False
    answers, judge, agree = scored
    R0 = p.candidates[0].R
    far = [i for i, k in enumerate(answers) if rotation_angle_deg(p.candidates[k].R @ R0.T) > LOOK_SAME_DEG
           and np.isfinite(agree[i])]
    check = {"candidates": answers, "agreement": [float(a) for a in agree], "rival": None, "margin": float("nan"),
             "margin_se": float("nan"), "bar": float(bar), "sigmas": LOOK_SIGMAS, "contradicts": False}
    ev["look_check"] = check
    if not far or not np.isfinite(agree[0]):
        return False
    j = max(far, key=lambda i: agree[i])
    if not agree[j] > agree[0]:
        check.update(rival=answers[j], margin=float(agree[j] - agree[0]))
        return False
    m, se = judge.margin(p.candidates[answers[j]].R, R0)
    need = max(bar, LOOK_SIGMAS * se) if np.isfinite(se) else float("nan")
    check.update(rival=answers[j], margin=m, margin_se=se)
    if not (np.isfinite(need) and m >= need):
        return False
    check["contradicts"] = True
    p.ambiguous = True
    ev["ambiguous_by"] = [*ev.get("ambiguous_by", []), "look"]
    p.notes = [f"ambiguous: the images' look contradicts the lines: image B agrees with image A turned by candidate "
               f"{answers[j]} ({rotation_angle_deg(p.candidates[answers[j]].R @ R0.T):.0f} deg from the answer; "
               f"correlation {agree[j]:.3f}) better than by the answer ({agree[0]:.3f}) by {m:.3f}, against a bar of "
               f"{need:.3f} (the look's bar {bar:g}, or {LOOK_SIGMAS:g} standard errors of that margin over blocks "
               f"of image B, {se:.3f})", *p.notes]
    return True


def translation_by_look(res: ImagePairPose, images: tuple, cams: tuple, masks=(None, None), *,
                        step: int = PARALLAX_STEP, known: dict | None = None) -> dict | None:
    """The direction of the translation by the images' look under the answer's rotation: the
    parallax ``t / D`` where image B agrees best with image A under ``res.pose.R``, the scene taken at
    one distance ``D`` from B (:meth:`catadioptric.photometric.RotationAgreement.parallax`, every
    ``step``-th pixel of B). It is the images' own estimate of where B moved, beside the lines'
    (``res.pose.t``; at the benchmark's baselines of 2-8 m the lines' direction is often far off, or
    reversed: docs/relative_pose.md, "The translation's direction by the look"). What it finds goes to
    ``pose.evidence["look_translation"]`` and is returned: ``direction`` (a unit vector of B's frame,
    ``x_B = R x_A + t``; None when no parallax agrees better than the scene at infinity),
    ``parallax`` (``|t| / D``), ``agreement`` (there) and ``agreement_at_infinity``, and
    ``from_lines_deg``, the angle to the lines' translation (None without one; more than
    :data:`TRANSLATION_APART_DEG`: a note says so), ``sign_from_look``, ``translation_from_look``.
    In an answer that is not ambiguous, a translation more than 90 degrees from the look's is not
    kept: a central model's direction (``t`` a unit vector, its sign from the meeting rays'
    cheirality) is turned round, with its covariance's cross terms and the answer's candidate
    (``sign_from_look``; ``from_lines_deg`` is then the angle after); a metric one (a non-central
    rig's two-view fit, whose lines were matched under the reversed direction and fit it better than
    a refinement started from the look's: docs/relative_pose.md) becomes the look's direction, a
    unit vector (``pose.metric`` False, the covariance's translation rows NaN; the lines' fit stays
    in ``candidates[0]``; ``translation_from_look``; ``from_lines_deg`` the angle to the lines'). A
    note says which. Returns None, and records nothing, for a pose without ``evidence`` (the label
    path) or a rotation under which too little of B is seen in A. ``known``: what a call found for
    another pose of the same images, masks and ``step`` with the same rotation (its returned dict):
    its search is not repeated, only the angle to this pose's translation is measured (as the
    benchmark runs one pair under two priors)."""
    from .photometric import RotationAgreement

    p = res.pose
    if p.evidence is None:
        return None
    if known is not None:
        at_infinity, agreement, u = known["agreement_at_infinity"], known["agreement"], known["parallax"]
        direction = None if known["direction"] is None else np.asarray(known["direction"], dtype=float)
    else:
        judge = RotationAgreement(images[0], images[1], cams[0], cams[1], masks=masks, step=step)
        at_infinity = judge.at(p.R)
        agreement, parallax = judge.parallax(p.R)
        if not np.isfinite(agreement):
            return None
        u = float(np.linalg.norm(parallax))
        direction = parallax / u if u > 0 else None
    apart = None
    if direction is not None and p.t is not None and np.linalg.norm(p.t) > 0:
        c = float(np.dot(direction, p.t) / np.linalg.norm(p.t))
        apart = float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
    reversed_from, replaced = None, False
    if apart is not None and apart > 90.0 and p.translation_observable and not p.ambiguous:
        # the lines' direction takes its sign from the meeting rays' cheirality, a vote of the few points where
        # matched lines meet, and a metric fit keeps the lines matched under it: the images' look, on the other
        # side, decides (under a decided answer's rotation only: under an ambiguous one's, which may be wrong,
        # the look's direction is no guide)
        if p.metric:
            _translation_from_look(p, direction)
            replaced = True
        else:
            _reverse_translation(p)
            reversed_from, apart = apart, 180.0 - apart
    out = {"direction": None if direction is None else [float(x) for x in direction], "parallax": u,
           "agreement": float(agreement), "agreement_at_infinity": float(at_infinity), "from_lines_deg": apart,
           "sign_from_look": reversed_from is not None, "translation_from_look": replaced, "step": int(step)}
    p.evidence["look_translation"] = out
    if reversed_from is not None:
        p.notes = [*p.notes, f"the translation's sign taken from the images' look: the meeting rays' cheirality "
                             f"put the direction {reversed_from:.0f} deg from the look's "
                             f"({np.round(direction, 3).tolist()}, evidence.look_translation)"]
    if replaced:
        p.notes = [*p.notes, f"the translation is the images' look's direction ({np.round(direction, 3).tolist()}, "
                             f"a unit vector; evidence.look_translation): the lines' metric fit put it {apart:.0f} deg "
                             f"from it, reversed, and its length with it (that fit: candidates[0])"]
    elif apart is not None and apart > TRANSLATION_APART_DEG:
        p.notes = [*p.notes, f"the images' look puts the translation {apart:.0f} deg from the lines' (its direction "
                             f"{np.round(direction, 3).tolist()}, evidence.look_translation): the translation's "
                             f"direction is uncertain" + (", the lines' perhaps reversed" if apart > 135.0 else "")]
    return out


def _translation_from_look(p, direction) -> None:
    """``p.t`` made the look's ``direction`` (a unit vector: ``p.metric`` False), its covariance's
    translation rows and columns unknown (NaN); the answer's candidate keeps the lines' fit."""
    p.t, p.metric = np.array(direction, dtype=float), False
    if p.cov is not None:
        cov = np.array(p.cov, dtype=float)
        cov[3:, :] = np.nan
        cov[:, 3:] = np.nan
        p.cov = cov


def _reverse_translation(p) -> None:
    """``p.t`` (and its first candidate's, the answer) turned round, their covariances' cross terms
    between rotation and translation with it."""
    from dataclasses import replace

    def turned(cov):
        if cov is None:
            return None
        cov = np.array(cov, dtype=float)
        cov[:3, 3:] *= -1.0
        cov[3:, :3] *= -1.0
        return cov

    p.t, p.cov = -np.asarray(p.t, dtype=float), turned(p.cov)
    c = p.candidates[0]
    if c.t is not None:
        p.candidates[0] = replace(c, t=-np.asarray(c.t, dtype=float), cov=turned(c.cov))


@dataclass
class LookChoice:
    """What the images' look makes of the answers (:func:`look_choice`; indices into the answers)."""

    #: the answer that agrees best
    first: int
    #: the answers the look does not tell from it (itself included): within :data:`LOOK_SAME_DEG`
    #: of it, their agreement within the bar of its
    same: list
    #: the geometry's first of them: the answer the look would take
    taken: int
    #: the first one's agreement over the best of the other answers (NaN: there is none)
    margin: float
    #: None when the look ranks every other answer below it enough; else ``(j, margin, needed)`` for the
    #: other answer ``j`` it does not (``j`` None: there is no other answer)
    short: tuple | None
    #: the answers among ``same`` within the matching's bar of the one taken: the geometry does not
    #: tell them from it either
    tied: list

    @property
    def decides(self) -> bool:
        """Whether the look takes ``taken`` (the geometry's bar and the rotations near it aside)."""
        return self.short is None and not self.tied


def look_choice(score, rotations, costs, bar: float, matching_bar: float) -> LookChoice:
    """The answer the images' look takes among answers ranked by the geometry (in that order) with
    agreements ``score`` (as :func:`ranked_agreement` gives them), ``rotations`` and the matching's
    ``costs``: the one that agrees best and those within :data:`LOOK_SAME_DEG` of it whose agreement
    is within ``bar`` of its are one answer to the look, and the geometry's first of them is taken
    if the geometry tells it from the others (each costs ``matching_bar`` more); every other answer
    must agree less, and by ``bar`` (by any margin when the one taken is the geometry's first) unless
    it costs ``matching_bar`` more than the one taken: each other answer ruled out by one cue
    (:func:`settle_by_look`)."""
    from .pose import rotation_angle_deg

    score = np.asarray(score, dtype=float)
    first = int(np.argmax(score))
    same = [j for j, R in enumerate(rotations)
            if rotation_angle_deg(R @ rotations[first].T) < LOOK_SAME_DEG and score[first] - score[j] < bar]
    taken = min(same)
    tied = [j for j in same if j != taken and costs[j] - costs[taken] < matching_bar]
    others = [j for j in range(len(score)) if j not in same]
    if not others:
        return LookChoice(first, same, taken, float("nan"), (None, float("nan"), 0.0), tied)
    j = max(others, key=lambda i: score[i])
    margin, need = float(score[first] - score[j]), bar if taken > 0 else 0.0
    # each other answer must be ruled out by one cue: the look (by the bar) or the geometry (its cost the
    # matching's bar above the answer taken's)
    rivals = [i for i in others if costs[i] - costs[taken] < matching_bar]
    short = None
    if margin <= 0.0:
        short = (j, margin, need)
    elif rivals:
        r = max(rivals, key=lambda i: score[i])
        m_r = float(score[first] - score[r])
        if not (m_r > 0.0 and m_r >= need):
            short = (r, m_r, need)
    return LookChoice(first, same, taken, margin, short, tied)


def _short_note(ch: LookChoice, answers, bar: float) -> str:
    """Why the look does not take an answer (:attr:`LookChoice.short`, :attr:`LookChoice.tied`)."""
    if ch.short is None:
        return (f"it does not tell candidates {answers[ch.taken]} and {answers[ch.tied[0]]} apart (at most "
                f"{LOOK_SAME_DEG:g} deg apart, agreements within {bar:g}), nor does the geometry (costs within "
                f"the matching's bar)")
    j, m, need = ch.short
    if j is None:
        return (f"its answers all lie within {LOOK_SAME_DEG:g} deg of its best, their agreements within {bar:g}: "
                f"it does not tell them apart")
    if need > 0.0:
        return f"margin {m:.3f} over candidate {answers[j]} against a bar of {need:g}"
    return f"candidate {answers[j]} agrees as well as its best (margin {m:.3f})"


def _decided_note(ch: LookChoice, answers, score, unseen, bar: float) -> str:
    """The note of an answer the look decided (:func:`settle_by_look`; ``score`` as ranked)."""
    k = answers[ch.taken]
    text = (f"decided by the images' look: image B agrees with image A turned by "
            f"{'the best answer' if k == 0 else f'candidate {k} (within the matching bar of the best)'} "
            f"(correlation {score[ch.first]:.3f}) better than by any of the "
            f"{len(answers) - len(ch.same)} other answers by {ch.margin:.3f}")
    if ch.first != ch.taken:
        text += (f" (it agrees best as candidate {answers[ch.first]}, within {LOOK_SAME_DEG:g} deg of it: the look "
                 f"does not tell them apart, and the geometry ranks candidate {k} first)")
    if ch.taken > 0 or ch.margin >= bar:
        text += f", against a bar of {bar:g}"
    else:
        text += f", confirming the lines' own first answer (another answer would need {bar:g})"
    if unseen.any():
        text += f" ({int(unseen.sum())} of them turn B's view out of A's)"
    return text


def ranked_agreement(agreement, *, masked: bool):
    """The answers' agreements (:func:`settle_by_look`) as they are ranked: an answer under which too
    little of B is seen in A to compare (NaN) says the two views share nearly nothing, against the
    lines it matched in both, and ranks last (-1) when no mask is given; with a mask, the mask may be
    what hides the view, and such an answer leaves nothing to rank (None), as when no answer is
    measured at all."""
    a = np.asarray(agreement, dtype=float)
    unseen = ~np.isfinite(a)
    if unseen.all() or (unseen.any() and masked):
        return None
    return np.where(unseen, -1.0, a)


def look_figure(res: ImagePairPose, images: tuple, cams: tuple, masks=(None, None), *, step: int = 2):
    """What the images' look compares, for a reader to see: image B, image A turned by the answer
    (``res.pose``'s first candidate) and image A turned by the other answer that agrees best among
    those more than :data:`LOOK_SAME_DEG` from it
    (:func:`catadioptric.photometric.turned_image`, every ``step``-th pixel; the scene taken at
    infinity, as the look takes it), each titled with its agreement and that agreement's standard
    error (:meth:`~catadioptric.photometric.RotationAgreement.agreement`; under ``masks``). A
    matplotlib figure (``catadioptric relative-pose`` writes it as ``look.png``); None when the pose
    has no other answer (fewer than two rotations more than
    :data:`~catadioptric.pose.labelled.SAME_ANSWER_DEG` apart) to compare."""
    from ._extras import require
    from .photometric import turned_image
    from .pose import rotation_angle_deg

    p = res.pose
    scored = _scored(p, images, cams, masks)
    if scored is None:
        return None
    answers, judge, agree = scored
    R0 = p.candidates[0].R
    far = [i for i, k in enumerate(answers) if rotation_angle_deg(p.candidates[k].R @ R0.T) > LOOK_SAME_DEG]
    shown = [0] + ([max(far, key=lambda i: agree[i] if np.isfinite(agree[i]) else -np.inf)] if far else [])
    require("matplotlib", "the images' look figure")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .detect.image import to_channels

    def show(ax, img, title):
        shown_img = np.clip(np.nan_to_num(img, nan=0.0), 0, 255) / 255.0
        ax.imshow(shown_img[..., 0] if shown_img.shape[2] == 1 else shown_img, cmap="gray", vmin=0, vmax=1)
        ax.set_title(title, fontsize=8)
        ax.set_axis_off()

    fig, axes = plt.subplots(1, 1 + len(shown), figsize=(3.6 * (1 + len(shown)), 3.3), dpi=100, squeeze=False)
    show(axes[0, 0], to_channels(images[1]), "image B")
    for ax, i in zip(axes[0, 1:], shown):
        c = p.candidates[answers[i]]
        a, se = judge.agreement(c.R)
        what = "the answer" if i == 0 else (f"candidate {answers[i]}, {rotation_angle_deg(c.R @ R0.T):.0f} deg from "
                                             f"the answer")
        seen = f"agreement {a:.3f} (se {se:.3f})" if np.isfinite(a) else "too little of B seen in A"
        show(ax, turned_image(images[0], cams[0], cams[1], c.R, step=step), f"image A turned by {what}\n{seen}")
    fig.tight_layout()
    return fig


def _take_rival(res: ImagePairPose, k: int):
    """``res`` made to hold its pose's refined rival ``k`` (``pose.rivals[k]``) as the answer: its
    candidate first, the geometry's margin of that answer over the next different one, the first
    answer's evidence and notes before the rival's own (a note both give, once). Returns the new pose."""
    from .pose import rotation_angle_deg
    from .pose.labelled import SAME_ANSWER_DEG

    p, new = res.pose, res.pose.rivals[k]
    costs = [c.cost for j, c in enumerate(p.candidates) if j != k
             and rotation_angle_deg(c.R @ p.candidates[k].R.T) > SAME_ANSWER_DEG]
    new.candidates = [p.candidates[k], *[c for j, c in enumerate(p.candidates) if j != k]]
    new.margin = float(min(costs) - p.candidates[k].cost)
    new.evidence, new.notes = p.evidence, list(dict.fromkeys([*p.notes, *new.notes]))  # a note both fits give, once
    res.hold(new)
    return new
