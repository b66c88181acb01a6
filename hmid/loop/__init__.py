"""Close the loop: residual diagnostics, a library of candidate physical effects generated for the
rig, nested tests, selection by blocked cross-validation, rivals said out loud, and an honest
verdict when structure remains unexplained."""

from hmid.loop.candidates import CANDIDATES, Candidate, Setting, library
from hmid.loop.config import LoopSpec
from hmid.loop.engine import LoopBase, run_loop
from hmid.loop.result import Effect, LoopResult

__all__ = [
    "CANDIDATES",
    "Candidate",
    "Effect",
    "LoopBase",
    "LoopResult",
    "LoopSpec",
    "Setting",
    "library",
    "run_loop",
]
