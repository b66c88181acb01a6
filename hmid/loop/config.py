"""The ``loop:`` section of an experiment: which fitted model to diagnose, the candidate library
and the acceptance rule."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, field_validator

from hmid.loop.candidates import CANDIDATES, Setting


class LoopSpec(BaseModel):
    """Close the loop: residual diagnostics, candidate effects, ranking and held-out confirmation.

    ``base`` names a model of the experiment's ``models`` (e.g. ``sls``, ``poly:cubic_xvP``,
    ``balance``): its fit is the "before", and its terms are refitted by least squares with each
    candidate added. ``candidates`` defaults to every library effect the rig can show (those
    reading a channel the rig lacks are left out).

    Rule: a candidate passes on training data when its extra-sum-of-squares F-test (on the
    effective sample size) is significant at ``alpha`` after Holm's correction over the round's
    candidates, it lowers BIC, and it is identified: its profiled parameter is not on a grid edge
    that means "no such effect" and its sign-constrained parameters (a friction coefficient) have
    their physical sign; passing candidates are tried in BIC order and the first whose
    held-out RMSE is lower by at least ``margin`` (relative) is added. Rounds repeat until none
    is added, ``max_effects`` are in, or no signal explains ``structure_threshold`` of the
    residual's variance.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    base: Annotated[str, Field(min_length=1)]
    candidates: tuple[str, ...] | None = None
    alpha: Annotated[float, Field(gt=0, lt=0.5)] = 0.01
    margin: Annotated[float, Field(ge=0, lt=1)] = 0.03
    max_effects: Annotated[int, Field(ge=0, le=10)] = 3
    structure_threshold: Annotated[float, Field(gt=0, lt=1)] = 0.05
    confidence: Annotated[float, Field(gt=0.5, lt=1)] = 0.95
    max_lag_s: Annotated[float, Field(gt=0)] = 0.5  # autocorrelation and cross-correlation
    stride_s: Annotated[float, Field(gt=0)] = 0.05  # decimation for Ljung-Box
    hint: bool = True  # sparse regression of a residual that keeps unexplained structure

    @field_validator("candidates")
    @classmethod
    def _known(cls, names):
        if names is None:
            return names
        unknown = [n for n in names if n not in CANDIDATES]
        if unknown:
            raise ValueError(f"unknown candidate effect(s) {unknown}; known: {sorted(CANDIDATES)}")
        if len(set(names)) != len(names):
            raise ValueError("candidate effects are listed twice")
        return names

    def check(self, rig, model_names: list[str]) -> None:
        """ValueError (one line) if the base is no model or a listed candidate cannot apply."""
        if self.base not in model_names:
            raise ValueError(f"loop.base {self.base!r} is none of the models {model_names}")
        setting = Setting.of(rig)
        for name in self.candidates or ():
            why = CANDIDATES[name].missing(setting)
            if why:
                raise ValueError(f"loop.candidates: {name!r} {why}; leave it out")

    def candidate_names(self, setting: Setting) -> tuple[str, ...]:
        """The candidates to test: the listed ones, or every one the rig supports."""
        if self.candidates is not None:
            return self.candidates
        return tuple(name for name, cls in CANDIDATES.items() if cls.missing(setting) is None)
