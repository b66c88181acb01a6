"""Rig friction: identified from free-fall logs, then used to reconstruct the muscle force.

Thesis Ch. 4: with the muscle disconnected, the hanging mass drags the block along the rail and
friction is the only unknown force (eq. 4.1 with F_m = 0); the muscle force of a dynamic log is
then the load-cell force plus friction (eqs. 4.1-4.2), or, without a load cell, the inertial force
plus friction (eq. 5.1).

* :class:`FrictionModel` strategies: :class:`Coulomb` (the thesis's) and :class:`CoulombViscous`.
* :func:`identify_friction` fits a model to the x(t) of each free fall and pools the logs into a
  :class:`FrictionEstimate` (intervals, per-log fits, load-cell cross-check, Cochran's Q).
* :func:`reconstruct_muscle_force` adds ``F_m``, ``friction`` and ``sliding`` to a denoised log.
* :func:`plot_free_fall` draws the fits and their residuals.

Sign convention (the simulator's): friction is a force along +x that opposes motion,
``friction(v) = sign(v) Fc (+ b v)``, and ``(M + m1) a = F_m - m1 g - friction``.
"""

from hmid.friction._estimate import FrictionEstimate, LoadCellCheck, LogFriction
from hmid.friction._identify import (
    MIN_SLIDING_SAMPLES,
    derivative_reach,
    identify_friction,
    sliding_segment,
)
from hmid.friction._models import Coulomb, CoulombViscous, FallFit, FrictionModel
from hmid.friction._plot import plot_free_fall
from hmid.friction._reconstruct import reconstruct_muscle_force

__all__ = [
    "MIN_SLIDING_SAMPLES",
    "Coulomb",
    "CoulombViscous",
    "FallFit",
    "FrictionEstimate",
    "FrictionModel",
    "LoadCellCheck",
    "LogFriction",
    "derivative_reach",
    "identify_friction",
    "plot_free_fall",
    "reconstruct_muscle_force",
    "sliding_segment",
]
