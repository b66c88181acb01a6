"""Close the loop: residual diagnostics, a library of candidate physical effects, nested tests
with held-out confirmation, and an honest verdict when structure remains unexplained."""

from hmid.loop.bases import PistonBase, SLSBase
from hmid.loop.candidates import CANDIDATES, Candidate
from hmid.loop.config import LoopSpec
from hmid.loop.data import LoopData, from_sequences
from hmid.loop.engine import run_loop
from hmid.loop.result import Effect, LoopResult

__all__ = [
    "CANDIDATES",
    "Candidate",
    "Effect",
    "LoopData",
    "LoopResult",
    "LoopSpec",
    "PistonBase",
    "SLSBase",
    "from_sequences",
    "run_loop",
]
