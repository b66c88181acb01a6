"""Errors of the SLS sampler."""

from pathlib import Path

from hmid.errors import HmidError


class SamplerError(HmidError, RuntimeError):
    """The sampler cannot start or resume (non-finite start, foreign or mismatching chain file)."""


class SamplingInterrupted(HmidError, KeyboardInterrupt):
    """Ctrl-C during sampling: the steps done are saved (where a chain file is kept)."""

    def __init__(self, step: int, path: Path | None) -> None:
        where = (
            f"the chain is saved at step {step} in {path}; run the same command again to resume"
            if path is not None and step
            else "no chain file is kept, nothing was saved"
        )
        super().__init__(f"sampling interrupted (Ctrl-C): {where}")
        self.step, self.path = step, path
