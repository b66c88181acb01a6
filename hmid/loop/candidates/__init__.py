"""The candidate-effect library, generated for each rig; see :mod:`._base` for the contract."""

from hmid.loop.candidates._base import (
    CANDIDATES,
    Candidate,
    Setting,
    library,
    make_candidates,
)
from hmid.loop.candidates.drift import ELASTIC, STIFFNESS, PreloadDrift, StiffnessDrift, ZeroDrift
from hmid.loop.candidates.friction import Friction, level
from hmid.loop.candidates.timing import Delay, Lag

__all__ = [
    "CANDIDATES",
    "ELASTIC",
    "STIFFNESS",
    "Candidate",
    "Delay",
    "Friction",
    "Lag",
    "PreloadDrift",
    "Setting",
    "StiffnessDrift",
    "ZeroDrift",
    "level",
    "library",
    "make_candidates",
]
