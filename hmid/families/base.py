"""Model families as pipeline plug-ins: a typed config section that fits a model of the balance.

A family is a :class:`FamilySpec` subclass with a literal ``family`` name; it registers itself on
definition. Its :meth:`~FamilySpec.fit` returns :class:`Fitted` models whose
:class:`FittedModel` predicts the balance's fitted part on any rows and states its terms
(:meth:`FittedModel.structure`), so that the loop can refit any fitted model with candidate
effects added. Families that fill the rig's model slot (polynomial, SINDy, SLS) model the
actuator's force; the ``balance`` family fits the declared terms themselves.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict

from hmid._registry import from_registry
from hmid.balance import RigSection, Signals, SignFinding, Structure
from hmid.intervals import IntervalNote
from hmid.models.base import FitStatistics

FAMILIES: dict[str, type[FamilySpec]] = {}


@dataclass(frozen=True)
class FitData:
    """The rows a family fits or is scored on: ``signals`` (whole segments, smoothed channels,
    ``target`` = the explained quantity less the known terms) and the ``role`` whose rows count
    (``"train"`` or ``"validation"``). The fit stage hands families a ``target`` that is NaN
    outside the training rows, so no held-out force can leak into a fit (but for one that reads
    it only through :attr:`y`: ``FamilySpec.reads_training_target_only``)."""

    signals: Signals
    rig: RigSection
    role: str = "train"

    @property
    def rows(self) -> np.ndarray:
        return self.signals.rows(self.role)

    @property
    def indices(self) -> np.ndarray:
        """This role's row numbers, increasing (found once per signals and role; 32-bit where
        they fit: a long log's training rows are held as long as their signals)."""

        def found() -> np.ndarray:
            rows = np.flatnonzero(self.rows)
            return rows.astype(np.int32) if len(self.rows) <= np.iinfo(np.int32).max else rows

        return self.signals.derived(("indices", self.role), found)

    @property
    def y(self) -> np.ndarray:
        """``target`` on this role's rows."""
        return self.signals.target[self.rows]

    def frame(self, columns: tuple[str, ...], keys: bool = True) -> pd.DataFrame:
        """This role's rows: log, t (unless ``keys`` is False) and ``columns`` (smoothed
        channels)."""
        return self.signals.role_frame(self.role, columns, keys)

    @property
    def slot_sign(self) -> int:
        slot = self.rig.slot
        return 1 if slot is None else slot.sign

    def as_role(self, role: str) -> FitData:
        return FitData(self.signals, self.rig, role)


def at_once(fn: Callable[..., Any], /, *args: Any) -> Callable[[], Any]:
    """``fn(*args)`` run at once; what :attr:`FitContext.beside` does by default."""
    value = fn(*args)
    return lambda: value


@dataclass(frozen=True)
class FitContext:
    """What a family may need beyond its config: the experiment seed, a persistent folder (the
    stage cache) for resumable work such as an MCMC chain, the identified free-fall friction
    (``friction.friction(v)`` in N, or None), and ``force`` (start resumable work afresh).

    ``beside(fn, *args)`` gives a callable that returns ``fn(*args)``: side work a fit needs only
    later (e.g. a sign check), which the runner may hand to a free worker meanwhile (``fn`` a
    module-level function and ``args`` picklable); by default it runs at once."""

    seed: int
    workdir: Path
    friction: Any = None  # hmid.friction.FrictionEstimate | None
    force: bool = False
    beside: Callable[..., Callable[[], Any]] = at_once


class FittedModel(ABC):
    """What every fitted model offers the pipeline (comparison, report, loop)."""

    @abstractmethod
    def predict(self, data: FitData) -> np.ndarray:
        """The fitted part of the balance (``target``'s prediction) on ``data``'s rows."""

    @abstractmethod
    def structure(self) -> Structure:
        """Its terms, with profiled parameters at their fitted values, as the loop refits them by
        least squares (together with the rig's fitted terms)."""

    def predict_interval(self, data: FitData) -> tuple[np.ndarray, np.ndarray] | None:
        """A predictive band (lower, upper) on ``data``'s rows, for models that have one."""
        return None

    def report_extras(self) -> Extras | None:
        """Extra text, tables and figures for the report (e.g. MCMC diagnostics); the figures
        are said (:class:`FigureSpec`), and the runner draws them."""
        return None


@dataclass(frozen=True)
class FigureSpec:
    """A figure for the report, said rather than drawn: ``draw(*args, path)`` writes a PNG at
    ``path``, which the runner chooses (``figures/<model>_<file>``), drawing it where it likes
    (in a worker: ``draw`` a module-level function, ``args`` picklable). ``dear``: among the
    first drawn (e.g. a corner plot of thousands of draws), so that a worker begins it while
    the run does the rest. ``takes_truth``: ``draw`` accepts ``truths=`` (parameter name ->
    known value), which the runner passes where the logs come with a simulator's truth."""

    draw: Callable[..., Any]
    args: tuple
    file: str
    caption: str
    dear: bool = False
    takes_truth: bool = False

    def __post_init__(self) -> None:
        if not self.file.endswith(".png") or Path(self.file).name != self.file:
            raise ValueError(f"FigureSpec.file must be a PNG file's name, got {self.file!r}")


@dataclass(frozen=True)
class FittedTerms(FittedModel):
    """A model that is balance terms at their fitted parameters (``structure``) times
    coefficients ``coef`` in column order: what a least-squares family fits, ready to use;
    ``covariance``: the coefficients' (column order), which the model file carries."""

    fitted: Structure
    names: tuple[str, ...]
    coef: np.ndarray
    covariance: np.ndarray | None = None

    def predict(self, data: FitData) -> np.ndarray:
        columns = self.fitted.columns(data.signals)
        if columns.names != self.names:
            raise ValueError(f"columns {columns.names} differ from the fitted {self.names}")
        return (columns.values @ self.coef)[data.rows]

    def structure(self) -> Structure:
        return self.fitted


@dataclass(frozen=True)
class Extras:
    text: str
    tables: list  # (frame, caption)
    figures: list[FigureSpec]


#: Goodness of fit on the training rows, as :func:`hmid.models.base.fit_statistics` computes it.
STATISTICS = ("r2", "r2_adj", "rmse", "aic", "bic")
#: metrics.json's keys of a fit, in order, as the families that fit a model's design write them
#: (a family may state its own :attr:`FitSummary.record`).
MODEL_RECORD = ("family", "name", "n_obs", "n_params", *STATISTICS, "condition_number",
                "condition_number_unscaled", "warnings")  # fmt: skip


@dataclass(frozen=True)
class FitExtras:
    """A family's own statistics of a fit (a subclass per family), after the common ones in
    metrics.json."""

    def to_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass(frozen=True)
class FitSummary(FitStatistics):
    """How one fitted model fits its training rows, comparable across families (metrics.json's
    ``fit`` entries; the comparison table reads its attributes): the estimator's
    :class:`~hmid.models.base.FitStatistics` and what a family adds, ``tau_int`` the residual's
    integrated autocorrelation time [samples] and ``n_eff`` = ``n_obs`` / ``tau_int`` where a
    family states them, ``extras`` the family's own. ``record`` names the fields metrics.json
    writes, in order (each family's keys as it first wrote them, so that metrics stay
    comparable across versions)."""

    tau_int: float | None = None
    n_eff: float | None = None
    extras: FitExtras | None = None
    record: tuple[str, ...] = field(default=MODEL_RECORD, repr=False)

    def __post_init__(self) -> None:
        known = {f.name for f in fields(self)} - {"extras", "record"}
        unknown = [k for k in self.record if k not in known]
        if unknown:
            raise ValueError(f"FitSummary.record: {unknown} are no fields; it has {sorted(known)}")

    @classmethod
    def of_fit(cls, family: str, name: str, y: np.ndarray, y_hat: np.ndarray, n_params: int,
               **more: Any) -> FitSummary:  # fmt: skip
        """From the training target ``y`` and its fit ``y_hat`` (R², RMSE, AIC, BIC by
        :func:`hmid.models.base.fit_statistics`), with ``more`` fields (``tau_int``, ...)."""
        from hmid.models.base import fit_statistics

        stats = fit_statistics(np.asarray(y), np.asarray(y_hat), n_params)
        return cls(family=family, name=name, n_obs=int(np.size(y)), n_params=n_params,
                   **stats, **more)  # fmt: skip

    @classmethod
    def of_model(cls, summary, **more) -> FitSummary:
        """From a model's ``summary_`` (:class:`hmid.models.base.FitSummary`), with ``more``
        fields (``extras``, ...)."""
        common = {f.name: getattr(summary, f.name) for f in fields(summary)}
        return cls(**common | more)

    def to_dict(self) -> dict[str, Any]:
        """metrics.json's entry: the ``record`` fields in order, then the family's extras."""
        out = {k: list(self.warnings) if k == "warnings" else getattr(self, k) for k in self.record}
        return out | (self.extras.to_dict() if self.extras is not None else {})


@dataclass(frozen=True)
class Fitted:
    """One fitted model variant, ready to predict and to be reported."""

    name: str
    family: str
    model: FittedModel
    kind: str  # "one-step": the explained quantity from measured signals at each sample
    fit_summary: FitSummary
    coefficients: pd.DataFrame  # value, std. error, CI, unit per parameter
    equation: str
    notes: tuple[str, ...] = field(default_factory=tuple)
    findings: tuple[SignFinding, ...] = field(default_factory=tuple)
    reused: str | None = None  # what the fit read back from stored work (e.g. an MCMC chain)
    interval: IntervalNote | None = None  # what the coefficients' intervals are

    def coefficient_table(self) -> pd.DataFrame:
        """The coefficients with the interval's method and calibration status as columns."""
        if self.interval is None:
            return self.coefficients
        columns = self.interval.columns()  # a family's own per-row column stays
        return self.coefficients.assign(
            **{k: v for k, v in columns.items() if k not in self.coefficients}
        )

    def predict(self, data: FitData) -> np.ndarray:
        return np.asarray(self.model.predict(data), dtype=float)

    def predict_interval(self, data: FitData) -> tuple[np.ndarray, np.ndarray] | None:
        return self.model.predict_interval(data)


class FamilySpec(BaseModel):
    """Base of every family's config section."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
    family: str
    fills_slot: ClassVar[bool] = True  # models the rig's actuator force (its {kind: model})
    #: what its fit imports (seconds for some): a worker that may fit it imports them ahead
    imports: ClassVar[tuple[str, ...]] = ()
    #: its fit reads the explained quantity only on the training rows (``FitData.y``), never the
    #: ``target`` column itself: the fit stage then hands it the signals as they are, not a copy
    #: with the held-out rows blanked (on a long log a whole column more, 0.25x its size)
    reads_training_target_only: ClassVar[bool] = False

    @classmethod
    def __pydantic_init_subclass__(cls, **kwargs):
        super().__pydantic_init_subclass__(**kwargs)
        default = cls.model_fields["family"].default
        if isinstance(default, str) and default:
            FAMILIES[default] = cls

    @classmethod
    def example(cls, rig: RigSection) -> FamilySpec:
        """A cheap, valid instance for ``rig`` (for contract tests and documentation)."""
        return cls.model_validate({})  # a subclass: its family has a default

    def model_names(self) -> list[str]:
        """Names of the models this entry fits (checked for clashes at load): by default one,
        named by the entry's ``name`` if it has one, else by its family."""
        return [str(getattr(self, "name", self.family))]

    def check(self, rig: RigSection) -> None:
        """ValueError (one line) if this family cannot model ``rig``'s balance."""
        if self.fills_slot and rig.slot is None:
            raise ValueError(
                f"family {self.family!r} models an actuator force, but rig.balance has no "
                "{kind: model} term for it to fill; add one, or fit the declared terms with "
                "{family: balance}"
            )
        if self.fills_slot and rig.fitted:
            names = [t.name for t in rig.fitted]
            raise ValueError(
                f"family {self.family!r} needs every other balance term known (a value, or "
                f"from: free_fall), but {names} are to be fitted; fit them with {{family: "
                "balance}, whose slot terms you declare"
            )

    def channels_needed(self, rig: RigSection, channels) -> None:
        missing = [c for c in channels if c not in rig.model_channels]
        if missing:
            raise ValueError(
                f"family {self.family!r} reads {missing}, which the rig does not give; its "
                f"channels are {list(rig.model_channels)}"
            )

    def fit(self, data: FitData, context: FitContext) -> list[Fitted]:
        raise NotImplementedError


def make_family(spec: Mapping[str, Any] | FamilySpec, source: str = "models") -> FamilySpec:
    """A family config from ``{"family": name, ...}``; unknown families or keys are ConfigErrors."""
    return from_registry(spec, FamilySpec, FAMILIES, tag="family", what="family", source=source)
