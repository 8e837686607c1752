"""Relative pose from two images alone: the lines and families of each image
(:func:`catadioptric.detect.detect_lines`), matched across the views and turned into a relative
pose by :func:`catadioptric.pose.relative_pose` (its path for lines without labels), with a
report and overlays. ``catadioptric relative-pose IMAGE_A IMAGE_B --rig RIG --out DIR`` runs it.

Nothing here uses ground truth; :mod:`catadioptric.validate.image_pairs` scores it on rendered
pairs. Method, options and measured behaviour: docs/relative_pose.md ("From two images").
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ._checks import CatadioptricError, as_scalar

__all__ = ["ImagePairPose", "relative_pose_from_images", "pose_from_detections", "pair_overlay", "image_pair_summary",
           "image_pair_markdown", "register", "COVARIANCE_SCALE", "LOOK_BAR", "LOOK_SIGMAS", "settle_by_look", "check_by_look", "ranked_agreement"]


@dataclass
class ImagePairPose:
    """What :func:`relative_pose_from_images` returns. ``pose``: the
    :class:`catadioptric.pose.RelativePose` (``x_B = R x_A + t``, mirror frames);
    ``detections``: the two :class:`catadioptric.detect.DetectedLines`; ``family_map``:
    ``{family of B: (family of A, sign)}`` of the chosen answer (detection indices; ``sign``: the
    direction of B's family is ``sign R`` times A's); ``seconds``: per stage."""

    pose: object
    detections: tuple
    family_map: dict
    seconds: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON-ready: the fields of ``pose.json`` (:func:`image_pair_summary`)."""
        return image_pair_summary(self)


def _family_map(pose) -> dict:
    """The chosen answer's assignment of B's detected families to A's, from its first candidate."""
    out = {}
    for b, v in pose.candidates[0].signs.items():
        if isinstance(v, tuple):
            a, s = v
            out[int(b)] = (int(a), int(s))
    return out


def relative_pose_from_images(image_a, image_b, cam_a, cam_b=None, *, detect_options: dict | None = None,
                              min_pixels: int = 30, max_rotation_deg: float | None = None, decisive: float = 25.0,
                              decisive_matching: float | None = None, seed: int = 0, joint: bool = True,
                              covariance_scale: float | None = None, masks=(None, None),
                              look: bool = True, calibration_rms_px: float = 0.0) -> ImagePairPose:
    """The relative pose of two views from their images alone.

    ``image_a``, ``image_b``: arrays (RGB or grey; uint8, uint16 or float in [0, 1]) taken by
    ``cam_a`` and ``cam_b`` (default ``cam_a``). ``detect_options``: options of
    :func:`catadioptric.detect.detect_lines` (when one image is grey and the other colour and
    ``colour`` is not given, both are detected on luminance, ``colour=False``: the detector would
    otherwise see other lines in each; the notes say so); ``masks``: the two images' masks (non-zero: use the
    pixel; None: all), for what moves or does not belong to the scene. ``min_pixels``: shortest line
    used by the pose.
    ``max_rotation_deg``: a prior on the motion (see :func:`catadioptric.pose.relative_pose`):
    without it the symmetric answers of a Manhattan scene usually leave the result ``ambiguous``.
    ``decisive``, ``decisive_matching``: see :func:`catadioptric.pose.relative_pose`. ``joint``:
    families of the lines left over found in both views at once (:func:`pose_from_detections`).
    ``covariance_scale``: the answer's covariance is that of the fit times its square (default
    :data:`COVARIANCE_SCALE`, measured on rendered pairs; 1: the fit's own). ``look``: an answer that
    only its margin left ambiguous is decided by the images' look where it clearly prefers one of
    the answers the geometry keeps, and an answer the geometry decided is left ambiguous where the
    look plainly prefers another (:func:`settle_by_look`, :func:`check_by_look`). ``calibration_rms_px``: the cameras'
    calibration rms in pixels (see :func:`catadioptric.pose.relative_pose`; 0 for a rendered rig).
    For the lines of one planar target that a half-turn about its axes maps onto itself (a
    chessboard, masked), call it with ``look=False``, then
    :func:`catadioptric.pose.twins.flag_twins` on ``res.pose`` (an answer whose twin under such a
    turn is listed is ambiguous), then :func:`settle_by_look` (which leaves such an answer alone), as
    ``relative-pose --symmetric-target`` does. Raises :class:`CatadioptricError` naming the
    cause when a view has fewer than two families.
    """
    from .detect import detect_lines
    from .detect.image import check_image_size, to_channels

    cam_b = cam_a if cam_b is None else cam_b
    if not (isinstance(min_pixels, (int, np.integer)) and min_pixels >= 2):
        raise CatadioptricError(f"min_pixels: expected an integer >= 2, got {min_pixels!r}")
    opts = dict(detect_options or {})
    grey = []
    for name, img in (("A", image_a), ("B", image_b)):
        shape = np.shape(img)
        if len(shape) >= 2:
            check_image_size(shape[1], shape[0], f"image_{name.lower()}")
        try:
            grey.append(to_channels(img).shape[2] == 1)
        except CatadioptricError as exc:
            raise CatadioptricError(f"image {name}: {exc}") from None
    mixed = None
    if grey[0] != grey[1] and "colour" not in opts:
        # the detector takes a colour image's edges on its RGB channels and a grey one's on one channel:
        # it would see other lines in each (a grey and a colour image of one scene came out decisive,
        # 118 degrees off); both on luminance, the same lines
        opts["colour"] = False
        mixed = (f"image {'A' if grey[0] else 'B'} is grey and image {'B' if grey[0] else 'A'} colour: both "
                 f"detected on luminance (detect option colour=False), so that both see the same lines")
    t0 = time.perf_counter()
    dets = []
    for name, img, cam, mask in (("A", image_a, cam_a, masks[0]), ("B", image_b, cam_b, masks[1])):
        try:
            dets.append(detect_lines(img, cam, mask=mask, **opts))
        except CatadioptricError as exc:
            raise CatadioptricError(f"image {name}: {exc}" + ("" if mixed is None else f" ({mixed})")) from None
    t1 = time.perf_counter()
    try:
        res = pose_from_detections(dets[0], dets[1], min_pixels=min_pixels, max_rotation_deg=max_rotation_deg,
                                   decisive=decisive, decisive_matching=decisive_matching, seed=seed, joint=joint,
                                   covariance_scale=covariance_scale, calibration_rms_px=calibration_rms_px)
    except CatadioptricError as exc:
        if mixed is None:
            raise
        raise CatadioptricError(f"{exc} ({mixed})") from None
    if look:
        settle_by_look(res, (image_a, image_b), (cam_a, cam_b), masks)
    if mixed is not None:
        res.pose.notes = [mixed, *res.pose.notes]
    t2 = time.perf_counter()
    res.seconds = {"detect": t1 - t0, "pose": t2 - t1, "total": t2 - t0}
    return res


def pose_from_detections(det_a, det_b, *, min_pixels: int = 30, max_rotation_deg: float | None = None,
                         decisive: float = 25.0, decisive_matching: float | None = None, seed: int = 0,
                         joint: bool = True, covariance_scale: float | None = None,
                         calibration_rms_px: float = 0.0, threads: int = 2) -> ImagePairPose:
    """The relative pose from two detections (:class:`catadioptric.detect.DetectedLines`); the
    options are those of :func:`relative_pose_from_images`, and ``threads``: as
    :func:`catadioptric.pose.relative_pose`'s (the answers do not depend on it).

    The fit takes the detected pixels' errors as independent; they are not (module constant
    :data:`COVARIANCE_SCALE`), and the answer's covariance is the fit's times
    ``covariance_scale ** 2``, the notes say so. The joint families and the guard below use the
    fit's own deviations.

    With ``joint`` and a first answer that is not ambiguous, the lines that no matched family holds
    are then grouped in both views at once
    under the answer's rotation (:func:`catadioptric.detect.joint_families.joint_families`: two
    lines in each view make a family that one image alone cannot show), and when that finds
    families the pose is estimated again with them added to both detections (the search of
    :func:`catadioptric.pose.relative_pose` starts anew: the added families are not taken as
    matched). That second answer is kept only when it is decisive and its rotation lies within
    ``_JOINT_AGREE_SIGMA`` combined deviations of the first (the families were found under the
    first); otherwise the first answer stands. The notes say what was added, or why it was not kept."""

    scale = COVARIANCE_SCALE if covariance_scale is None else as_scalar(covariance_scale, "covariance_scale",
                                                                        positive=True)
    res = _pose_from_detections(det_a, det_b, min_pixels, max_rotation_deg, decisive, decisive_matching, seed, joint,
                                calibration_rms_px, threads)
    p = res.pose
    if scale != 1.0 and p.cov is not None:
        p.cov = p.cov * scale**2
        p.notes = [*p.notes, f"covariance: the fit's times {scale:g} squared (the detected pixels' errors are not "
                             f"independent; twoview.COVARIANCE_SCALE)"]
    return res


def _pose_from_detections(det_a, det_b, min_pixels, max_rotation_deg, decisive, decisive_matching, seed, joint,
                          calibration_rms_px, threads):
    from .detect.joint_families import joint_families, with_families
    from .pose import relative_pose, rotation_angle_deg

    if not (isinstance(min_pixels, (int, np.integer)) and min_pixels >= 2):
        raise CatadioptricError(f"min_pixels: expected an integer >= 2, got {min_pixels!r}")
    dets = (det_a, det_b)

    def estimate(dets):
        views = [d.to_view_lines(min_pixels=min_pixels) for d in dets]
        for name, d, v in zip("AB", dets, views):
            if len(v.families()) < 2:
                raise CatadioptricError(
                    f"image {name}: expected at least 2 families of parallel lines, found {len(d.families)} "
                    f"({len(d)} lines detected, {int(np.sum(d.family >= 0))} in a family, {len(v.uv)} of them "
                    f"with {min_pixels} pixels or more)")
        return relative_pose(views[0], views[1], seed=seed, decisive=decisive, max_rotation_deg=max_rotation_deg,
                             decisive_matching=decisive_matching, calibration_rms_px=calibration_rms_px,
                             threads=threads)

    pose = estimate(dets)
    fmap = _family_map(pose)
    if not joint or pose.ambiguous:
        # families found under a rotation that is not trusted would confirm it: on the benchmark's
        # hyperboloid_9pct pair p04 without a prior, an ambiguous half-turn found one and came out
        # decisive (margin 78), 180 degrees off
        return ImagePairPose(pose, dets, fmap)
    taken_a = [i for a, _ in fmap.values() for i in det_a.families[a].lines]
    taken_b = [i for b in fmap for i in det_b.families[b].lines]
    found = joint_families(det_a, det_b, pose.R, taken_a=taken_a, taken_b=taken_b, min_pixels=min_pixels,
                           rotation_std_deg=_finite_std(pose),
                           known_directions=[det_a.families[a].direction for a, _ in fmap.values()])
    if not found:
        return ImagePairPose(pose, dets, fmap)
    new_a, _ = with_families(det_a, [(f.lines_a, f.direction) for f in found])
    new_b, _ = with_families(det_b, [(f.lines_b, pose.R @ f.direction) for f in found])
    pose2 = estimate((new_a, new_b))
    what = (f"{len(found)} families found in both views at once under the first answer's rotation (lines in A / "
            f"B: {', '.join(f'{len(f.lines_a)}/{len(f.lines_b)}' for f in found)})")
    # the families were found under the first answer's rotation: estimated again with them, the
    # pose may refine it, not leave it (on the held-out elliptic pair p00 one such family moved a
    # decisive answer from 0.35 to 1.93 degrees off, 2.27 degrees, 20 combined claimed deviations)
    apart = rotation_angle_deg(pose2.R @ pose.R.T)
    bound = _JOINT_AGREE_SIGMA * float(np.hypot(_finite_std(pose), _finite_std(pose2)))
    if pose2.ambiguous or apart > bound:
        why = ("is ambiguous" if pose2.ambiguous else
               f"turns {apart:.3g} deg from the first answer, more than {_JOINT_AGREE_SIGMA:g} combined deviations "
               f"({bound:.3g} deg)")
        pose.notes = [f"{what}: not kept, the pose estimated again with them {why}", *pose.notes]
        return ImagePairPose(pose, dets, fmap)
    pose2.notes = [f"{what} and the pose estimated again with them", *pose2.notes]
    return ImagePairPose(pose2, (new_a, new_b), _family_map(pose2))


#: The scale of the image path's covariance (:func:`pose_from_detections`). The two-view fit takes the
#: detected pixels' errors as independent and estimates their size from its residuals (0.04-0.13 px);
#: they are not independent: smooth along each line (their residuals about the line's own curve
#: correlate 0.66 at one pixel, 0.4 at four), they lie a median 0.50-0.65 px from the exact curves
#: (the benchmark report's "pixels"). On 18 answered pairs of the relative-pose benchmark (the prior
#: 60, code of d977fc6) the rotation error's Mahalanobis square against the fit's covariance had a
#: median of 19.8 where a right covariance gives 2.37 (chi-square, 3 degrees of freedom): deviations
#: 2.9 times too small. Checked on the whole benchmark and the held-out pairs
#: (``catadioptric validate image-runs``; docs/relative_pose.md, "The covariance of the image
#: path"; the research log, validate/NOTES.md). Measured on rendered images: other images may want
#: another scale (``covariance_scale``).
COVARIANCE_SCALE = 3.0

#: the pose estimated again with the families found in both views at once is kept only within this
#: many combined rotation deviations of the first answer (:func:`pose_from_detections`): 5 deviations
#: once the claimed ones are scaled by 2.5, the image path's median ratio of rotation error to its own
#: claimed deviation on the benchmark's answered pairs and on the held-out ones (2.4 and 2.5;
#: docs/relative_pose.md, "Families only both images show")
_JOINT_AGREE_SIGMA = 5.0 * 2.5


#: the agreement of the images (:func:`catadioptric.photometric.rotation_agreement`, a correlation) by
#: which an answer other than the geometry's first must beat every other answer its directions allow,
#: for :func:`settle_by_look` to decide an answer left ambiguous (the geometry's first needs only to lead)
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
    the look ranks every other answer below it by at least ``bar`` (by any margin when it is the
    geometry's own first answer: the two cues then agree, and only an answer that overturns the
    lines' ranking needs the bar), the geometry keeps it (its cost within the matching's
    bar of the best: one of the answers the geometry could not tell apart, refined as the best was),
    no rotation near it agrees better by ``bar``
    (:meth:`~catadioptric.photometric.RotationAgreement.best_near`: the answer is where the images
    agree, not only the best of the answers), and image B agrees with image A turned by it by
    :data:`LOOK_SIGMAS` standard errors of that agreement
    (:meth:`~catadioptric.photometric.RotationAgreement.agreement`: the look sees the scene under it). ``res`` then holds it, decisive, its candidates first;
    its ``margin`` stays the geometry's (negative when the geometry ranked another first). What was measured
    goes to ``pose.evidence["look"]`` (each answer's candidate index and agreement, the one it ranks
    first, the answer taken, its margin, the best agreement near it and how far, the standard error
    of its own agreement, the bar, whether it decided) and the notes. Returns whether it decided."""
    from .photometric import RotationAgreement
    from .pose import rotation_angle_deg

    p = res.pose
    ev = p.evidence
    if ev is not None and not p.ambiguous:
        check_by_look(res, images, cams, masks, bar=bar)
        return False
    why = ev.get("ambiguous_by") if ev else None
    if not p.ambiguous or not why or not set(why) <= {"margin", "lines_in_order"}:
        return False
    answers = _answers(p)
    if len(answers) < 2 or answers[0] != 0:
        return False
    judge = RotationAgreement(images[0], images[1], cams[0], cams[1], masks=masks)
    agree = judge(np.stack([p.candidates[k].R for k in answers]))
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


def _answers(p) -> list:
    """The different answers among ``p.candidates`` (indices): rotations more than
    :data:`~catadioptric.pose.labelled.SAME_ANSWER_DEG` apart, the cheapest of each, finite costs only."""
    from .pose import rotation_angle_deg
    from .pose.labelled import SAME_ANSWER_DEG

    answers = []
    for k, c in enumerate(p.candidates):
        if np.isfinite(c.cost) and all(rotation_angle_deg(c.R @ p.candidates[j].R.T) > SAME_ANSWER_DEG for j in answers):
            answers.append(k)
    return answers


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
    from .photometric import RotationAgreement
    from .pose import rotation_angle_deg

    p = res.pose
    ev = p.evidence
    if ev is None or p.ambiguous:
        return False
    answers = _answers(p)
    if len(answers) < 2 or answers[0] != 0:
        return False
    R0 = p.candidates[0].R
    judge = RotationAgreement(images[0], images[1], cams[0], cams[1], masks=masks)
    agree = judge(np.stack([p.candidates[k].R for k in answers]))
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
    must agree less by ``bar``, by any margin when the one taken is the geometry's first
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
    short = None if margin > 0.0 and margin >= need else (j, margin, need)
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


def _take_rival(res: ImagePairPose, k: int):
    """``res`` made to hold its pose's refined rival ``k`` (``pose.rivals[k]``) as the answer: its
    candidate first, the geometry's margin of that answer over the next different one, the first
    answer's evidence and notes before the rival's own. Returns the new pose."""
    from .pose import rotation_angle_deg
    from .pose.labelled import SAME_ANSWER_DEG

    p, new = res.pose, res.pose.rivals[k]
    costs = [c.cost for j, c in enumerate(p.candidates) if j != k
             and rotation_angle_deg(c.R @ p.candidates[k].R.T) > SAME_ANSWER_DEG]
    new.candidates = [p.candidates[k], *[c for j, c in enumerate(p.candidates) if j != k]]
    new.margin = float(min(costs) - p.candidates[k].cost)
    new.evidence, new.notes = p.evidence, [*p.notes, *new.notes]
    res.pose, res.family_map = new, _family_map(new)
    return new


def _finite_std(pose) -> float:
    """The answer's rotation deviation (degrees), 0.5 where it is not known."""
    std = pose.rotation_std_deg
    return float(std) if np.isfinite(std) else 0.5


def pair_overlay(image_a, image_b, result: ImagePairPose, *, scale: int = 1) -> np.ndarray:
    """Both images side by side (RGB ``uint8``), each detected line coloured by its family, B's
    families in the colour of the family of A they are matched to (unmatched: grey), each
    matched family's vanishing points as rings."""
    from .detect.overlay import overlay_image

    det_a, det_b = result.detections
    used_a = {a for a, _ in result.family_map.values()}
    ov_a = overlay_image(image_a, det_a, scale=scale, colours={f: f for f in used_a})
    ov_b = overlay_image(image_b, det_b, scale=scale, colours={b: a for b, (a, _) in result.family_map.items()})
    h = max(ov_a.shape[0], ov_b.shape[0])
    pad = np.zeros((h, 8, 3), np.uint8)

    def fit(x):
        return np.pad(x, ((0, h - x.shape[0]), (0, 0), (0, 0)))

    return np.concatenate([fit(ov_a), pad, fit(ov_b)], axis=1)


def image_pair_summary(result: ImagePairPose) -> dict:
    """JSON-ready: the pose (R, t, covariance, verdict, candidates), the matched families with their
    directions in each view, and each view's detection summary."""
    p = result.pose
    det_a, det_b = result.detections
    fams = []
    for b, (a, s) in sorted(result.family_map.items()):
        fams.append({"family_a": a, "family_b": b, "sign": s, "direction_a": det_a.families[a].direction,
                     "direction_b": det_b.families[b].direction, "lines_a": len(det_a.families[a].lines),
                     "lines_b": len(det_b.families[b].lines)})
    return {
        "format": "catadioptric-image-pair-pose/1",
        "R": p.R, "t": p.t, "metric": p.metric, "model": p.model, "cov": p.cov,
        "translation_observable": p.translation_observable,
        "rotation_std_deg": p.rotation_std_deg, "translation_std": p.translation_std,
        "ambiguous": p.ambiguous, "margin": p.margin, "lines_matched": p.lines_matched, "sigma_px": p.sigma_px,
        "turned_in_place": None if p.turned_in_place is None else {
            "lines_seen_again": len(p.turned_in_place.twins), "rival_rotations": p.turned_in_place.rivals,
            "rival_most": p.turned_in_place.rival_twins},
        "matched_families": fams,
        "evidence": p.evidence,
        "candidates": [_candidate(c, k, p.evidence) for k, c in enumerate(p.candidates)],
        "notes": p.notes,
        "views": [{"lines": len(d), "families": len(d.families), "assigned": int(np.sum(d.family >= 0)),
                   "denoise": d.denoise, "noise": d.noise} for d in (det_a, det_b)],
        "seconds": result.seconds,
    }


def _candidate(c, k: int, evidence: dict | None) -> dict:
    """One candidate of :func:`image_pair_summary`: its assignment, pose and cost; the lines its
    matching paired and the meeting points of A it found in B; its cost by the geometry alone."""
    from .pose import LineMatch

    out = {"mapping": c.signs, "R": c.R, "t": c.t, "cost": c.cost}
    if isinstance(c.fit, LineMatch):
        out |= {"lines_matched": len(c.fit.pairs), "meeting_points_found": [c.fit.n_inliers, c.fit.n_crossings]}
    if evidence and evidence.get("cost_geometry_alone"):
        out["cost_geometry_alone"] = evidence["cost_geometry_alone"][k]
    return out


def image_pair_markdown(summary: dict, command: str) -> str:
    """A short Markdown report of :func:`image_pair_summary`'s dict."""
    from .pose import rotation_angle_deg

    def known(x):
        return x is not None and np.isfinite(x)

    R = np.asarray(summary["R"], float)
    lines = ["# Relative pose from two images", "", f"Command: `{command}`", ""]
    verdict = ("**ambiguous**: the best answer does not beat the next different one by the decisive margin; "
               "every candidate is in pose.json" if summary["ambiguous"] else "decisive")
    margin = summary["margin"]
    margin = f"margin {margin:.1f}" if known(margin) else "no rival answer"
    ev = summary.get("evidence")
    if ev and known(ev["margin"]):
        margin += f" against a bar of {ev['bar']:g}"
        if ev["appearance"] and ev["margin_geometry_alone"] is not None:
            g = ev["margin_geometry_alone"]
            margin += ("; without the lines' appearance, by the geometry alone: "
                       + (f"{g:.1f}" if known(g) else "no rival answer")
                       + (", another answer first" if known(g) and g < 0 else ""))
        if ev["turned_in_place"]:
            margin += "; decided by the lines seen again unchanged (a camera turned in place)"
        look = ev.get("look")
        if look:
            m = look["margin"]
            margin += ("; decided by the images' look" if look["decided"] else "; the images' look did not decide it") \
                + (f" (agreement margin {m:.3f} against {look['bar']:g})" if known(m) else " (a rival it cannot score)")
    std = summary["rotation_std_deg"]
    lines += [f"- verdict: {verdict} ({margin})",
              f"- rotation: {rotation_angle_deg(R):.3f} deg turn"
              + (f" (std {std:.3f} deg)" if known(std) else " (its deviation not estimated)")]
    t_std = summary.get("translation_std")
    if summary["t"] is None:
        lines.append("- translation: not estimated")
    elif not summary.get("translation_observable", True):
        lines.append("- translation: zero, not observable (no parallax: the notes say why)")
    elif summary["metric"] and known(t_std) and t_std < np.linalg.norm(np.asarray(summary["t"], float)):
        t = np.asarray(summary["t"], float)
        lines.append(f"- translation (metres, metric): {np.round(t, 3).tolist()} (|t| = {np.linalg.norm(t):.3f} m, "
                     f"std {t_std:.3f} m)")
    elif summary["metric"]:
        t = np.asarray(summary["t"], float)
        n = np.linalg.norm(t)
        lines.append(f"- translation direction: {np.round(t / n if n > 0 else t, 4).tolist()}; its length is not "
                     f"observable from these images (std "
                     + (f"{t_std:.3g} m against a length of {n:.3g} m" if known(t_std) else "not estimated") + ")")
    else:
        lines.append(f"- translation direction (central model): {np.round(np.asarray(summary['t']), 4).tolist()}")
    sigma = summary["sigma_px"]
    lines += [f"- lines matched in both views: {summary['lines_matched']}"
              + (f"; pixel noise estimate {sigma:.2f} px" if known(sigma) else ""), "",
              "| family of A | family of B | sign | lines in A | lines in B |",
              "|---|---|---|---|---|"]
    lines += [f"| {f['family_a']} | {f['family_b']} | {f['sign']:+d} | {f['lines_a']} | {f['lines_b']} |"
              for f in summary["matched_families"]]
    lines += ["", "![overlay](overlay.png)", "", "Notes:", ""] + [f"- {n}" for n in summary["notes"]]
    return "\n".join(lines) + "\n"


def _calibration_rms(args) -> tuple[float, list | None]:
    """``--calibration-rms``, or when not given the largest rms the rigs' calibration files keep
    (OpenCV's omnidir sample writes one; :func:`catadioptric.formats.calibration_rms`), else 0; with
    the files it came from (None when given or none kept)."""
    if args.calibration_rms is not None:
        return args.calibration_rms, None
    from .formats import calibration_rms

    kept = [(r, calibration_rms(r)) for r in dict.fromkeys((args.rig, args.rig_b or args.rig))]
    kept = [(r, v) for r, v in kept if v is not None]
    return (max(v for _, v in kept), [r for r, _ in kept]) if kept else (0.0, None)


def _run(args) -> int:
    import os
    import shlex
    import sys

    from ._io import atomic_write_bytes, atomic_write_json, jsonable
    from .cliargs import check_out_dir, resolve_rig
    from .detect.cli import camera_from_folder, read_image, read_mask
    from .detect.report import write_png

    check_out_dir(args.out)
    images = [read_image(p) for p in (args.image_a, args.image_b)]
    from .detect.image import check_image_size

    for flag, img in zip(("IMAGE_A", "IMAGE_B"), images):
        if np.ndim(img) >= 2:
            check_image_size(img.shape[1], img.shape[0], flag)

    def camera(value, flag, img, which):
        if os.path.isdir(value):
            return camera_from_folder(value, flag)
        return resolve_rig(value, width=img.shape[1], height=img.shape[0], flag=flag, camera=which,
                           calibrations=True)[0]

    cam_a = camera(args.rig, "--rig", images[0], args.camera)
    cam_b = camera(args.rig_b or args.rig, "--rig-b" if args.rig_b else "--rig", images[1],
                   args.camera_b or args.camera)
    masks = (read_mask(args.mask, images[0].shape[:2], "--mask") if args.mask else None,
             read_mask(args.mask_b, images[1].shape[:2], "--mask-b") if args.mask_b else None)
    from .detect.detector import preset_options

    opts = {} if args.denoise is None else {"denoise": args.denoise}
    if args.threshold is not None:
        opts["threshold"] = args.threshold
    opts = preset_options(args.preset, opts)
    symmetric = args.symmetric_target or args.preset == "chessboard"
    rms, rms_from = _calibration_rms(args)
    res = relative_pose_from_images(images[0], images[1], cam_a, cam_b, detect_options=opts,
                                    min_pixels=args.min_pixels, max_rotation_deg=args.max_rotation,
                                    decisive=args.decisive, decisive_matching=args.decisive_matching,
                                    joint=not args.no_joint_families, masks=masks,
                                    look=not (args.no_look or symmetric), calibration_rms_px=rms)
    if rms_from:
        res.pose.notes = [*res.pose.notes, f"the calibration's rms, {rms:g} px, is the rms kept in "
                                           f"{' and '.join(rms_from)} (--calibration-rms overrides it)"]
    if symmetric:  # the target's twins first: the look then leaves an answer they make ambiguous alone
        from .pose.twins import flag_twins

        t0 = time.perf_counter()
        flag_twins(res.pose)
        if not args.no_look:
            settle_by_look(res, (images[0], images[1]), (cam_a, cam_b), masks)
        spent = time.perf_counter() - t0
        res.seconds = {k: v + spent if k in ("pose", "total") else v for k, v in res.seconds.items()}
    os.makedirs(args.out, exist_ok=True)
    summary = image_pair_summary(res) | {"images": [os.path.abspath(args.image_a), os.path.abspath(args.image_b)],
                                         "rig": [args.rig, args.rig_b or args.rig]}
    atomic_write_json(os.path.join(args.out, "pose.json"), jsonable(summary))
    write_png(os.path.join(args.out, "overlay.png"), pair_overlay(images[0], images[1], res))
    command = "catadioptric " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    atomic_write_bytes(os.path.join(args.out, "report.md"), image_pair_markdown(summary, command).encode())
    from .pose import rotation_angle_deg

    p = res.pose
    t = "none" if p.t is None else (f"{np.linalg.norm(p.t):.3f} m" if p.metric else "direction only")
    if not p.translation_observable:
        t = "zero, not observable (no parallax)"
    print(f"{len(res.family_map)} families matched, {p.lines_matched} lines; turn {rotation_angle_deg(p.R):.3f} deg, "
          f"translation {t}; {'AMBIGUOUS' if p.ambiguous else 'decisive'} (margin {p.margin:.1f}); "
          f"{res.seconds['total']:.1f} s; wrote {os.path.join(args.out, 'pose.json')}, report.md, overlay.png")
    return 3 if p.ambiguous else 0


def register(sub) -> None:
    from .cliargs import CALIBRATION_RIG_HELP, nonnegative_float, positive_float, positive_int
    from .detect.detector import PRESETS

    p = sub.add_parser("relative-pose", help="relative pose from two images alone (no labels)",
                       description="Detect the line curves of two images of a catadioptric rig, group them into "
                                   "families, match the families and lines across the images and estimate the "
                                   "relative pose (rotation; metric translation for a non-central rig). Writes "
                                   "pose.json, report.md and overlay.png into --out. Exit code 3 when the answer "
                                   "is ambiguous (docs/relative_pose.md).")
    p.add_argument("image_a", metavar="IMAGE_A", help="first image (PNG, JPEG, TIFF, .npy)")
    p.add_argument("image_b", metavar="IMAGE_B", help="second image")
    p.add_argument("--rig", required=True, metavar="RIG",
                   help=CALIBRATION_RIG_HELP + ", or a dataset (view) folder whose stored camera took the images")
    p.add_argument("--rig-b", metavar="RIG", help="the rig of IMAGE_B when it differs (default: --rig)")
    p.add_argument("--camera", metavar="camN", help="the camera of a Kalibr camchain given as --rig (cam0, cam1, ...)")
    p.add_argument("--camera-b", metavar="camN", help="the camera of a Kalibr camchain for IMAGE_B (default: --camera)")
    p.add_argument("--mask", metavar="PNG", help="a mask of IMAGE_A's size: non-zero where a pixel may be used (zero on "
                                                 "what moves or does not belong to the scene)")
    p.add_argument("--mask-b", metavar="PNG", help="the mask of IMAGE_B (default: none)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--max-rotation", type=positive_float, metavar="DEG",
                   help="prior: the views turn by at most DEG degrees (rules out the symmetric answers of a "
                        "Manhattan scene; default: none, such answers are reported ambiguous)")
    p.add_argument("--min-pixels", type=positive_int, default=30, help="shortest line used, pixels (default 30)")
    p.add_argument("--calibration-rms", type=nonnegative_float, default=None, metavar="PX",
                   help="the calibration's reprojection rms in pixels, as its tool reports it: an error the lines of "
                        "a family share, added to each family's direction (default: the rms the calibration file "
                        "keeps, as OpenCV's omnidir sample writes it, else 0: an exact model, as a rendered rig's; "
                        "docs/cameras.md)")
    p.add_argument("--decisive", type=positive_float, default=25.0,
                   help="margin (chi-square units) the best answer needs over the next (default 25)")
    p.add_argument("--decisive-matching", type=positive_float, default=None,
                   help="margin the best matching of the two images' families and lines needs over the next "
                        "different one (default: 25 when at most 24 family assignments are tried, 40 beyond; "
                        "chance agreements of the matching, docs/relative_pose.md)")
    p.add_argument("--no-joint-families", action="store_true",
                   help="do not look for the families that only both images together show (two lines in each; "
                        "docs/relative_pose.md)")
    p.add_argument("--symmetric-target", action="store_true",
                   help="the lines are one planar target that a half-turn about its axes maps onto itself (a "
                        "chessboard, masked): an answer whose twin under such a turn is listed is ambiguous "
                        "(implied by --preset chessboard; docs/cameras.md)")
    p.add_argument("--no-look", action="store_true",
                   help="do not let the images' look decide an answer the geometry leaves ambiguous by its margin, "
                        "nor check one it decided (docs/relative_pose.md)")
    p.add_argument("--denoise", choices=["auto", "nlmeans", "bilateral", "none"],
                   help="denoising before the edges (default auto)")
    p.add_argument("--threshold", type=positive_float, default=None, metavar="PX",
                   help="the detector's distance of a line's pixels to its curve (default 1; overrides the preset's)")
    p.add_argument("--preset", choices=sorted(PRESETS),
                   help="the detector's options for a kind of scene (catadioptric.detect.PRESETS): chessboard for "
                        "a board's masked lines, whose edges break at every corner; it implies --symmetric-target "
                        "(docs/cameras.md)")
    p.set_defaults(func=_run)
