"""The polynomial regression family of thesis Ch. 4: the actuator force as a polynomial in the
rig's channels (x, v and P for the thesis's four variants), fitted by OLS to the slot's share
of the balance."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Annotated, ClassVar, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from hmid.balance import RigSection, Structure
from hmid.balance.checks import declared_positive
from hmid.balance.kinds import ChannelTerm, ConstantTerm, TermSpec, channel_product
from hmid.balance.signals import raw
from hmid.families.base import FamilySpec, FitContext, FitData, FitSummary, Fitted, FittedModel

if TYPE_CHECKING:
    from hmid.models.polynomial import PolynomialModel

Variant = Literal["quadratic_xv", "cubic_xv", "quadratic_xvP", "cubic_xvP"]
THESIS_VARIANTS: tuple[Variant, ...] = ("quadratic_xv", "cubic_xv", "quadratic_xvP", "cubic_xvP")
Variable = Annotated[str, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$")]


class CustomTerms(BaseModel):
    """Every monomial in ``variables`` (rig channels) up to total ``degree``, single variables
    capped by ``max_degree`` (e.g. ``{P: 1}``: pressure only linearly, as in the thesis)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]+$")]
    variables: tuple[Variable, ...] = ("x", "v", "P")
    degree: Annotated[int, Field(ge=1, le=6)] = 3
    max_degree: dict[Variable, Annotated[int, Field(ge=0, le=6)]] = {"P": 1}

    def terms(self):
        from hmid.models.terms import polynomial_terms

        caps = {v: c for v, c in self.max_degree.items() if v in self.variables}
        return polynomial_terms(self.variables, self.degree, caps)


class PolynomialSpec(FamilySpec):
    """``variants``: named term sets (the thesis's four by default), plus ``custom`` term sets;
    every one fitted by OLS on the same training rows, intervals by the ``errors`` method."""

    family: Literal["polynomial"] = "polynomial"
    reads_training_target_only: ClassVar[bool] = True  # its fit reads data.y alone
    variants: tuple[Variant, ...] = THESIS_VARIANTS
    custom: tuple[CustomTerms, ...] = ()
    confidence: Annotated[float, Field(gt=0.5, lt=1)] = 0.95
    scale: bool = True
    # Interval method: "autocov" (OLS with the residual's autocovariance, calibrated on the
    # pipeline's correlated residuals by benchmarks/bench_calibration_polynomial.py), "ols"
    # (independent errors) or "hac" (Newey-West); see hmid.models.polynomial.
    errors: Literal["autocov", "ols", "hac"] = "autocov"
    # terms whose coefficient physics makes positive (e.g. [P]: the pressure pushes); a fit with
    # the whole interval below zero is a sign finding, as for the balance's positive terms
    positive: tuple[str, ...] = ()

    def _term_sets(self):
        from hmid.models.terms import variant_terms

        sets = [(v, variant_terms(v)) for v in self.variants]
        return sets + [(c.name, c.terms()) for c in self.custom]

    def model_names(self) -> list[str]:
        return [f"poly:{name}" for name, _ in self._term_sets()]

    def check(self, rig: RigSection) -> None:
        super().check(rig)
        if not self.variants and not self.custom:
            raise ValueError("give at least one of variants or custom")
        for _, terms in self._term_sets():
            self.channels_needed(rig, sorted({v for t in terms for v in t.variables}))
        names = {t.name for _, terms in self._term_sets() for t in terms}
        unknown = [name for name in self.positive if name not in names]
        if unknown:
            raise ValueError(
                f"positive: {unknown} are no terms of these variants ({sorted(names)})"
            )

    def fit(self, data: FitData, context: FitContext) -> list[Fitted]:
        from hmid.models.polynomial import PolynomialModel

        units = dict(data.signals.units)
        fitted = []
        for variant, terms in self._term_sets():
            variables = tuple(sorted({v for t in terms for v in t.variables}))
            model = PolynomialModel(
                terms=variant if variant in THESIS_VARIANTS else terms,
                confidence=self.confidence,
                scale=self.scale,
                errors=self.errors,
                units=units,
                target_unit=units["target"],
            )
            y = data.y if data.slot_sign == 1 else data.slot_sign * data.y
            # the variables too are read from the signals by blocks: a long log's training
            # rows are not copied into a table beside them
            model.fit(None, y, monomials=smoothed_monomials(model.term_set, data, linear=True))
            del y
            table = model.coefficient_table()
            findings = declared_positive(f"poly:{variant}", table, self.positive, data.rig.position)
            fitted.append(
                Fitted(
                    name=f"poly:{variant}",
                    family=self.family,
                    model=FittedPolynomial(model, variables, data.slot_sign),
                    kind="one-step",
                    fit_summary=FitSummary.of_model(model.summary_),
                    coefficients=table,
                    equation=model.equation(),
                    notes=(
                        model.interval_method(),
                        *model.summary_.warnings,
                        *(f.message() for f in findings),
                    ),
                    interval=model.interval_note(),
                    findings=findings,
                )
            )
        return fitted


@dataclass(frozen=True)
class FittedPolynomial(FittedModel):
    """An OLS polynomial of the slot force (``sign`` is the slot's sign in the balance)."""

    model: PolynomialModel  # fitted
    variables: tuple[str, ...]
    sign: int

    def predict(self, data: FitData) -> np.ndarray:
        monomials = smoothed_monomials(self.model.term_set, data, linear=True)
        predicted = self.model.predict(None, monomials=monomials, n=len(data.indices))
        return predicted if self.sign == 1 else self.sign * predicted

    @property
    def covariance(self) -> np.ndarray:
        """The coefficients' covariance (the intervals' estimator), in :meth:`structure`'s
        order."""
        return self.model.cov_

    def structure(self) -> Structure:
        terms: list[TermSpec] = []
        for k, term in enumerate(self.model.term_set):
            name = f"C{k}"
            if term.powers:
                terms.append(ChannelTerm(name=name, channel=term.name, sign=self.sign))
            else:
                terms.append(ConstantTerm(name=name, sign=self.sign))
        return Structure.of(terms)


def smoothed_monomials(terms, data: FitData, linear: bool = False) -> Mapping[str, np.ndarray]:
    """Each term of degree two or more (one or more: ``linear``), on ``data``'s rows, as the
    balance evaluates it (:class:`~hmid.balance.kinds.ChannelTerm`): a product of logged
    channels on the unsmoothed signals and smoothed after, as the smoothed force that contains
    it (a single channel: its smoothed column). Computed when read, so that a long log's design
    is the only copy of them."""
    least = 1 if linear else 2
    names = [t.name for t in terms if sum(power for _, power in t.powers) >= least]
    return _Monomials(names, data)


@dataclass(frozen=True)
class _Monomials(Mapping):
    names: list[str]
    data: FitData

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self.names:
            raise KeyError(name)
        column = ChannelTerm(name="c", channel=name).columns(self.data.signals, None)
        return column.values[self.data.rows, 0]

    def block(self, name: str) -> Callable[[slice], np.ndarray]:
        """``name``'s column on any block of this data's rows (a slice of them), computed there
        alone: a long log's design is never held whole."""
        term, signals = ChannelTerm(name="c", channel=name), self.data.signals
        index = self.data.indices
        powers = term.powers()
        if term.of_smoothed(signals):  # a product of smoothed channels, row by row
            return partial(_product_at, {c: signals[c] for c in powers}, powers, index)
        raws = {c: signals[raw(c)] for c in powers}  # smoothed after the product
        return lambda rows: signals.smooth_at(partial(channel_product, raws, powers), index[rows])

    def __contains__(self, name: object) -> bool:  # Mapping's would compute the column
        return name in self.names

    def __iter__(self):
        return iter(self.names)

    def __len__(self) -> int:
        return len(self.names)


def _product_at(columns, powers: Mapping[str, int], index: np.ndarray, rows: slice) -> np.ndarray:
    return channel_product(columns, powers, index[rows])
