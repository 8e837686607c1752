"""Relative pose of two views of one rig (or two rigs) from the pixels of families of parallel
lines matched across the views (by label): rotation and, for a non-central rig, metric
translation, with covariance and an explicit verdict when the answer is ambiguous. The front
door is :func:`~catadioptric.pose.relative.relative_pose`; lines matched by nothing go through
:mod:`~catadioptric.pose.unlabelled` first.

Steps (docs/relative_pose.md):

1. each view fits its families (:func:`~catadioptric.pose.families.fit_view_families`): a
   direction with covariance per family, and each line (a 3-D line for a non-central rig, an
   interpretation plane for a central one);
2. the families seen in both views give rotation candidates, one per sign pattern that a
   rotation can fit (:func:`~catadioptric.pose.signs.sign_candidates`); with the ends matched
   (``ends``) the signs are known and there is one candidate;
3. every candidate: the direction between the views' centres from the points where lines of
   two families meet (:func:`~catadioptric.pose.central.translation_direction_from_crossings`),
   then the rotation and that direction refined together from the directions and the meeting
   rays (:func:`~catadioptric.pose.epipolar.refine_with_crossings`). Central rigs: that is the
   estimate. Non-central rigs: the best candidates are then refined with their metric
   translation, directions and lines on the pixels of both views
   (:func:`~catadioptric.pose.bundle.refine_two_view`), starting there, with the scene held far
   unless the pixels fix its scale (:func:`~catadioptric.pose.scale.refine_far_or_free`);
4. the candidates are ranked by that two-view cost. The best is the answer when its margin
   over the second (a log-likelihood ratio, chi-square units) is at least ``decisive``;
   otherwise the result is ``ambiguous`` and lists every candidate.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .._checks import CatadioptricError, as_count, as_scalar
from .bundle import TwoViewData, TwoViewFit, TwoViewOptions, TwoViewStart, check_residuals
from .central import (CrossingFit, Parallax, meeting_rays, parallax, residual_weights, rotation_twins,
                      translation_direction_from_crossings)
from .epipolar import refine_with_crossings
from .families import FamilyEstimate, ViewLines, fit_view_families, is_central
from .rotation import rotation_angle_deg
from .scale import ScaleOptions, refine_far_or_free, scale_by_search
from .signs import sign_candidates
from .translation import ray_depths, triangulate_line

__all__ = ["Candidate", "RelativePose", "RivalInputs", "PoseOptions", "labelled_pose", "MIN_MEETINGS",
           "WEAK_BAR_PER_PIXEL", "SAME_ANSWER_DEG"]

_FITS = 4.0  # a refinement fits the pixels when its robust cost is at most this per pixel (about 2 sigma)
#: a central pair shows no parallax when at least this many lines, and at least as many as the lines a
#: translation matched (this many times), are seen again unchanged under the rotation alone
#: (pose.central.rotation_twins): the rotation alone then explains more of the scene than a translation
#: does. On the real static pairs of validate/real, 21-41 such lines against 8-24 matched (whose
#: meeting points, under a translation hypothesis, pair neighbouring parallel lines: none of them agree
#: with no motion); on a moving rendered central pair, none
_TWINS_MIN = 5
_TWINS_OVER_MATCHED = 1
SAME_ANSWER_DEG = 5.0  # two answers whose rotations are closer than this are one answer (the ambiguities are
# discrete: half-turns, permutations of the families)
#: The meeting rays (pairs of matched lines of different families whose planes meet on the seen half of
#: both, :func:`~catadioptric.pose.central.meeting_rays`) the first stage needs before it may tell the
#: sign candidates apart (leave one unrefined, or decide a central answer by where lines meet): each ray
#: adds at most 9 chi-square units to a candidate's score, and with few of them a wrong candidate finds
#: more inliers than the right one (docs/relative_pose.md, "The verdict at wide baselines": a wide pair
#: with 12 meeting rays gave a half-turn 7 inliers, the right rotation 4-5, and the half-turn was
#: answered, margin 26.6). A count of the data, not of a candidate's inliers, which exact pixels make
#: few (17-33 at 0 px on the committed benchmark's pairs, 60-196 at 2 px): its pairs have 70 or more
#: rays at any noise (10 checked, the fewest lines among them); the first stage put a half-turn first
#: at 12 rays, and the wide pairs of 39 or more were all answered right through it.
MIN_MEETINGS = 30
#: Then the refinement's margin too is weak evidence: lines seen in both views of a (near-)central rig
#: meet in any rotation's planes, and the half-turns that fit the directions differ in little but the
#: nuisance (each line's distance, where the refinement stops along the flat scale), whose chance gap
#: grows with the pixels fitted: the bar is at least this many chi-square units per pixel of the best fit
#: (calibrated on validate/relative_pose_wide.toml; docs/relative_pose.md, "The verdict at wide baselines").
WEAK_BAR_PER_PIXEL = 0.5
#: The lines seen in one view only enter the two-view refinement when they are more than this many times
#: the lines seen in both (:func:`_noncentral_candidate`). Set between the committed benchmark's pairs
#: (at most 1.33 times as many; leaving them out changed no median beyond its interval and took a
#: fifth off the label path's time) and the wide pairs where leaving them out cost accuracy (3.8-8.9
#: times as many; validate/NOTES.md, "one-view lines").
ONE_VIEW_LINES_OVER = 1.5


@dataclass(frozen=True)
class PoseOptions:
    """The options of :func:`~catadioptric.pose.relative.relative_pose`, checked there (its docstring
    says what each means)."""

    seed: object = 0
    f_scale: float = 1.0
    pixel_sigma: float | None = None
    decisive: float = 25.0
    max_pixels: int | None = 40
    min_families: int = 2
    max_rotation_deg: float | None = None
    model_error_px: float = 0.0
    decisive_matching: float | None = None
    calibration_rms_px: float = 0.0
    #: the two-view refinement fits the lines seen in one view only too; False: only where they
    #: outnumber the lines seen in both views (``ONE_VIEW_LINES_OVER``); the image path sets it
    #: (:func:`_noncentral_candidate`)
    one_view_lines: bool = False
    #: the free and the far refinement side by side in two threads, or one after the other (1)
    #: (:attr:`~catadioptric.pose.scale.ScaleOptions.threads`)
    threads: int = 2
    #: the two-view refinement's residuals (:attr:`~catadioptric.pose.bundle.TwoViewOptions.residuals`)
    residuals: str = "first_order"

    def checked(self) -> PoseOptions:
        """These options with each number checked (a one-line error naming a bad one) and made a float."""

        def positive(name):
            v = getattr(self, name)
            return None if v is None else as_scalar(v, name, positive=True)

        ok = {k: positive(k) for k in ("decisive", "decisive_matching", "f_scale", "pixel_sigma", "max_rotation_deg")}
        for name in ("model_error_px", "calibration_rms_px"):
            v = as_scalar(getattr(self, name), name)
            if v < 0:
                raise CatadioptricError(f"{name}: expected a non-negative number of pixels, got {v}")
            ok[name] = v
        ok["threads"] = as_count(self.threads, "threads", minimum=1, maximum=2)
        check_residuals(self.residuals)
        return replace(self, **ok)


@dataclass
class Candidate:
    """One answer: ``signs`` (``{family: +1/-1}``, ``b_f ~ sign R a_f``), ``R``, ``t`` (metres;
    a unit vector for a central model; None when not estimated), ``cost`` (the two-view cost
    used for ranking, chi-square units; the direction cost when nothing else is available),
    ``direction_cost`` (directions alone), ``fit``: the two-view refinement (non-central) or
    the crossing fit (central), ``cov (6, 6)`` of ``(w, t)`` or None."""

    signs: dict
    R: np.ndarray
    t: np.ndarray | None
    cost: float
    direction_cost: float
    cov: np.ndarray | None = None
    fit: object = None

    def summary(self) -> dict:
        # signs: {family: sign}, or {family of B: (family of A, sign)} when the families were matched here
        signs = {str(k): (int(v) if not isinstance(v, tuple) else [str(v[0]), int(v[1])]) for k, v in self.signs.items()}
        return {"signs": signs, "R": self.R, "t": self.t,
                "cost": self.cost, "direction_cost": self.direction_cost}


@dataclass
class RelativePose:
    """The relative pose ``x_B = R x_A + t`` between the mirror frames of views A and B.

    ``t`` in metres when ``metric`` (a non-central rig), a unit vector otherwise (the
    direction between the viewpoints), None when it could not be estimated; ``cov (6, 6)``:
    covariance of ``(w, t)`` (left rotation vector, translation) or None. ``ambiguous``: the
    best candidate does not beat the second by ``decisive``; ``margin``: that difference
    (inf with one candidate); ``candidates``: every candidate, best first. ``families``: the
    family keys used; ``lines_matched``: lines seen in both views and used; ``model``:
    ``"non-central"`` or ``"central"``; ``sigma_px``: pixel noise estimate; ``estimates``:
    the per-view :class:`FamilyEstimate` dicts; ``notes``: what was dropped and why;
    ``parallax``: for a central model, whether the meeting rays show the translation at all
    (:func:`~catadioptric.pose.central.parallax`); when they do not (a camera turned in place, or a
    baseline too small for its distance to the lines), ``t`` is zero and ``translation_observable``
    is False."""

    R: np.ndarray
    t: np.ndarray | None
    cov: np.ndarray | None
    metric: bool
    ambiguous: bool
    margin: float
    candidates: list
    families: list
    lines_matched: int
    model: str
    sigma_px: float
    estimates: tuple = field(repr=False, default=())
    notes: list = field(default_factory=list)
    #: the meeting rays the first stage scored the candidates on (``MIN_MEETINGS``; None without labels)
    meeting_rays: int | None = None
    #: the margin the answer needed to be decisive (``decisive``, more when the first stage is weak)
    bar: float | None = None
    parallax: object = None
    #: the :class:`~catadioptric.pose.static.StaticRotation` that decided the answer (the lines its
    #: rotation alone shows again unchanged: a camera turned in place, or one that sees far lines), or None
    turned_in_place: object = None
    #: without labels, what decided (``margin``, ``bar``, ``margin_unordered``, ``appearance``,
    #: ``margin_geometry_alone``, ``margin_geometry_alone_unordered``, ``cost_geometry_alone`` per
    #: candidate, ``turned_in_place``; docs/relative_pose.md, pose.json); None with labels
    evidence: dict | None = None
    #: without labels and ambiguous, the rivals refined as the answer was: ``{candidate index:
    #: RelativePose}`` (empty otherwise), so that another cue may pick one of them
    rivals: dict = field(default_factory=dict, repr=False)
    #: without labels and ambiguous, the other rivals within the bar, not refined yet: ``{candidate
    #: index: RivalInputs}``, for :meth:`refine_rival` (None each in a pose that was pickled)
    rival_inputs: dict = field(default_factory=dict, repr=False)

    def refine_rival(self, k: int) -> bool:
        """Refine candidate ``k`` as the answer was (the labelled path with its own assignment and
        matched lines), when it is a rival within the bar not refined yet (``rival_inputs``): its
        candidate then takes the refined ``R``, ``t`` and covariance (its cost stays the matching's)
        and ``rivals[k]`` the refined pose. Returns whether ``k`` is refined (already, or now)."""
        if k in self.rivals:
            return True
        inputs = self.rival_inputs.pop(k, None)
        if inputs is None:  # not a rival within the bar, or a pose that was pickled
            return False
        from threadpoolctl import threadpool_limits

        try:
            with threadpool_limits(1):  # as relative_pose computes the answer and its rivals
                r = labelled_pose(inputs.view_a, inputs.view_b, inputs.ends, inputs.opts, fitted=inputs.fitted)
        except CatadioptricError:
            return False
        c = self.candidates[k]
        self.candidates[k] = Candidate(c.signs, r.R, r.t, c.cost, c.direction_cost, r.cov, c.fit)
        self.rivals[k] = r
        return True

    @property
    def translation_observable(self) -> bool:
        """False when a central model's meeting rays show no parallax (``t`` is then zero)."""
        return self.parallax is None or bool(self.parallax.observable)

    @property
    def rotation_std_deg(self) -> float:
        """Root of the trace of the rotation covariance, in degrees."""
        if self.cov is None:
            return float("nan")
        return float(np.degrees(np.sqrt(max(np.trace(self.cov[:3, :3]), 0.0))))

    @property
    def translation_std(self) -> float:
        """Root of the trace of the translation covariance (metres, or unit-vector units)."""
        if self.cov is None:
            return float("nan")
        return float(np.sqrt(max(np.trace(self.cov[3:, 3:]), 0.0)))


@dataclass
class RivalInputs:
    """What refining a rival answer takes (:meth:`RelativePose.refine_rival`): the two views
    relabelled by its assignment and matched lines, its families' matched ``ends``, each view's
    family estimates ``fitted`` and the pose's options."""

    view_a: ViewLines
    view_b: ViewLines
    ends: dict
    fitted: tuple
    opts: PoseOptions

    # the views hold their cameras, which need not pickle (a solver's local functions): a pickled
    # pose keeps no inputs (``refine_rival`` then returns False); a copy shares them (never changed)
    def __reduce__(self):
        return (_no_inputs, ())

    def __copy__(self):
        return self

    def __deepcopy__(self, memo):
        return self


def _no_inputs():
    """What a pickled :class:`RivalInputs` becomes: nothing to refine from."""
    return None


def _subsample(mask, k):
    idx = np.nonzero(mask)[0]
    if k is None or len(idx) <= k:
        return idx
    return idx[np.round(np.linspace(0, len(idx) - 1, k)).astype(int)]


def _two_view_direction(ea: FamilyEstimate, eb: FamilyEstimate, R) -> np.ndarray:
    """A family's direction in A from the planes (through each view's centre) of its lines in both
    views: the direction normal to all of them. One view of a near-central rig places each
    line's plane far better than the direction within it; two views pin the direction even for
    a family of one line. Oriented like view A's fit."""
    n = np.concatenate([ea.normals, eb.normals @ R])
    n = n[np.all(np.isfinite(n), axis=1)]
    if len(n) < 2:
        return ea.direction
    s = np.linalg.eigh(n.T @ n)[1][:, 0]
    return s if s @ ea.direction >= 0 else -s


def _pixels_of(view, est: FamilyEstimate, k, max_pixels):
    line = est.lines[k]
    idx = _subsample(est.inliers[k], max_pixels)
    return view.uv[line][idx]


def _corners(meeting, crossing, R, t_dir, lines, va, ea):
    """The refinement's pairs of lines whose meeting rays are inliers of ``crossing`` (stage 1),
    with the deviation of each one's epipolar residual at ``R``, ``t_dir`` (from its planes' fits
    in both views, as stage 1 weighs it); ``(None, None)`` when there are none."""
    if meeting is None or crossing is None or crossing.inliers is None or meeting.pairs is None \
            or meeting.cov_a is None:
        return None, None
    index = {va.line_id[ea[key].lines[ka]]: li for li, (key, ka, kb) in enumerate(lines)
             if ka is not None and kb is not None}
    W, _ = residual_weights(meeting.xa @ R.T, meeting.xb, R @ meeting.cov_a @ R.T, meeting.cov_b,
                            0.1 * crossing.threshold_rad / 3.0)
    sd = np.sqrt(np.einsum("i,kij,j->k", t_dir, W, t_dir))
    pairs, sig = [], []
    for k in np.flatnonzero(crossing.inliers):
        i, j = meeting.pairs[k]
        if i in index and j in index:
            pairs.append((index[i], index[j]))
            sig.append(sd[k])
    if not pairs:
        return None, None
    return np.array(pairs), np.array(sig)


def _side_in_plane(n, s, d):
    """The unit vector in the plane of normal ``n`` normal to the direction ``s`` (where a line of
    direction ``s`` in that plane lies, seen from the plane's centre), turned to the side that the
    rays ``d (M, 3)`` look to on average (as is when ``d`` is empty), and the length of ``n x s``
    before it was made unit (0: ``s`` along ``n``, the vector left zero)."""
    u = np.cross(n, s)
    norm = float(np.linalg.norm(u))
    u = u / norm if norm > 0 else u
    return (-u if len(d) and np.mean(d @ u) < 0 else u), norm


def _noncentral_candidate(cand, keys, va, vb, ea, eb, crossing, *, opts, sigma_cost, meeting=None):
    """Starting translation and two-view refinement of one rotation candidate (``opts``:
    :class:`PoseOptions`). Returns ``(TwoViewFit or None, lines matched)``; None when fewer than two
    lines are matched in both views.

    The refinement fits the lines seen in both views, and those seen in one view only with
    ``opts.one_view_lines`` or where they are more than ``ONE_VIEW_LINES_OVER`` times as many. A
    near-central rig barely tells a one-view line's distance, which ran to its bound (twice the
    mirror's size), where the refinement's steps failed twice as often; where the lines of both
    views are many, they give the families' directions without them (the relative-pose benchmark,
    at most 1.33 times as many one-view lines: its label evaluation 1.25 times faster, its medians in
    their intervals), where they are few the one-view lines carry the directions (the wide pairs,
    3.8-8.9 times as many: rotation errors up to 10 times larger without them; validate/NOTES.md,
    "one-view lines"). The image path keeps them: its lines left unmatched are mostly seen in both
    views, and without them its rotation errors were 1.6-4 times larger."""
    R = cand.R
    t_dir = cand.t if cand.t is not None else (None if crossing is None else crossing.t)
    max_pixels, pixel_sigma = opts.max_pixels, opts.pixel_sigma
    matched, single = [], []  # (key, ka, kb) with ka/kb None for a line seen in one view only
    for key in keys:
        A_ids = {va.line_id[i]: k for k, i in enumerate(ea[key].lines) if va.line_id[i] is not None}
        B_ids = {vb.line_id[i]: k for k, i in enumerate(eb[key].lines) if vb.line_id[i] is not None}
        matched += [(key, A_ids[lid], B_ids[lid]) for lid in A_ids if lid in B_ids]
        single += [(key, k, None) for k, i in enumerate(ea[key].lines) if va.line_id[i] not in B_ids]
        single += [(key, None, k) for k, i in enumerate(eb[key].lines) if vb.line_id[i] not in A_ids]
    if not (opts.one_view_lines or len(single) > ONE_VIEW_LINES_OVER * len(matched)):
        single = []
    if len(matched) < 2:
        return None, len(matched)
    rays = lambda view, est, k: view.cam.backproject(_pixels_of(view, est, k, max_pixels))
    ra = [rays(va, ea[key], ka) for key, ka, _ in matched]
    rb = [rays(vb, eb[key], kb) for key, _, kb in matched]
    ok = lambda r: (r.origins[r.valid], r.directions[r.valid])
    if crossing is None:  # no direction to start from: the lines alone do not place the views
        return None, len(matched)
    # directions from the planes of both views; the translation's direction between the rays' centres
    # from where lines meet, its length by a search on the matched lines' pixels
    used = [k for k in keys if any(m[0] == k for m in matched)]
    fam_index = {k: i for i, k in enumerate(used)}
    dirs_a = np.array([_two_view_direction(ea[k], eb[k], R) for k in used])
    offset = eb[keys[0]].centre - R @ ea[keys[0]].centre
    alpha = scale_by_search(va, vb, [(fam_index[key], _pixels_of(va, ea[key], ka, max_pixels),
                                       _pixels_of(vb, eb[key], kb, max_pixels)) for key, ka, kb in matched],
                             dirs_a, R, t_dir, offset, sigma_cost)
    t0 = alpha * t_dir + offset
    # matched lines triangulated; a line seen in one view starts in its plane through that view's
    # centre, as far as the matched lines' median (one view of a near-central rig hardly places it:
    # the refinement moves it where its pixels say)
    c_a = ea[keys[0]].centre
    c_b_in_a = R.T @ (eb[keys[0]].centre - t0)
    rays_ab = [(dirs_a[fam_index[key]], np.concatenate([ok(a)[0], (ok(b)[0] - t0) @ R]),
                np.concatenate([ok(a)[1], ok(b)[1] @ R])) for (key, _, _), a, b in zip(matched, ra, rb)]
    tri = [triangulate_line(*r) for r in rays_ab]
    # a line the start puts behind either view is not placed: the search's length can be far from
    # the true one (a near-central rig barely tells it), and then two views' planes of a line nearly
    # parallel to the baseline can meet behind a view, where none of its pixels can be explained
    n_a = [len(ok(a)[0]) for a in ra]
    front = [bool(np.median(ray_depths(q, s, o[:k], d[:k])) > 0 and np.median(ray_depths(q, s, o[k:], d[k:])) > 0)
             for (q, _), (s, o, d), k in zip(tri, rays_ab, n_a)]
    tri = [(q, well and f) for (q, well), f in zip(tri, front)]
    dist = [np.linalg.norm(np.cross(q - c_a, r[0])) for (q, well), r in zip(tri, rays_ab) if well]
    d_med = float(np.median(dist)) if dist else 10.0 * float(np.linalg.norm(t0))
    pts = []
    for (q, well), (s, o, d), (key, ka, _), f, k in zip(tri, rays_ab, matched, front, n_a):
        if not f:  # in its plane through c_A, on the side A's rays see, as far as the placed lines' median
            u, _ = _side_in_plane(ea[key].normals[ka], s, d[:k])
            q = c_a + d_med * u
            q = q - (q @ s) * s
        elif not well:  # in its plane through c_A, as far as the well-placed lines' median
            u, _ = _side_in_plane(ea[key].normals[ka], s, d)
            q, _ = triangulate_line(s, o, d, prior=c_a + d_med * u)
        pts.append(q)
    lines = list(matched)
    for key, ka, kb in single:
        if key not in fam_index:
            continue
        s = dirs_a[fam_index[key]]
        if ka is not None:
            n, c, r = ea[key].normals[ka], c_a, rays(va, ea[key], ka)
            d = r.directions[r.valid]
        else:
            n, c, r = R.T @ eb[key].normals[kb], c_b_in_a, rays(vb, eb[key], kb)
            d = r.directions[r.valid] @ R
        u, norm = _side_in_plane(n, s, d)
        if norm < 1e-9 or len(d) == 0:
            continue
        pts.append(c + d_med * u)
        lines.append((key, ka, kb))
    uv_a, own_a, uv_b, own_b = [], [], [], []
    for li, (key, ka, kb) in enumerate(lines):
        if ka is not None:
            uv_a.append(_pixels_of(va, ea[key], ka, max_pixels))
            own_a.append(np.full(len(uv_a[-1]), li))
        if kb is not None:
            uv_b.append(_pixels_of(vb, eb[key], kb, max_pixels))
            own_b.append(np.full(len(uv_b[-1]), li))
    corners, corner_sigma = _corners(meeting, crossing, R, t_dir, lines, va, ea)
    data = TwoViewData(va.cam, vb.cam, np.concatenate(uv_a), np.concatenate(own_a), np.concatenate(uv_b),
                       np.concatenate(own_b), line_family=np.array([fam_index[k] for k, _, _ in lines]),
                       centres=(ea[keys[0]].centre, eb[keys[0]].centre), corners=corners, corner_sigma=corner_sigma)
    start = TwoViewStart(R, t0, dirs_a, np.array(pts))
    options = ScaleOptions(refine=TwoViewOptions(sigma_cost=sigma_cost, pixel_sigma=pixel_sigma, residuals=opts.residuals),
                           threads=opts.threads)
    fit = refine_far_or_free(data, start, options)
    return fit, len(matched)
def _direction_margin(out):
    """The margin of the first candidate of ``out`` over the next different answer (rotations more
    than ``SAME_ANSWER_DEG`` apart) by the directions' cost alone (0 when a different answer fits them as
    well; inf when there is none)."""
    gaps = [o.direction_cost - out[0].direction_cost for o in out[1:]
            if rotation_angle_deg(o.R @ out[0].R.T) > SAME_ANSWER_DEG]
    return max(0.0, min(gaps)) if gaps else float("inf")

def _within_prior(cands, max_rotation_deg, what):
    """The candidates (anything with ``.R``) that turn by at most ``max_rotation_deg``."""
    if max_rotation_deg is None:
        return cands
    kept = [c for c in cands if rotation_angle_deg(c.R) <= max_rotation_deg]
    if not kept:
        angles = sorted(round(rotation_angle_deg(c.R), 1) for c in cands)
        raise CatadioptricError(f"max_rotation_deg: no {what} turns by at most {max_rotation_deg} degrees (the "
                                f"candidates turn by {angles})")
    return kept

def labelled_pose(view_a: ViewLines, view_b: ViewLines, ends: dict | None, opts: PoseOptions,
                  fitted: tuple | None = None) -> RelativePose:
    """The relative pose from lines matched across the views by ``line_id`` (steps 1-4 of the module
    docstring; :func:`~catadioptric.pose.relative.relative_pose` checks the arguments and sends views
    without ``line_id`` to :func:`~catadioptric.pose.unlabelled.unlabelled_pose`). ``fitted``: each
    view's families already fitted with these options (``{family: FamilyEstimate}`` per view, keyed
    as the views' families), used instead of fitting them again."""
    seed, f_scale, pixel_sigma, decisive = opts.seed, opts.f_scale, opts.pixel_sigma, opts.decisive
    max_pixels, min_families, max_rotation_deg = opts.max_pixels, opts.min_families, opts.max_rotation_deg
    model_error_px = opts.model_error_px
    central = is_central(view_a.cam)
    fa, fb = view_a.families(), view_b.families()
    common = [k for k in fa if k in fb]
    if ends is not None:
        missing = [k for k in common if k not in ends]
        if missing:
            raise CatadioptricError(f"ends: expected the matched ends of every family seen in both views, "
                                    f"missing {missing}")
    hints_a = {k: ends[k][0] for k in common} if ends is not None else None
    hints_b = {k: ends[k][1] for k in common} if ends is not None else None
    # each view: planes of its lines and its families' directions (stages 1 and the refinement's start)
    if fitted is None:
        ea, fail_a = fit_view_families(view_a, keys=common, seed=seed, f_scale=f_scale, pixel_sigma=pixel_sigma,
                                       hints=hints_a, max_pixels=max_pixels, exact=False, model_error_px=model_error_px,
                                       calibration_rms_px=opts.calibration_rms_px)
        eb, fail_b = fit_view_families(view_b, keys=common, seed=seed, f_scale=f_scale, pixel_sigma=pixel_sigma,
                                       hints=hints_b, max_pixels=max_pixels, exact=False, model_error_px=model_error_px,
                                       calibration_rms_px=opts.calibration_rms_px)
    else:
        (ea, fail_a), (eb, fail_b) = (_refitted(f, common, h) for f, h in zip(fitted, (hints_a, hints_b)))
    notes = [f"family {k} not used in view A: {v}" for k, v in fail_a.items()]
    notes += [f"family {k} not used in view B: {v}" for k, v in fail_b.items()]
    keys = [k for k in common if k in ea and k in eb]
    if len(keys) < min_families:
        only_a = [k for k in fa if k not in fb]
        only_b = [k for k in fb if k not in fa]
        raise CatadioptricError(
            f"views: expected at least {min_families} families of lines fitted in both views, got {len(keys)} "
            f"(families with lines in A: {len(fa)}, in B: {len(fb)}, in both: {len(common)}; seen only in A: "
            f"{len(only_a)}, only in B: {len(only_b)}; fits that failed: "
            + ("; ".join(notes) if notes else "none") + ")")
    a = np.array([ea[k].direction for k in keys])
    b = np.array([eb[k].direction for k in keys])
    Ca = np.array([ea[k].cov for k in keys])
    Cb = np.array([eb[k].cov for k in keys])
    sigmas = [e.sigma for e in list(ea.values()) + list(eb.values()) if np.isfinite(e.sigma)]
    sigma_est = float(np.median(sigmas)) if sigmas else f_scale
    # the robust losses' scale: the pixel noise, but not below a tenth of f_scale (exact pixels would
    # otherwise make every pixel an outlier of a loss a thousandth of a pixel wide)
    sigma_cost = pixel_sigma if pixel_sigma is not None else max(sigma_est, 0.1 * f_scale)
    # stage 1: the sign candidates, ranked by their directions and where lines meet (cheap)
    stage, out, rays = _first_stage(a, b, Ca, Cb, keys, view_a, view_b, ea, eb, ends, max_rotation_deg, sigma_cost,
                                    seed, notes)
    # how much the first stage knows: with few meeting rays its ranking of the sign candidates is no
    # evidence (MIN_MEETINGS), only the directions' part of its cost is
    n_meet = 0 if rays is None else len(rays.xa)
    weak = n_meet < MIN_MEETINGS
    n_matched = rays.n_lines if rays is not None else 0
    margin = out[1].cost - out[0].cost if len(out) > 1 else float("inf")
    if weak and len(out) > 1:
        margin = _direction_margin(out)
        if not central:
            notes.append(f"the first stage rests on {n_meet} meeting rays (fewer than {MIN_MEETINGS}): every "
                         f"sign candidate refined on the pixels, none dismissed by where lines meet")
        else:
            notes.append(f"the answer rests on {n_meet} meeting rays (fewer than {MIN_MEETINGS}): its margin is "
                         f"the directions' alone ({margin:.1f}), where lines meet does not tell the candidates apart")
    if not central:
        out, n_matched, refined_margin = _refine_on_pixels(out, stage, keys, view_a, view_b, ea, eb, rays, weak, notes,
                                                           opts=opts, sigma_cost=sigma_cost, n_matched=n_matched)
        if refined_margin is not None:
            margin = refined_margin
    best = out[0]
    if not central and not isinstance(best.fit, TwoViewFit):
        notes.append("no two lines were matched in both views with a fitted 3-D line in each: metric translation "
                     "not estimated" + ("" if best.t is None else "; t is the direction between the rays' centres"))
    if best.t is None:
        notes.append("no two lines of different families meet in both views: translation not estimated")
    cov = best.cov
    if cov is None:
        cov = np.full((6, 6), np.nan)
        cov[:3, :3] = next(s[1].cov for s in stage if rotation_angle_deg(s[1].R @ best.R.T) < 1e-9)
    sigma = best.fit.sigma if isinstance(best.fit, TwoViewFit) else sigma_est
    bar = decisive
    if weak and isinstance(best.fit, TwoViewFit) and len(out) > 1:
        bar = max(decisive, WEAK_BAR_PER_PIXEL * float(np.sum(best.fit.n_pixels)))
        if decisive <= margin < bar:
            notes.append(f"margin {margin:.1f} on the pixels, against the bar of {bar:.0f} of an answer whose first "
                         f"stage is weak ({WEAK_BAR_PER_PIXEL:g} per pixel fitted): ambiguous")
    par, t_best = None, best.t
    if central and t_best is not None and isinstance(best.fit, CrossingFit):
        par, t_best = _parallax_verdict(best, rays, view_a, view_b, ea, eb, keys, n_matched, notes)
    return RelativePose(R=best.R, t=t_best, cov=cov, metric=isinstance(best.fit, TwoViewFit), parallax=par,
                        ambiguous=bool(margin < bar), margin=float(margin), candidates=out, families=keys,
                        lines_matched=n_matched, model="central" if central else "non-central", sigma_px=float(sigma),
                        estimates=(ea, eb), notes=notes, meeting_rays=n_meet, bar=float(bar))

def _first_stage(a, b, Ca, Cb, keys, view_a, view_b, ea, eb, ends, max_rotation_deg, sigma_cost, seed, notes):
    """Stage 1 of :func:`_relative_pose`: the sign candidates of the families' directions ``a``,
    ``b`` (covariances ``Ca``, ``Cb``; all signs known with ``ends``) within the prior, each with
    the direction between the centres from the rays where lines meet. Returns ``(stage, out,
    rays)``: per candidate ``(score, sign candidate, crossing fit)``, best first; the
    :class:`Candidate` of each, in that order; the meeting rays. Notes are appended to ``notes``."""
    cands = sign_candidates(a, b, Ca, Cb, signs=np.ones(len(keys)) if ends is not None else None)
    n_all = len(cands)
    cands = _within_prior(cands, max_rotation_deg, "sign pattern of the families")
    if len(cands) < n_all:
        notes.append(f"{n_all - len(cands)} of {n_all} sign patterns turn by more than max_rotation_deg = "
                     f"{max_rotation_deg} degrees: not considered")
    # stage 1: directions and the rays where lines meet, for every candidate (cheap)
    rays = meeting_rays(view_a, view_b, ea, eb, keys)
    stage = []
    for c in cands:
        cr = translation_direction_from_crossings(rays, c.R, sigma_px=sigma_cost, seed=seed)
        # a rotation under which the meeting rays give no direction is scored as if none of them fitted
        # (the truncated cost's ceiling, 9 each), not as if they all fitted perfectly (0)
        stage.append((c.cost + (cr.cost if cr is not None else 0.0 if rays is None else 9.0 * len(rays.xa)), c, cr))
    stage.sort(key=lambda x: x[0])
    out = []
    for score1, c, cr in stage:
        cov, R, t = None, c.R, None if cr is None else cr.t
        if cr is not None:
            cov = np.full((6, 6), np.nan)
            cov[:3, :3], cov[3:, 3:] = c.cov, cr.cov
            if rays.cov_a is not None and cr.n_inliers >= 2:
                # the rotation and the translation's direction together, from the directions and the
                # inlier meeting rays (pose/epipolar.py); the candidates keep their stage-1 ranking
                ef = refine_with_crossings(a * c.signs[:, None], b, Ca, Cb, rays, cr, c.R)
                R, cov = ef.R, ef.cov
                # the direction again at that rotation, as stage 1 places it: its inliers follow their
                # own spread, so that exact pixels give it exactly (the joint fit's Cauchy weights
                # leave the rays that pass the threshold without meeting a pull of 1e-3 degree)
                cr_r = translation_direction_from_crossings(rays, R, sigma_px=sigma_cost, seed=seed)
                t = cr.t if cr_r is None else cr_r.t
        out.append(Candidate(dict(zip(keys, c.signs.astype(int))), R, t, score1, c.cost, cov, cr))
    return stage, out, rays


def _refine_on_pixels(out, stage, keys, view_a, view_b, ea, eb, rays, weak, notes, *, opts, sigma_cost, n_matched):
    """Stage 2 of :func:`_relative_pose` (non-central rigs): the candidates ``out`` of stage 1
    (``stage``: their ``(score, sign candidate, crossing fit)``) refined on the pixels of both views
    as the comment below says (``opts``: :class:`PoseOptions`). Returns ``(out, n_matched,
    margin)``: the candidates, the refined first by their cost; the most lines matched; the margin to
    the next different answer, None when no candidate was refined (stage 1's margin stands). Notes
    are appended to ``notes``."""
    margin, decisive = None, opts.decisive
    # stage 2: the metric refinement on the pixels of both views. The best candidate of stage 1 and
    # every one stage 1 cannot tell from it (within ``decisive``) are refined and ranked by the
    # refinement's cost; if the best of stage 1 then does not fit the pixels, every candidate is.
    todo = [i for i, o in enumerate(out) if o.cost < out[0].cost + decisive or weak]
    done = set()
    while todo:
        for i in todo:
            fit, n_m = _noncentral_candidate(out[i], keys, view_a, view_b, ea, eb, stage[i][2], opts=opts,
                                             sigma_cost=sigma_cost, meeting=rays)
            n_matched = max(n_matched, n_m)
            done.add(i)
            if fit is not None:
                o = out[i]
                out[i] = Candidate(o.signs, fit.R, fit.t, fit.cost, o.direction_cost, fit.cov, fit)
        fits = [out[i].fit for i in done if isinstance(out[i].fit, TwoViewFit)]
        good = any(f.cost <= _FITS * int(f.n_pixels.sum()) for f in fits)
        todo = [] if good or not fits else [i for i in range(len(out)) if i not in done]
    refined = sorted((out[i] for i in done if isinstance(out[i].fit, TwoViewFit)), key=lambda o: o.cost)
    if refined:
        # a rival whose refinement failed (no crossing fit under its rotation) was not scored by the
        # refinement: it counts by its stage-1 cost over the winner's, as the rivals never refined do
        # (it was refined because stage 1 could not tell it from the best), not as no rival at all
        s_win = next(stage[i][0] for i in done if out[i] is refined[0])
        failed = [max(0.0, stage[i][0] - s_win) for i in done if not isinstance(out[i].fit, TwoViewFit)
                  and rotation_angle_deg(out[i].R @ refined[0].R.T) > SAME_ANSWER_DEG]
        rest = [o for i, o in enumerate(out) if i not in done or not isinstance(o.fit, TwoViewFit)]
        out = refined + rest
        # the margin is to the next different answer (two candidates that refine to the same rotation
        # are one answer); candidates never refined lost stage 1 by at least ``decisive``
        others = [o.cost - refined[0].cost for o in refined[1:]
                  if rotation_angle_deg(o.R @ refined[0].R.T) > SAME_ANSWER_DEG] + failed
        if len(done) < len(stage):
            others.append(max(decisive, min(s[0] for i, s in enumerate(stage) if i not in done) - stage[0][0]))
        if failed:
            notes.append(f"{len(failed)} rival answers could not be refined on the pixels: counted by their "
                         f"first-stage cost over the best's (margin {min(failed):.1f} from them)")
        margin = min(others) if others else float("inf")
    return out, n_matched, margin


def _parallax_verdict(best, rays, view_a, view_b, ea, eb, keys, n_matched, notes):
    """For a central answer with a translation direction from the meeting rays: its parallax and
    translation, ``(par, t)``: ``t`` zero (its direction not observable, a note appended to
    ``notes``) when the meeting points agree with the rotation alone, or when many lines of A are
    seen again unchanged under it (a camera turned in place); else ``best.t``."""
    t_best = best.t
    par = parallax(rays, best.R, best.fit)
    twins = rotation_twins(view_a, view_b, ea, eb, keys, best.R)
    if par is not None and not par.observable:
        why = (f"the {par.n_rays} meeting points agree with a rotation alone (median {par.median_deg:.3g} deg apart, "
               f"chi-square {par.chi2:.1f} on {par.dof} degrees of freedom, p = {par.p_value:.2g})")
    elif len(twins.pairs) >= max(_TWINS_MIN, _TWINS_OVER_MATCHED * n_matched):
        why = (f"{len(twins.pairs)} of the {twins.lines_a} lines of A's matched families are seen again unchanged "
               f"under the rotation alone (same plane and place), against {n_matched} lines that a translation "
               f"matched")
        par = Parallax(par.chi2 if par else float("nan"), par.dof if par else 0, par.p_value if par else float("nan"),
                       False, par.n_rays if par else 0, par.median_deg if par else float("nan"))
    else:
        why = None
    if why is not None:
        t_best = np.zeros(3)
        notes.append(f"no parallax: {why}: a camera turned in place, or a baseline too small to see; t is "
                     f"reported as zero (its direction is not observable)")
    return par, t_best

def _refitted(fitted: dict, keys, hints) -> tuple[dict, dict]:
    """:func:`~catadioptric.pose.families.fit_view_families`'s answer for ``keys`` from families
    ``fitted`` with the same options: each direction (and Pluecker line) signed as its hint says."""
    est, fail = {}, {}
    for k in keys:
        if k not in fitted:
            fail[k] = "not fitted"
            continue
        e = fitted[k]
        h = None if hints is None else hints.get(k)
        if h is not None and e.direction @ np.asarray(h, float) < 0:
            e = replace(e, direction=-e.direction, pluecker=-e.pluecker)
        est[k] = e
    return est, fail
