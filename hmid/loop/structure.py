"""A model under test, the base at a hyperparameter value plus added effects, and its fit.

Fits are least squares on the training rows; the base's hyperparameter (the SLS relaxation
time) is profiled on its grid, by a full scan or by a walk from the current value.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
import pandas as pd

from hmid.loop.bases import Base
from hmid.loop.candidates import Candidate
from hmid.loop.data import LoopData
from hmid.loop.design import Columns, LeastSquares
from hmid.loop.statistics import inference
from hmid.metrics import Scores, score


@dataclass(frozen=True)
class Term:
    candidate: Candidate
    value: float | None


@dataclass(frozen=True)
class Structure:
    """Base at a hyperparameter value plus added effects; ``elastic`` from the last base fit."""

    base: Base
    base_value: float | None
    effects: tuple[Term, ...] = ()
    elastic: np.ndarray | None = None

    def plus(self, term: Term) -> Structure:
        return replace(self, effects=(*self.effects, term))

    def data_for(self, data: LoopData) -> LoopData:
        for term in self.effects:
            data = term.candidate.transform(data, term.value)
        return data

    def columns(self, data: LoopData, cache: dict | None = None) -> Columns:
        seen = self.data_for(data)
        columns = self.base.columns(seen, self.base_value, cache)
        elastic = self.elastic if self.elastic is not None else np.zeros(len(data))
        for term in self.effects:
            extra = term.candidate.columns(seen, term.value, elastic)
            # a correction two effects share, or one the base has (the Coulomb level), enters once
            keep = [
                i
                for i, name in enumerate(extra.names)
                if name not in columns.names
                and not any(
                    np.array_equal(extra.values[:, i], columns.values[:, j])
                    for j in range(columns.width)
                )
            ]
            columns = columns + Columns(
                tuple(extra.names[i] for i in keep),
                tuple(extra.units[i] for i in keep),
                extra.values[:, keep],
            )
        return columns


@dataclass(frozen=True)
class StructureFit:
    structure: Structure
    columns: Columns
    fit: LeastSquares
    y: np.ndarray = field(repr=False)

    @cached_property
    def residual(self) -> np.ndarray:
        """On every row (fitted on the training rows only)."""
        return self.y - self.fit.predict(self.columns)

    @property
    def params(self) -> dict[str, float]:
        return dict(zip(self.columns.names, self.fit.coef, strict=True))

    def held_out(self, data: LoopData) -> Scores:
        rows = data.validation
        return score(data["y"][rows], data["y"][rows] - self.residual[rows], "one-step")


def fit_structure(structure: Structure, data: LoopData, cache: dict) -> StructureFit:
    columns = structure.columns(data, cache)
    fit = LeastSquares.fit(columns, data["y"], data.train)
    return StructureFit(structure, columns, fit, data["y"])


def descend(structure: Structure, data: LoopData, cache: dict) -> StructureFit:
    """The base hyperparameter near the current one: walk the grid while the SSE falls."""
    grid = structure.base.grid
    best = fit_structure(structure, data, cache)
    if len(grid) == 1:
        return best
    start = int(np.argmin(np.abs(np.log(np.asarray(grid) / structure.base_value))))
    if grid[start] != structure.base_value:
        structure = replace(structure, base_value=grid[start])
        best = fit_structure(structure, data, cache)
    for step in (-1, 1):
        j = start + step
        while 0 <= j < len(grid):
            trial = fit_structure(replace(structure, base_value=grid[j]), data, cache)
            if trial.fit.sse >= best.fit.sse:
                break
            best, j = trial, j + step
        if best.structure.base_value != structure.base_value:
            break
    return best


def refine(best: StructureFit, data: LoopData, cache: dict) -> StructureFit:
    """The base's hyperparameter between the grid neighbours of the grid optimum (bounded scalar
    search in its logarithm): estimates that trade off against it (a viscous b against the
    SLS relaxation time) otherwise inherit the grid's resolution as a bias."""
    from scipy.optimize import minimize_scalar

    grid = best.structure.base.grid
    if len(grid) < 2:
        return best
    i = int(np.argmin(np.abs(np.log(np.asarray(grid) / best.structure.base_value))))
    low, high = np.log(grid[max(i - 1, 0)]), np.log(grid[min(i + 1, len(grid) - 1)])

    def sse(log_value: float) -> float:
        s = replace(best.structure, base_value=float(np.exp(log_value)))
        return fit_structure(s, data, cache).fit.sse

    found = minimize_scalar(sse, bounds=(low, high), method="bounded", options={"xatol": 1e-3})
    trial = fit_structure(replace(best.structure, base_value=float(np.exp(found.x))), data, cache)
    return trial if trial.fit.sse < best.fit.sse else best


def refit(structure: Structure, data: LoopData, cache: dict, *, full: bool = False):
    """Re-profile the base's hyperparameter with the effects in (the whole grid, or a walk from
    the current value, then a continuous refinement), then update the elastic force the drift
    terms use."""
    if full:
        grid = structure.base.grid
        sse = [fit_structure(replace(structure, base_value=v), data, cache).fit.sse for v in grid]
        structure = replace(structure, base_value=grid[int(np.argmin(sse))])
    best = refine(descend(structure, data, cache), data, cache)
    s = best.structure
    elastic = s.base.elastic(s.data_for(data), s.base_value, best.params, cache)
    return fit_structure(replace(s, elastic=elastic), data, cache)


def _effect_sensitivity(fitted: StructureFit, index: int, data: LoopData, cache: dict):
    """d(prediction)/d(ln value) of effect ``index``'s profiled parameter, coefficients held
    fixed (central difference; None if it has none, or sits at 0 where ln is undefined)."""
    s, term = fitted.structure, fitted.structure.effects[index]
    if term.candidate.hyper is None or not term.value:
        return None
    h, predictions = 1e-3, []
    for factor in (np.exp(h), np.exp(-h)):
        effects = list(s.effects)
        effects[index] = Term(term.candidate, term.value * factor)
        columns = replace(s, effects=tuple(effects)).columns(data, cache)
        if columns.names != fitted.columns.names:
            return None
        predictions.append(columns.values @ fitted.fit.coef)
    return (predictions[0] - predictions[1]) / (2 * h)


def parameters(
    fitted: StructureFit, data: LoopData, tau_int: float, confidence: float, cache: dict
) -> pd.DataFrame:
    """The fitted parameters with intervals (standard errors inflated by tau_int). Profiled
    parameters (the base's, and each added effect's) enter the covariance through their
    sensitivity columns (Gauss-Newton), so the linear parameters that trade off against them get
    honest intervals. The base's gets a row of its own; an effect's keeps its profile-likelihood
    interval (added with the effect)."""
    s = fitted.structure
    base_extra = s.base.sensitivity(s.data_for(data), s.base_value, fitted.params, cache)
    effect_extra = [_effect_sensitivity(fitted, i, data, cache) for i in range(len(s.effects))]
    extras = [e for e in [base_extra, *effect_extra] if e is not None]
    columns = fitted.columns
    if extras:
        names = tuple(f"sensitivity {i}" for i in range(len(extras)))
        columns = columns + Columns(names, ("1",) * len(extras), np.column_stack(extras))
    table = inference(columns, data["y"], data.train, tau_int, confidence)
    if not extras:
        return table
    # a sensitivity column's coefficient is a Gauss-Newton step (~0 at the optimum): keep the
    # fitted values, take the half-widths from the joint covariance
    width = fitted.columns.width
    half = (table["upper"] - table["lower"]).to_numpy() / 2
    value = table["value"].to_numpy().copy()
    value[:width] = fitted.fit.coef
    table["value"], table["lower"], table["upper"] = value, value - half, value + half
    if base_extra is None:
        return table.iloc[:width].reset_index(drop=True)
    row = table.index[width]
    name, unit = s.base.hyper
    log_value = np.log(s.base_value)
    table.loc[row, ["parameter", "unit"]] = [name, unit]
    table.loc[row, "std. error"] *= s.base_value  # delta method, for reference
    table.loc[row, ["value", "lower", "upper"]] = np.exp(
        [log_value, log_value - half[width], log_value + half[width]]
    )
    return table.iloc[: width + 1].reset_index(drop=True)
