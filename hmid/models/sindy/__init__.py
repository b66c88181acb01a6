"""SINDy: a sparse force map F_m = Theta(x, v, P) xi discovered with pysindy.

Why a force map and not SINDy-with-control on [x, v]: the force map is scored one-step exactly
like the polynomial family, its target (the reconstructed F_m) is far less noisy than the
estimated acceleration, and stuck samples can be dropped by |v| without touching the target's
meaning; the equation of motion follows from it, the rig's balance and the identified friction,
and runs free like every family's (:mod:`hmid.portable.freerun`).

* :class:`SINDyForceModel` -- the force map by pysindy's STLSQ on a physics library (polynomials
  in x, v, P with per-variable caps, plus tanh(v/v0) for friction; no duplicate columns), rows
  with |v| < stick_speed left out, threshold by blocked cross-validation on the training rows
  (one-standard-error rule), a blocked-bootstrap ensemble (seeded ``numpy.random.Generator``,
  NumPy's global state untouched) for each term's inclusion probability, the support chosen by
  the same cross-validation among those the path and the ensemble keep, and an interval for
  each selected coefficient: the post-selection OLS refit's from the residual's autocovariance
  (conditional on the selected support; or the ensemble's percentile interval on request). All
  least-squares problems run on QR-compressed blocks, so 30k rows fit in about a second.

The pipeline's family (:mod:`hmid.families.sindy`) wraps these for the report and the loop.
"""

from hmid.models.sindy._library import TANH_NAME, Feature, FeatureLibrary
from hmid.models.sindy._model import SINDyForceModel
from hmid.models.sindy._settings import CrossValidation, Ensemble, SINDySettings
from hmid.models.sindy._sparse import ThresholdPath

__all__ = [
    "TANH_NAME",
    "CrossValidation",
    "Ensemble",
    "Feature",
    "FeatureLibrary",
    "SINDyForceModel",
    "SINDySettings",
    "ThresholdPath",
]
