"""SINDy: a sparse force map F_m = Theta(x, v, P) xi discovered with pysindy, and its free run.

Why a force map and not SINDy-with-control on [x, v]: the force map is scored one-step exactly
like the polynomial family, its target (the reconstructed F_m) is far less noisy than the
estimated acceleration, and stuck samples can be dropped by |v| without touching the target's
meaning; the equation of motion follows from it and the identified friction.

* :class:`SINDyForceModel` -- the force map by pysindy's STLSQ on a physics library (polynomials
  in x, v, P with per-variable caps, plus tanh(v/v0) for friction; no duplicate columns), rows
  with |v| < stick_speed left out, threshold by blocked cross-validation on the training rows
  (one-standard-error rule), a blocked-bootstrap ensemble (seeded ``numpy.random.Generator``,
  NumPy's global state untouched) for each term's inclusion probability, the support chosen by
  the same cross-validation among those the path and the ensemble keep, and an interval for
  each selected coefficient: the post-selection OLS refit's from the residual's autocovariance
  (conditional on the selected support; or the ensemble's percentile interval on request). All
  least-squares problems run on QR-compressed blocks, so 30k rows fit in about a second.
* :class:`EquationOfMotion` -- mass a = F_m(x, v, P) - friction(v) - offset from the rig's
  declared balance and motion (Ch. 4: mass M + m1, offset m1 g), sign(v) replaced by tanh(v/v0),
  and :func:`free_run` -- fixed-step RK4 on each held-out block, driven by the measured pressure,
  with divergence detection (reported with its time, never raised) and a wall-time bound.

The pipeline's family (:mod:`hmid.families.sindy`) wraps these for the report and the loop.
"""

from hmid.models.sindy._freerun import (
    BlockRun,
    EquationOfMotion,
    FreeRunResult,
    free_run,
    held_out_blocks,
    simulate,
)
from hmid.models.sindy._library import TANH_NAME, Feature, FeatureLibrary, ForceMap
from hmid.models.sindy._model import SINDyForceModel
from hmid.models.sindy._settings import CrossValidation, Ensemble, SINDySettings
from hmid.models.sindy._sparse import ThresholdPath

__all__ = [
    "TANH_NAME",
    "BlockRun",
    "CrossValidation",
    "Ensemble",
    "EquationOfMotion",
    "Feature",
    "FeatureLibrary",
    "ForceMap",
    "FreeRunResult",
    "SINDyForceModel",
    "SINDySettings",
    "ThresholdPath",
    "free_run",
    "held_out_blocks",
    "simulate",
]
