"""Stage functions and the runner that wires them (study definitions live in pipelines/)."""

from hmid.pipeline.runner import Pending, Runner, Stage, code_fingerprint

__all__ = ["Pending", "Runner", "Stage", "code_fingerprint"]
