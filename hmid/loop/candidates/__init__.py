"""The candidate-effect library; see :mod:`._base` for the contract."""

from hmid.loop.candidates._base import CANDIDATES, Candidate, Setting, make_candidates
from hmid.loop.candidates.friction import (
    Hysteresis,
    PressureFriction,
    StribeckFriction,
    ViscousFriction,
)
from hmid.loop.candidates.timing import ELASTIC, ForceZeroDrift, PressureLag, StiffnessDrift

__all__ = [
    "CANDIDATES",
    "ELASTIC",
    "Candidate",
    "ForceZeroDrift",
    "Hysteresis",
    "PressureFriction",
    "PressureLag",
    "Setting",
    "StiffnessDrift",
    "StribeckFriction",
    "ViscousFriction",
    "make_candidates",
]
