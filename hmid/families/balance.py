"""The ``balance`` family: least squares on the rig's declared terms (and, where the rig has a
model slot, on the slot terms declared here), every profiled parameter profiled over its grid.

Intervals count the residual's effective sample size (see :mod:`hmid.stats`) and
include the profiled parameters (Gauss-Newton); every parameter that physics makes positive is
checked (:func:`hmid.balance.sign_findings`).

Config (``models: [{family: balance, ...}]``)::

    name: balance            # the fitted model's name
    slot: []                 # the actuator force's terms, if the rig has a {kind: model} slot
    confidence: 0.95
"""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

import pandas as pd
from pydantic import Field, SerializeAsAny, field_validator

from hmid.balance import (
    RigSection,
    Structure,
    TermSpec,
    estimated,
    make_term,
    profile,
    sign_findings,
)
from hmid.balance.inference import CALIBRATED_TAU
from hmid.balance.kinds import ModelSlot
from hmid.families.base import (
    STATISTICS,
    FamilySpec,
    FitContext,
    FitData,
    FitSummary,
    Fitted,
    FittedTerms,
)
from hmid.intervals import IntervalNote
from hmid.stats import residual_tau_int


class BalanceSpec(FamilySpec):
    """Least squares on the declared balance; see the module docstring."""

    family: Literal["balance"] = "balance"
    fills_slot: ClassVar[bool] = False
    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9_.:-]+$")] = "balance"
    slot: tuple[SerializeAsAny[TermSpec], ...] = ()
    confidence: Annotated[float, Field(gt=0.5, lt=1)] = 0.95

    @field_validator("slot", mode="before")
    @classmethod
    def _terms(cls, specs):
        return tuple(make_term(spec, f"slot.{i}") for i, spec in enumerate(specs or ()))

    @classmethod
    def example(cls, rig: RigSection) -> BalanceSpec:
        """The declared terms alone; with a slot, the standard linear solid (a linear spring,
        one arm) as its terms."""
        if rig.slot is None:
            return cls()
        if rig.position is None:
            raise ValueError("a model slot's standard linear solid needs the rig's position")
        from hmid.models.sls.terms import SLSForce

        return cls(slot=SLSForce("linear", 1).terms(position=rig.position, pressure="P"))

    def model_names(self) -> list[str]:
        return [self.name]

    def check(self, rig: RigSection) -> None:
        if rig.slot is not None and not self.slot:
            raise ValueError(
                f"the rig's balance has a model slot ({rig.slot.name}): declare its terms under "
                "slot (e.g. the SLS's springs and arm), or fit it with a slot family"
            )
        if rig.slot is None and self.slot:
            raise ValueError("slot terms given, but rig.balance has no {kind: model} slot")
        names = [t.name for t in (*self.slot, *rig.balance)]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(f"slot terms share names with the rig's terms: {repeated}")
        for term in self.slot:
            if isinstance(term, ModelSlot) or term.known:
                raise ValueError(f"slot term {term.name!r} must be a fitted term, not {term.kind}")
            self.channels_needed(rig, term.reads)

    def terms(self, rig: RigSection) -> tuple[TermSpec, ...]:
        sign = rig.slot.sign if rig.slot is not None else 1
        slot = tuple(t.model_copy(update={"sign": t.sign * sign}) for t in self.slot)
        return (*slot, *rig.fitted)

    def fit(self, data: FitData, context: FitContext) -> list[Fitted]:
        from hmid.models.base import fit_statistics

        structure = Structure.of(self.terms(data.rig))
        signals = data.signals.trim(*structure.margins)
        fitted = profile(structure, signals)
        tau_int = residual_tau_int(fitted.residual, signals)
        table, covariance = estimated(fitted, signals, self.confidence)
        reads = dict(zip(fitted.columns.names, fitted.columns.reads, strict=True))
        findings = sign_findings(self.name, table, reads, data.rig.position)
        rows = signals.train
        n_params = fitted.columns.width + len(fitted.structure.hypers)
        stats = fit_statistics(signals.target[rows], fitted.prediction[rows], n_params)
        summary = FitSummary(
            family=self.family, name=self.name, n_obs=int(rows.sum()), n_params=n_params,
            tau_int=tau_int, n_eff=rows.sum() / tau_int, condition_number=None, **stats,
            record=("family", "name", "n_obs", "n_params", "tau_int", "n_eff",
                    "condition_number", *STATISTICS),
        )  # fmt: skip
        level = f"{100 * self.confidence:g}%"
        coefficients = table.rename(
            columns={"lower": f"ci_low ({level})", "upper": f"ci_high ({level})"}
        ).drop(columns=["positive"])
        model = FittedTerms(fitted.structure, fitted.columns.names, fitted.fit.coef.copy(),
                            covariance)  # fmt: skip
        notes = [
            f"least squares on {int(rows.sum())} rows; {100 * self.confidence:g} % intervals "
            "from the residual's autocovariance, the profiled parameters' included; calibrated "
            f"for residual correlation times up to {CALIBRATED_TAU:g} samples "
            "(benchmarks/bench_calibration_balance.py), this fit "
            f"{tau_int:.1f}: {'within' if tau_int <= CALIBRATED_TAU else 'BEYOND'} that range",
            *(f.message() for f in findings),
        ]
        return [
            Fitted(
                name=self.name,
                family=self.family,
                model=model,
                kind="one-step",
                fit_summary=summary,
                coefficients=coefficients,
                equation=_equation(data, fitted.structure, table),
                notes=tuple(notes),
                findings=findings,
                interval=IntervalNote(
                    self.confidence,
                    "OLS + autocovariance sandwich (profiled: Gauss-Newton)",
                    tau_int,
                    CALIBRATED_TAU,
                    "benchmarks/bench_calibration_balance.py",
                ),
            )
        ]


def _equation(data: FitData, structure: Structure, table: pd.DataFrame) -> str:
    values = table.set_index("parameter")
    parts = []
    for placed in structure.terms:
        term = placed.term
        assert isinstance(term, TermSpec)  # the family's own terms, not the loop's candidates
        row = values.loc[term.name] if term.name in values.index else None
        if row is None:
            continue
        coef = f"{row['value']:.4g} {row['unit']}"
        regressor = term.regressor()
        text = coef if regressor == "1" else f"{coef}·{regressor}"
        parts.append(("- " if term.sign < 0 else "+ ") + text)
        if placed.term.hyper is not None:
            parts[-1] += (
                f" ({placed.term.hyper.name} = {placed.value:.4g} {placed.term.hyper.unit})"
            )
    body = " ".join(parts).removeprefix("+ ")
    known = [t.name for t in data.rig.known]
    tail = f"  [known: {', '.join(known)}]" if known else ""
    return f"{data.rig.explained.name} = {body}{tail}"
