"""SINDy's hyperparameters, declared and validated once (scikit-learn's ``_parameter_constraints``).

:class:`SINDySettings` is a frozen pydantic model: its fields say each hyperparameter's type and
range, its validators the rules that tie them together (``keep`` names library terms, ``v0``
is well below ``stick_speed``, ...). The family's config section (:class:`~hmid.families.sindy.
SINDySpec`) *is* these settings plus the family's own keys, so a config file is validated by the
same declaration; :class:`~hmid.models.sindy.SINDyForceModel` takes one settings object and
trusts it, and :class:`~hmid.models.sindy.FeatureLibrary` is built from its library fields.
A bad value is a :class:`pydantic.ValidationError` (a ``ValueError``) naming the key.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

Variable = Literal["x", "v", "P"]


def _pressure_linear() -> dict[Variable, int]:
    return {"P": 1}


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class CrossValidation(_Section):
    """Blocked K-fold CV over the training rows along a log-spaced threshold path."""

    folds: Annotated[int, Field(ge=2, le=20)] = 5
    points: Annotated[int, Field(ge=5, le=200)] = 30
    rule: Literal["one_se", "min"] = "one_se"


class Ensemble(_Section):
    """Blocked bootstrap: ``models`` STLSQ fits on resampled ``block_seconds`` blocks;
    ``confidence``: the level of the coefficient intervals, whichever method."""

    models: Annotated[int, Field(ge=10, le=2000)] = 50
    block_seconds: Annotated[float, Field(gt=0, le=600)] = 0.25
    confidence: Annotated[float, Field(gt=0.5, lt=1)] = 0.95


class SINDySettings(_Section):
    """What a SINDy force map is fitted with; see :mod:`hmid.families.sindy` for the keys."""

    variables: Annotated[tuple[Variable, ...], Field(min_length=1)] = ("x", "v", "P")
    degree: Annotated[int, Field(ge=1, le=4)] = 3
    max_degree: dict[Variable, Annotated[int, Field(ge=0, le=4)]] = Field(
        default_factory=_pressure_linear
    )
    friction_terms: bool = True
    v0: Annotated[float, Field(gt=0, le=1)] = 1e-3
    stick_speed: Annotated[float, Field(ge=0, le=1)] = 1e-2
    # An equation of motion needs the pressure drive and a restoring force. On quasi-static logs
    # F_m ~ m1 g + friction, and cross-validation alone keeps only {1, tanh(v/v0)} (a map with no
    # P and no x, whose free run drifts); ``keep`` spares these terms from the threshold.
    keep: tuple[str, ...] = ("x", "P")
    threshold: Literal["cv"] | Annotated[float, Field(ge=0)] = "cv"
    cv: CrossValidation = CrossValidation()
    support: Literal["cv", "threshold"] = "cv"
    ridge: Annotated[float, Field(ge=0)] = 0.0
    ensemble: Ensemble = Ensemble()
    # autocov: calibrated (benchmarks/bench_calibration_sindy.py); bootstrap: the old percentile
    # intervals, kept for comparison -- far wider wherever resamples pick other terms
    intervals: Literal["autocov", "bootstrap"] = "autocov"

    @field_validator("threshold", mode="before")
    @classmethod
    def _threshold(cls, value):
        number = isinstance(value, int | float) and not isinstance(value, bool)
        if value != "cv" and not (number and value >= 0):
            raise ValueError("must be 'cv' (cross-validated) or a number >= 0")
        return value

    @model_validator(mode="after")
    def _consistent(self):
        if len(set(self.variables)) != len(self.variables):
            raise ValueError(f"variables must not repeat, got {list(self.variables)}")
        extra = sorted(set(self.max_degree) - set(self.variables))
        if extra:
            raise ValueError(f"max_degree names {extra}, which are not among variables")
        from hmid.models.sindy._library import canonical_name

        candidates = self.library().candidate_names()
        unknown = [k for k in self.keep if canonical_name(k) not in candidates]
        if unknown:
            raise ValueError(
                f"keep names {unknown}, which are not library terms; terms: {', '.join(candidates)}"
            )
        if self.stick_speed and self.friction_terms and self.v0 > 10 * self.stick_speed:
            raise ValueError(
                f"v0={self.v0} m/s is over ten times stick_speed={self.stick_speed} m/s: "
                "tanh(v/v0) would be nearly linear on the fitted rows; lower v0"
            )
        return self

    def library(self):
        """A new, unfitted :class:`~hmid.models.sindy.FeatureLibrary` of these settings."""
        from hmid.models.sindy._library import FeatureLibrary

        return FeatureLibrary(
            self.variables, self.degree, dict(self.max_degree), self.friction_terms, self.v0
        )
