"""The SINDy family: a sparse force map F_m(x, v, P) discovered with pysindy, with per-term
inclusion probabilities and intervals.

Two questions, two answers: a term's *inclusion probability* (the blocked-bootstrap ensemble)
says how sure the data are that it belongs in the model; the *interval* of a selected
coefficient (by default the post-selection OLS refit's, from the residual's autocovariance, as
the polynomial family's) says how well the data pin it down **given the selected support**.

Design (issue 4): the muscle force is a sparse regression ``F_m = Theta(x, v, P) xi`` on the
sliding training rows (target: the pipeline's reconstructed F_m), scored one-step like the
polynomial family; the equation of motion ``(M + m1) a = F_m - m1 g - friction(v)`` uses the
identified friction and runs free on each held-out block, driven by the measured pressure, as
every family's model does (the pipeline's ``freerun`` stage, :mod:`hmid.portable.freerun`).
SINDy-with-control on the state [x, v] was not chosen: its target would be the estimated
acceleration (the noisiest signal of the rig), and the stuck samples (a = 0 while the forces do not
balance the sign(v) friction) would sit in the target itself. See
:mod:`hmid.models.sindy` for the regression, threshold rule and ensemble.

Config (``models: [{family: sindy, ...}]``)::

    name: stlsq                 # the fitted model is called "sindy:<name>"
    variables: [x, v, P]        # polynomial library variables
    degree: 3                   # total degree, 1-4
    max_degree: {P: 1}          # caps per variable (pressure linear, as in the thesis)
    friction_terms: true        # add tanh(v / v0) to the library
    v0: 0.001                   # m/s, smooth-sign speed of the library's tanh(v / v0)
    stick_speed: 0.01           # m/s, rows with |v| below are left out (stick, transitions)
    keep: [x, P]                # terms never thresholded (physics prior; [] lets CV decide)
    threshold: cv               # or a number: RMS contribution / std(F_m) below which terms go
    cv: {folds: 5, points: 30, rule: one_se}
    support: cv                 # with threshold: cv, the support is cross-validated
                                #   (cv.rule) among those the threshold path and the bootstrap
                                #   keep; or threshold (STLSQ's at the threshold, as a fixed
                                #   threshold always is; see hmid.models.sindy._select)
    ridge: 0.0                  # STLSQ ridge, per training row
    ensemble: {models: 50, block_seconds: 0.25, confidence: 0.95}  # confidence: the level
                                #   of the coefficient intervals, whichever method
    intervals: autocov          # or bootstrap (the ensemble's percentile intervals; see
                                #   hmid.models.sindy._intervals)
    seed_offset: 0              # ensemble seed = experiment seed + seed_offset
    velocity: {kind: pipeline}  # or {kind: smoothed_finite_difference, window_s: 0.05,
                                #     polyorder: 3} (pysindy, on each whole log)
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Annotated, ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from hmid.balance import RigSection
from hmid.families.base import FamilySpec, FitContext, FitData, FitExtras, FitSummary, Fitted
from hmid.models.sindy._settings import SINDySettings


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class PipelineVelocity(_Section):
    """The velocity the pipeline's denoise stage estimated (its settings are in ``denoise``)."""

    kind: Literal["pipeline"] = "pipeline"

    def build(self):
        return None

    def label(self) -> str:
        return "the pipeline's velocity estimate (the experiment's denoise.derivative)"


class SmoothedFiniteDifferenceVelocity(_Section):
    """pysindy's SmoothedFiniteDifference (Savitzky-Golay, then centred differences) on each
    whole log's smoothed x."""

    kind: Literal["smoothed_finite_difference"] = "smoothed_finite_difference"
    window_s: Annotated[float, Field(gt=0, le=10)] = 0.05
    polyorder: Annotated[int, Field(ge=1, le=7)] = 3

    def build(self):
        from hmid.models.sindy._derivative import SmoothedVelocity

        return SmoothedVelocity(self.window_s, self.polyorder)

    def label(self) -> str:
        return (
            f"pysindy SmoothedFiniteDifference on each whole log (Savitzky-Golay window "
            f"{self.window_s:g} s, order {self.polyorder})"
        )


class SINDySpec(SINDySettings, FamilySpec):
    """A SINDy force map; see the module docstring for the keys.

    The fit's hyperparameters are :class:`~hmid.models.sindy.SINDySettings` (declared and
    validated there, once); the family adds its name, the seed offset and the velocity."""

    family: Literal["sindy"] = "sindy"
    imports: ClassVar[tuple[str, ...]] = ("hmid.models.sindy", "hmid.models.sindy._stlsq")
    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]+$")] = "stlsq"
    seed_offset: Annotated[int, Field(ge=0)] = 0
    velocity: Annotated[
        PipelineVelocity | SmoothedFiniteDifferenceVelocity, Field(discriminator="kind")
    ] = PipelineVelocity()

    # terms whose coefficient physics makes positive (e.g. [P]); a whole interval below zero is
    # a sign finding, as for the balance's positive terms
    positive: tuple[str, ...] = ()

    @model_validator(mode="after")
    def _positive_terms(self) -> SINDySpec:
        from hmid.models.sindy._library import canonical_name

        candidates = self.library().candidate_names()
        unknown = [k for k in self.positive if canonical_name(k) not in candidates]
        if unknown:
            raise ValueError(
                f"positive names {unknown}, which are not library terms; terms: "
                f"{', '.join(candidates)}"
            )
        return self

    def settings(self) -> SINDySettings:
        """The fit's hyperparameters alone (already validated: not validated again)."""
        fields = {k: getattr(self, k) for k in SINDySettings.model_fields}
        return SINDySettings.model_construct(**fields)

    def model_names(self) -> list[str]:
        return [f"sindy:{self.name}"]

    def check(self, rig: RigSection) -> None:
        super().check(rig)
        self.channels_needed(rig, sorted({*self.variables, "v", "x"}))
        if "P" not in rig.model_channels:
            raise ValueError("family 'sindy' is driven by the pressure P, which the rig lacks")

    def fit(self, data: FitData, context: FitContext) -> list[Fitted]:
        from hmid.balance.checks import declared_positive
        from hmid.families._sindy_result import (
            VARIABLES,
            SINDyResult,
            interval_note,
            sequences,
            with_velocity,
        )
        from hmid.models.sindy import SINDyForceModel
        from hmid.models.sindy._library import canonical_name

        velocity = self.velocity.build()
        whole = sequences(data.signals)
        frame = data.frame(VARIABLES)
        if velocity is not None:
            frame = with_velocity(frame, whole, velocity)
        model = SINDyForceModel(
            self.settings(), seed=context.seed + self.seed_offset, name=self.name
        )
        model.fit(frame, data.slot_sign * data.y)
        notes = [*model.summary_.warnings, interval_note(model)]
        extras = SINDyExtras(
            threshold=model.threshold_,
            selected_terms=tuple(model.selected),
            stuck_rows_left_out=model.n_stuck_,
            ensemble_models=model.n_models,
            intervals=model.intervals,
            residual_tau_int_rows=model.tau_int_,
        )
        summary = FitSummary.of_model(model.summary_, extras=extras)
        result = SINDyResult(model, velocity, self.velocity.label(), data.slot_sign)
        table = model.coefficient_table()
        positive = [canonical_name(k) for k in self.positive]
        findings = declared_positive(f"sindy:{self.name}", table, positive, data.rig.position)
        return [
            Fitted(
                name=f"sindy:{self.name}",
                family=self.family,
                model=result,
                kind="one-step",
                fit_summary=summary,
                coefficients=table,
                equation=model.equation(),
                notes=(*notes, *(f.message() for f in findings)),
                interval=model.interval_note(),
                findings=findings,
            )
        ]


@dataclass(frozen=True)
class SINDyExtras(FitExtras):
    """SINDy's own statistics of a fit: the threshold chosen, the terms selected, the stuck rows
    left out, the ensemble's size, the intervals' method and the residual's τ_int [rows]."""

    threshold: float
    selected_terms: tuple[str, ...]
    stuck_rows_left_out: int
    ensemble_models: int
    intervals: str
    residual_tau_int_rows: float

    def to_dict(self) -> dict:
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        out["selected_terms"] = list(self.selected_terms)
        return out
