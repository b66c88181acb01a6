"""The ``loop:`` section of an experiment: base model, candidate library and acceptance rule."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, field_validator

from hmid.loop.bases import BaseSpec, SLSBase
from hmid.loop.candidates import CANDIDATES

DEFAULT_CANDIDATES = (
    "viscous",
    "stribeck",
    "pressure_friction",
    "hysteresis",
    "pressure_lag",
    "stiffness_drift",
    "force_zero_drift",
)


class LoopSpec(BaseModel):
    """Close the loop: residual diagnostics, candidate effects, ranking and held-out confirmation.

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

    base: BaseSpec = SLSBase()
    candidates: tuple[str, ...] = DEFAULT_CANDIDATES
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
        unknown = [n for n in names if n not in CANDIDATES]
        if unknown:
            raise ValueError(f"unknown candidate effect(s) {unknown}; known: {sorted(CANDIDATES)}")
        if len(set(names)) != len(names):
            raise ValueError("candidate effects are listed twice")
        return names
