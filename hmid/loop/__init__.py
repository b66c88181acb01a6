"""Close the loop: residual diagnostics, a library of candidate physical effects generated for the
rig, nested tests, selection by blocked cross-validation, rivals said out loud, and an honest
verdict when a residual pattern remains unexplained."""

from hmid.loop.candidates import CANDIDATES, Candidate, Setting, library
from hmid.loop.config import LoopSpec
from hmid.loop.decision import Decision
from hmid.loop.engine import LoopBase, run_loop
from hmid.loop.result import AddedEffect, LoopResult, Verdict

__all__ = [
    "CANDIDATES",
    "AddedEffect",
    "Candidate",
    "Decision",
    "LoopBase",
    "LoopResult",
    "LoopSpec",
    "Setting",
    "Verdict",
    "library",
    "run_loop",
]
