"""Denoising (moving averages) and derivative estimation.

Smoothers (:class:`Smoother`: :class:`MovingAverage`, :class:`Identity`) and differentiators
(:class:`Differentiator`: :class:`DerivativeOfSmoothed`, :class:`SavitzkyGolay`,
:class:`SmoothedFiniteDifference`) are frozen, validated strategies that a pipeline picks from
its config.

Import from ``hmid.signal``: the function :func:`moving_average` re-exported here shadows the
submodule of the same name as an attribute, so ``import hmid.signal.moving_average as m`` gives
the function, not the module.
"""

from hmid.signal.derivatives import (
    MAX_STEP_JITTER,
    DerivativeOfSmoothed,
    Differentiator,
    SavitzkyGolay,
    SmoothedFiniteDifference,
    estimate_motion,
)
from hmid.signal.moving_average import (
    Identity,
    MovingAverage,
    Smoother,
    Window,
    moving_average,
)

__all__ = [
    "MAX_STEP_JITTER",
    "DerivativeOfSmoothed",
    "Differentiator",
    "Identity",
    "MovingAverage",
    "SavitzkyGolay",
    "SmoothedFiniteDifference",
    "Smoother",
    "Window",
    "estimate_motion",
    "moving_average",
]
