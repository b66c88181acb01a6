"""The force-balance language: a rig's physics declared as named terms, and their fit.

* :class:`RigSection` (``rig:`` in an experiment): channels with their sign convention, the
  explained quantity, the balance as a list of terms (:mod:`.kinds`), free-fall tests, motion;
* :class:`Term`: the one contract of every force contribution (declared terms, model families'
  terms, the loop's candidate effects), returning :class:`Columns` whose coefficients are
  physical parameters;
* :class:`Signals`: the rows they are evaluated on, smoothed alike on both sides;
* :class:`Structure` and :func:`profile`: terms at hyperparameter values, fitted by least
  squares with the hyperparameters profiled; :func:`parameters` with intervals (and
  :func:`estimated`, with the coefficients' covariance);
* :func:`sign_findings`: parameters that physics makes positive, fitted negative.
"""

from hmid.balance.checks import SignFinding, sign_findings
from hmid.balance.columns import Column, Columns, LeastSquares
from hmid.balance.inference import inference
from hmid.balance.kinds import TERM_KINDS, Grid, ModelSlot, TermSpec, make_term
from hmid.balance.rig import Explained, FreeFall, Motion, RigSection
from hmid.balance.signals import Signals, raw
from hmid.balance.structure import (
    Placed,
    Structure,
    StructureFit,
    descend,
    estimated,
    fit_structure,
    parameters,
    profile,
    refine,
    scan,
)
from hmid.balance.terms import Hyper, Term

__all__ = [
    "TERM_KINDS",
    "Column",
    "Columns",
    "Explained",
    "FreeFall",
    "Grid",
    "Hyper",
    "LeastSquares",
    "ModelSlot",
    "Motion",
    "Placed",
    "RigSection",
    "SignFinding",
    "Signals",
    "Structure",
    "StructureFit",
    "Term",
    "TermSpec",
    "descend",
    "estimated",
    "fit_structure",
    "inference",
    "make_term",
    "parameters",
    "profile",
    "raw",
    "refine",
    "scan",
    "sign_findings",
]
