"""Which end of each family is which: sign patterns of matched directions, and the rotations
they allow.

A family of parallel lines fixes a direction up to sign in each view. With the ends matched
(the paper's matched vanishing points) the signs are known and nothing is searched. Otherwise
every pattern is a hypothesis ``b_f ~ sigma_f R a_f``; patterns are generated from pairs of
families (four sign choices each give a rotation; every other family then takes the sign
that rotation gives it) and refined with the covariances. Several patterns can fit the
directions exactly: for two orthogonal families, or an orthogonal triad (any Manhattan scene),
flipping two directions is a rotation by 180 degrees about the third, and when every family is
horizontal or vertical the half-turn about the vertical flips all the horizontal ones. The
directions cannot tell those apart; the caller scores the survivors with the two-view geometry
of the lines (:mod:`catadioptric.pose.labelled`).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError, as_float_array
from .rotation import refine_rotation, rotation_angle_deg, rotation_from_directions

__all__ = ["SignCandidate", "sign_candidates"]


@dataclass
class SignCandidate:
    """One sign pattern: ``signs (F,)`` (+1/-1, ``b_f ~ signs_f R a_f``), the refined rotation ``R``
    with ``cov (3, 3)``, per family ``chi2 (F,)`` and robust ``weights``, and the robust
    direction ``cost``."""

    signs: np.ndarray
    R: np.ndarray
    cov: np.ndarray
    chi2: np.ndarray
    weights: np.ndarray
    cost: float


def _refined(a, b, Ca, Cb, signs, R0=None) -> SignCandidate:
    bb = b * signs[:, None]
    fit = refine_rotation(a, bb, Ca, Cb, R0)
    return SignCandidate(signs=signs.astype(float), R=fit.R, cov=fit.cov, chi2=fit.chi2, weights=fit.weights,
                         cost=fit.cost)


def sign_candidates(a, b, cov_a, cov_b, *, signs=None, max_cost_gap: float = 100.0,
                    max_candidates: int = 8, same_deg: float = 0.5) -> list[SignCandidate]:
    """Sign patterns of the matched directions ``a, b (F, 3)`` (F >= 2) that a rotation can fit.

    ``cov_a, cov_b (F, 3, 3)``: the directions' covariances. ``signs (F,)``: the known pattern
    (ends matched): one candidate, nothing searched. Otherwise the distinct patterns generated
    from every pair of non-parallel families, refined (robust, covariance-weighted), sorted by
    cost; those within ``max_cost_gap`` (chi-square units) of the best are kept, at most
    ``max_candidates``; a pattern whose rotation is within ``same_deg`` of a better one's is the
    same answer and dropped.
    """
    a = as_float_array(a, "a", 3).reshape(-1, 3)
    b = as_float_array(b, "b", 3).reshape(-1, 3)
    Ca = as_float_array(cov_a, "cov_a", (3, 3)).reshape(-1, 3, 3)
    Cb = as_float_array(cov_b, "cov_b", (3, 3)).reshape(-1, 3, 3)
    F = len(a)
    if not (len(b) == len(Ca) == len(Cb) == F):
        raise CatadioptricError(f"a, b, cov_a, cov_b: expected the same count, got {F}, {len(b)}, {len(Ca)}, "
                                f"{len(Cb)}")
    if F < 2:
        raise CatadioptricError(f"a: expected at least 2 families seen in both views, got {F}")
    if signs is not None:
        sg = as_float_array(signs, "signs").reshape(-1)
        if len(sg) != F or not np.all(np.isin(sg, (-1.0, 1.0))):
            raise CatadioptricError(f"signs: expected {F} values of +1 or -1, got {sg.tolist()}")
        return [_refined(a, b, Ca, Cb, sg)]
    an = a / np.linalg.norm(a, axis=1, keepdims=True)
    bn = b / np.linalg.norm(b, axis=1, keepdims=True)
    # most informative families first: pairs among the 6 best-determined families suffice
    info = 1.0 / np.maximum(np.trace(Ca, axis1=1, axis2=2) + np.trace(Cb, axis1=1, axis2=2), 1e-300)
    order = np.argsort(-info)[: min(F, 6)]
    patterns = {}
    for f, g in itertools.combinations(order, 2):
        if np.linalg.norm(np.cross(an[f], an[g])) < 0.05 or np.linalg.norm(np.cross(bn[f], bn[g])) < 0.05:
            continue  # nearly parallel: no rotation from this pair
        for sf, sg_ in itertools.product((1.0, -1.0), repeat=2):
            try:
                R = rotation_from_directions(an[[f, g]], bn[[f, g]] * np.array([sf, sg_])[:, None])
            except CatadioptricError:
                continue
            dots = np.sum((an @ R.T) * bn, axis=1)
            pat = np.where(dots >= 0, 1.0, -1.0)
            pat[f], pat[g] = sf, sg_
            key = tuple(pat.astype(int))
            if key not in patterns:
                patterns[key] = R
    if not patterns:
        raise CatadioptricError("a: expected at least two non-parallel families, got nearly parallel ones")
    cands = [_refined(a, b, Ca, Cb, np.array(k, float), R0) for k, R0 in patterns.items()]
    cands.sort(key=lambda c: c.cost)
    best = cands[0].cost
    kept = []
    for c in cands:
        if c.cost > best + max_cost_gap or len(kept) >= max_candidates:
            break
        # two patterns that differ only in a family that carries no weight give the same rotation:
        # one answer, not two (the lines do not care about a direction's sign)
        if any(rotation_angle_deg(c.R @ k.R.T) < same_deg for k in kept):
            continue
        kept.append(c)
    return kept
