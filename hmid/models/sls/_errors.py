"""Errors of the SLS sampler."""

from hmid.errors import HmidError


class SamplerError(HmidError, RuntimeError):
    """The sampler cannot start or resume (non-finite start, foreign or mismatching chain file)."""
