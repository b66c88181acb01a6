"""Model families as pipeline plug-ins: a typed config section that knows how to fit itself.

A family is a :class:`FamilySpec` subclass with a literal ``family`` name; it registers itself on
definition. The experiment config lists families under ``models:``; the pipeline fits each on the
same training rows and scores every fitted variant on the same held-out rows. Adding a family is a
new module here plus a config section — the runner does not change.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, ValidationError

from hmid._messages import format_validation_error
from hmid.errors import ConfigError

FAMILIES: dict[str, type[FamilySpec]] = {}


@dataclass(frozen=True)
class FitData:
    """Rows for fitting or scoring: regressors x [m], v [m/s], P [Pa], target F_m [N].

    ``sequences`` holds every dynamic log whole (columns t, x, v, P, F_m, train, validation:
    the last two mark the rows in each set), for families with memory that must run through
    the entire record; ``frame`` holds only this set's rows, in log order.
    """

    frame: pd.DataFrame  # columns log, t, x, v, P, F_m
    role: str  # "train" or "validation"
    sequences: Mapping[str, pd.DataFrame] = field(default_factory=dict)

    @property
    def X(self) -> pd.DataFrame:
        return self.frame[["x", "v", "P"]]

    @property
    def y(self) -> np.ndarray:
        return self.frame["F_m"].to_numpy()


@dataclass(frozen=True)
class Fitted:
    """One fitted model variant, ready to predict and to be reported."""

    name: str
    family: str
    model: Any  # has predict(X: DataFrame) -> ndarray
    kind: str  # "one-step": force from measured x, v, P
    fit_summary: Mapping[str, Any]
    coefficients: pd.DataFrame  # value, std. error, CI, unit per term
    equation: str
    notes: tuple[str, ...] = field(default_factory=tuple)

    def predict(self, data: FitData) -> np.ndarray:
        if hasattr(self.model, "predict_rows"):  # models with memory predict from sequences
            return np.asarray(self.model.predict_rows(data), dtype=float)
        return np.asarray(self.model.predict(data.X), dtype=float)

    def predict_interval(self, data: FitData) -> tuple[np.ndarray, np.ndarray] | None:
        """A predictive band (lower, upper) on ``data``'s rows, for families that have one."""
        if hasattr(self.model, "predict_interval_rows"):
            return self.model.predict_interval_rows(data)
        return None


@dataclass(frozen=True)
class FitContext:
    """What a family may need beyond its config: the experiment seed, a persistent folder (the
    stage cache) for resumable work such as an MCMC chain, the rig's constants (M, m1, g) and the
    identified friction (``friction.friction(v)`` in N), e.g. to build an equation of motion."""

    seed: int
    workdir: Path
    rig: Any = None  # hmid.io.log.RigConstants
    friction: Any = None  # hmid.friction.FrictionEstimate
    force: bool = False  # --force: start resumable work afresh


class FamilySpec(BaseModel):
    """Base of every family's config section."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
    family: str
    name_prefix: ClassVar[str] = ""

    @classmethod
    def __pydantic_init_subclass__(cls, **kwargs):
        super().__pydantic_init_subclass__(**kwargs)
        default = cls.model_fields["family"].default
        if isinstance(default, str) and default:
            FAMILIES[default] = cls

    def fit(self, train: FitData, context: FitContext) -> list[Fitted]:
        raise NotImplementedError


def make_family(spec: Mapping[str, Any] | FamilySpec, source: str = "models") -> FamilySpec:
    """A family config from ``{"family": name, ...}``; unknown families or keys are ConfigErrors."""
    if isinstance(spec, FamilySpec):
        return spec
    if not isinstance(spec, Mapping) or "family" not in spec:
        raise ConfigError(f"{source}: each entry needs a 'family', one of {sorted(FAMILIES)}")
    name = spec["family"]
    if name not in FAMILIES:
        raise ConfigError(f"{source}: family {name!r} is unknown; known: {sorted(FAMILIES)}")
    cls = FAMILIES[name]
    try:
        return cls.model_validate(dict(spec))
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, source, cls)) from None
