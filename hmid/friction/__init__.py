"""Rig friction identified from free-fall logs, for the balance terms that take it from them.

Thesis Ch. 4: with the muscle disconnected, the hanging mass drags the block along the rail and
friction is the only unknown force (eq. 4.1 with F_m = 0). A rig declares its free-fall test as
a :class:`FallRig` (the moving mass, the drive that pulls it) and a Coulomb term ``from:
free_fall``; the identified law then enters its balance with that term's sign.

* :class:`FrictionModel` strategies: :class:`Coulomb` (the thesis's) and :class:`CoulombViscous`.
* :func:`identify_friction` fits a model to the position of each free fall and pools the logs
  into a :class:`FrictionEstimate` (intervals, per-log fits, force cross-check, Cochran's Q).
* :class:`LawCheck`: whether the falls' residuals accept the law (runs test; Coulomb + viscous
  against Coulomb), said on every run when they do not.
* :func:`plot_free_fall` draws the fits and their residuals.
* :func:`affine_friction`: (Fc, b) of a law whose magnitude is Fc + b |v| (the model files').

``friction(v) = sign(v) Fc (+ b v)`` is a force along +x with the sign of the motion.
"""

from hmid.friction._estimate import (
    FrictionEstimate,
    LoadCellCheck,
    LogFriction,
    affine_friction,
)
from hmid.friction._identify import (
    MIN_SLIDING_SAMPLES,
    derivative_reach,
    identify_friction,
    sliding_segment,
)
from hmid.friction._law import LawCheck
from hmid.friction._models import Coulomb, CoulombViscous, FallFit, FallRig, FrictionModel
from hmid.friction._plot import plot_free_fall

__all__ = [
    "MIN_SLIDING_SAMPLES",
    "Coulomb",
    "CoulombViscous",
    "FallFit",
    "FallRig",
    "FrictionEstimate",
    "FrictionModel",
    "LawCheck",
    "LoadCellCheck",
    "LogFriction",
    "affine_friction",
    "derivative_reach",
    "identify_friction",
    "plot_free_fall",
    "sliding_segment",
]
