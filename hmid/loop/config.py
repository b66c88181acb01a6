"""The ``loop:`` section of an experiment: which fitted model to diagnose, the candidate library
and the acceptance rule."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, field_validator

from hmid.loop.candidates import Setting, library


class LoopSpec(BaseModel):
    """Close the loop: residual diagnostics, candidate effects, selection, held-out report.

    ``base`` names a model of the experiment's ``models`` (e.g. ``sls``, ``poly:cubic_xvP``,
    ``balance``): its fit is the "before", and its terms are refitted by least squares with each
    candidate added. ``candidates`` defaults to the whole library generated for the rig (see
    :func:`hmid.loop.candidates.library`); a list names some of it (``viscous.direction``,
    ``coulomb.x``, ``delay.P``...).

    Three roles of rows. On the **training** rows a candidate must be significant: its
    extra-sum-of-squares F-test (on the effective sample size) at ``alpha`` after Holm's
    correction over the round, a lower BIC, and identified (a physical sign of its sign-fixed
    parameters, a profiled value off any grid edge that means "no such effect"). **Selection**
    is blocked cross-validation on the same training rows (``folds`` folds of ``block_s`` time
    blocks): the candidate must lower the out-of-fold RMSE by more than ``margin`` (relative)
    even at the upper ``confidence`` bound of a block bootstrap (``draws`` resamples from the
    experiment's seed). The best selected candidate is added; any selected candidate of other
    physics that cross-validates not clearly worse is reported beside it as indistinguishable.
    The **held-out** rows of the comparison, which no decision sees, give the before/after error.
    Rounds repeat until none is added, ``max_effects`` are in, or no signal explains
    ``structure_threshold`` of the residual's variance.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    base: Annotated[str, Field(min_length=1)]
    candidates: tuple[str, ...] | None = None
    alpha: Annotated[float, Field(gt=0, lt=0.5)] = 0.01
    margin: Annotated[float, Field(ge=0, lt=1)] = 0.0
    folds: Annotated[int, Field(ge=2, le=20)] = 5
    block_s: Annotated[float, Field(gt=0)] = 1.0
    draws: Annotated[int, Field(ge=100, le=10000)] = 400
    max_effects: Annotated[int, Field(ge=0, le=10)] = 3
    # η² of a signal at which a residual pattern remains (the report calls it structure)
    structure_threshold: Annotated[float, Field(gt=0, lt=1)] = 0.05
    confidence: Annotated[float, Field(gt=0.5, lt=1)] = 0.95
    max_lag_s: Annotated[float, Field(gt=0)] = 0.5  # autocorrelation and cross-correlation
    stride_s: Annotated[float, Field(gt=0)] = 0.05  # decimation for Ljung-Box
    hint: bool = True  # sparse regression of a residual that keeps an unexplained pattern

    @field_validator("candidates")
    @classmethod
    def _unique(cls, names):
        if names is not None and len(set(names)) != len(names):
            raise ValueError("candidate effects are listed twice")
        return names

    def check(self, rig, model_names: list[str]) -> None:
        """ValueError (one line) if the base is no model or a listed candidate cannot apply."""
        if self.base not in model_names:
            raise ValueError(f"loop.base {self.base!r} is none of the models {model_names}")
        offered = library(Setting.of(rig))
        unknown = [n for n in self.candidates or () if n not in offered]
        if unknown:
            raise ValueError(
                f"loop.candidates: {unknown} are not effects this rig can show; it offers "
                f"{sorted(offered)}"
            )

    def candidate_names(self, setting: Setting) -> tuple[str, ...]:
        """The candidates to test: the listed ones, or the rig's whole library."""
        if self.candidates is not None:
            return self.candidates
        return tuple(library(setting))
