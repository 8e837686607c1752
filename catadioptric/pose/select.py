"""Choosing, pair by pair, between the exact (non-central) answer and the central approximation's.

On a near-central rig the exact model pays for the line distances it must estimate and barely
sees, the central approximation for its model error; which price is lower depends on the noise
and on the pair (docs/relative_pose.md, "Where the refinement ends on near-central rigs").
:func:`choose_model` takes both answers of one pair (the same pixels through both models,
:func:`~catadioptric.pose.relative_pose`) and keeps the rotation whose own covariance promises
the smaller error (``rotation_std_deg``). That is only fair when the central answer's covariance
carries its model error: estimate it with ``relative_pose(..., model_error_px=e)``, ``e`` the
approximation's rms pixel error (``validate.relative_pose.central_model_error_px``), as the
benchmark does.

The central answer is never taken when either answer is ambiguous (a verdict is not a
precision) or when the two rotations disagree by more than ``agree_sigma`` of their combined
deviations: then one of them is wrong, and which one the covariances cannot say. The central
translation is a direction: a choice of the central model concerns the rotation; the exact
answer's metric translation stays where it is (:attr:`ModelChoice.exact`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import CatadioptricError, as_scalar
from .relative import RelativePose
from .rotation import rotation_angle_deg

__all__ = ["ModelChoice", "choose_model"]


@dataclass
class ModelChoice:
    """``model``: ``"exact"`` or ``"central"``; ``pose``: that model's answer (``pose.R`` is the
    rotation chosen); ``exact``, ``central``: both answers; ``reason``: why, in words."""

    model: str
    pose: RelativePose
    exact: RelativePose
    central: RelativePose | None
    reason: str

    @property
    def R(self) -> np.ndarray:
        return self.pose.R

    @property
    def rotation_std_deg(self) -> float:
        return self.pose.rotation_std_deg


def choose_model(exact: RelativePose, central: RelativePose | None, *, agree_sigma: float = 5.0) -> ModelChoice:
    """The rotation of ``exact`` or of ``central`` (module docstring), whichever claims the smaller
    deviation; ``central`` may be None (then ``exact``)."""
    if not isinstance(exact, RelativePose):
        raise CatadioptricError(f"exact: expected a RelativePose, got {type(exact).__name__}")
    if central is not None and not isinstance(central, RelativePose):
        raise CatadioptricError(f"central: expected a RelativePose or None, got {type(central).__name__}")
    agree_sigma = as_scalar(agree_sigma, "agree_sigma", positive=True)

    def keep(why):
        return ModelChoice("exact", exact, exact, central, why)

    if central is None:
        return keep("no central answer")
    if exact.ambiguous or central.ambiguous:
        return keep("an ambiguous answer is not compared by its precision")
    se, sc = exact.rotation_std_deg, central.rotation_std_deg
    if not (np.isfinite(se) and np.isfinite(sc)):
        return keep(f"a deviation is not known (exact {se:.3g}, central {sc:.3g} deg)")
    apart = rotation_angle_deg(exact.R @ central.R.T)
    bound = agree_sigma * float(np.hypot(se, sc)) + 1e-6
    if apart > bound:
        return keep(f"the two rotations are {apart:.3g} deg apart, more than {agree_sigma:g} combined deviations "
                    f"({bound:.3g} deg): one of them is wrong")
    if sc < se:
        return ModelChoice("central", central, exact, central,
                           f"central deviation {sc:.3g} deg < exact {se:.3g} deg")
    return keep(f"exact deviation {se:.3g} deg <= central {sc:.3g} deg")
