"""The candidate-effect library; see :mod:`._base` for the contract."""

from hmid.loop.candidates._base import CANDIDATES, Candidate, make_candidates
from hmid.loop.candidates.friction import (
    Hysteresis,
    PressureFriction,
    StribeckFriction,
    ViscousFriction,
)
from hmid.loop.candidates.timing import ForceZeroDrift, PressureLag, StiffnessDrift

__all__ = [
    "CANDIDATES",
    "Candidate",
    "ForceZeroDrift",
    "Hysteresis",
    "PressureFriction",
    "PressureLag",
    "StiffnessDrift",
    "StribeckFriction",
    "ViscousFriction",
    "make_candidates",
]
