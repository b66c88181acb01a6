"""A balance under test: terms at their hyperparameter values, fitted by least squares.

Fits use the training rows of ``target``; hyperparameters (a relaxation time, a delay) are
profiled: every grid value of each is tried with the others fixed (coordinate sweeps until none
moves), then refined continuously between its grid neighbours. :func:`parameters` gives every
parameter with an interval, the profiled ones included (Gauss-Newton), on the residual's
effective sample size.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property, partial

import numpy as np
import pandas as pd

from hmid.balance.columns import Columns, LeastSquares, Plan, plan
from hmid.balance.inference import sandwich
from hmid.balance.signals import Signals
from hmid.balance.terms import Hyper, Term
from hmid.metrics import Scores, score


@dataclass(frozen=True)
class Placed:
    """A term at a value of its hyperparameter (None if it has none)."""

    term: Term
    value: float | None = None


@dataclass(frozen=True)
class Structure:
    """Terms at their hyperparameter values (each term's columns enter once)."""

    terms: tuple[Placed, ...]

    @classmethod
    def of(cls, terms, values: dict[int, float] | None = None) -> Structure:
        """Terms each at ``values[i]``, or at the first value of its grid."""
        values = values or {}
        placed = []
        for i, term in enumerate(terms):
            hyper = term.hyper
            placed.append(Placed(term, values.get(i, hyper.grid[0] if hyper else None)))
        return cls(tuple(placed))

    def plus(self, term: Term, value: float | None = None) -> Structure:
        return replace(self, terms=(*self.terms, Placed(term, value)))

    def at(self, index: int, value: float | None) -> Structure:
        terms = list(self.terms)
        terms[index] = Placed(terms[index].term, value)
        return replace(self, terms=tuple(terms))

    @property
    def hypers(self) -> list[int]:
        """Indices of the terms that have a hyperparameter (profiled)."""
        return [i for i, p in enumerate(self.terms) if p.term.hyper is not None]

    def profiled(self, index: int) -> tuple[Hyper, float]:
        """Term ``index``'s hyperparameter and its value (``index`` one of :attr:`hypers`)."""
        placed = self.terms[index]
        hyper = placed.term.hyper
        if hyper is None or placed.value is None:
            raise ValueError(f"term {index} ({placed.term.name}) has no hyperparameter value")
        return hyper, placed.value

    @property
    def margins(self) -> tuple[float, float]:
        starts = [p.term.margins[0] for p in self.terms]
        ends = [p.term.margins[1] for p in self.terms]
        return (max(starts, default=0.0), max(ends, default=0.0))

    def seen(self, signals: Signals) -> Signals:
        """The signals as the terms see them (sensor effects applied, cached per value)."""
        for placed in self.terms:
            key = ("transform", placed.term, placed.value)
            signals = signals.derived(key, partial(placed.term.transform, signals, placed.value))
        return signals

    def columns(self, signals: Signals, rows: np.ndarray | None = None) -> Columns:
        """The design on every row of ``signals`` (or on ``rows`` only)."""
        return self.plan(signals).assemble(rows)

    def plan(self, signals: Signals) -> Plan:
        """The design's parts, not yet assembled (:class:`~hmid.balance.columns.Plan`)."""
        seen = self.seen(signals)
        parts = []
        for placed in self.terms:
            key, columns = _term_columns(signals.cache, seen, placed)
            parts.append((key, columns, placed.term.refines))
        # whether a column is in another's span shows on any few thousand rows
        rows = np.flatnonzero(signals.usable)
        rows = rows[:: max(1, len(rows) // 4000)]
        return plan(len(signals), parts, rows, signals.cache)


def _term_columns(store: dict, seen: Signals, placed: Placed) -> tuple[int, Columns]:
    """A term's columns on ``seen``, and their key in ``store``: computed once for every set of
    the columns they read (a sensor effect on P changes neither the columns nor the Gram blocks
    of the terms that read only x)."""
    entries = store.setdefault(("columns", placed.term, placed.value), [])
    for key, deps, columns in entries:
        if seen.reads_same(deps):
            return key, columns
    with seen.memo.recording() as deps:
        columns = placed.term.columns(seen, placed.value)
    key = seen.memo.key()
    entries.append((key, frozenset(deps), columns))
    return key, columns


@dataclass(frozen=True)
class StructureFit:
    """A structure fitted to ``target`` on ``rows``."""

    structure: Structure
    plan: Plan = field(repr=False)
    fit: LeastSquares
    target: np.ndarray = field(repr=False)
    rows: np.ndarray = field(repr=False)

    @cached_property
    def columns(self) -> Columns:
        """The design, assembled when first asked for (profiling only needs the fit)."""
        return self.plan.assemble()

    @cached_property
    def prediction(self) -> np.ndarray:
        """On every row (fitted on the training rows only)."""
        return self.fit.predict(self.columns)

    @cached_property
    def residual(self) -> np.ndarray:
        return self.target - self.prediction

    @property
    def params(self) -> dict[str, float]:
        return dict(zip(self.plan.names, self.fit.coef, strict=True))

    @property
    def sse(self) -> float:
        return self.fit.sse

    def scores(self, rows: np.ndarray, kind: str = "one-step") -> Scores:
        return score(self.target[rows], self.prediction[rows], kind)


def fit_structure(
    structure: Structure, signals: Signals, rows: np.ndarray | None = None
) -> StructureFit:
    """Least squares of ``signals.target`` on the structure's columns over ``rows`` (default
    the training rows)."""
    rows = signals.train if rows is None else rows
    design = structure.plan(signals)
    target = signals.target
    y_key = signals.cache.get(("target digest",))
    if y_key is None:  # signals never change: their target is hashed once
        y_key = signals.cache[("target digest",)] = ("target", id(signals))
    least = LeastSquares.from_plan(design, target, rows, signals.cache, y_key)
    return StructureFit(structure, design, least, target, rows)


def scan(
    best: StructureFit, index: int, signals: Signals, rows=None, step: int = 1
) -> tuple[StructureFit, list]:
    """Every ``step``-th grid value (and the last) of term ``index``'s hyperparameter, the
    others fixed: the best fit and all of them (in grid order)."""
    full = best.structure.profiled(index)[0].grid
    grid = tuple(dict.fromkeys((*full[::step], full[-1])))
    fits = [fit_structure(best.structure.at(index, g), signals, rows) for g in grid]
    found = min(fits, key=lambda f: f.sse)
    return (found if found.sse < best.sse else best), fits


def descend(best: StructureFit, index: int, signals: Signals, rows=None) -> StructureFit:
    """Term ``index``'s hyperparameter near its current value: walk the grid while the SSE
    falls (from the nearest grid value, first down then up); never worse than ``best``."""
    hyper, current = best.structure.profiled(index)
    grid = np.asarray(hyper.grid)
    distance = np.abs(np.log(grid / current)) if hyper.log else np.abs(grid - current)
    start = int(np.argmin(distance))
    if grid[start] != current:
        # a refined value between grid points stays unless a grid point fits better: snapping
        # a sharply determined relaxation time to its grid would cost more than the walk gains
        trial = fit_structure(best.structure.at(index, float(grid[start])), signals, rows)
        if trial.sse < best.sse:
            best = trial
    origin = best.structure.terms[index].value
    for step in (-1, 1):
        j = start + step
        while 0 <= j < len(grid):
            trial = fit_structure(best.structure.at(index, float(grid[j])), signals, rows)
            if trial.sse >= best.sse:
                break
            best, j = trial, j + step
        if best.structure.terms[index].value != origin:
            break
    return best


def refine(best: StructureFit, signals: Signals, rows=None, *, fixed=()) -> StructureFit:
    """Every hyperparameter between the grid neighbours of its value (bounded scalar search, in
    the logarithm for log grids): estimates that trade off against it (a viscous b against the
    SLS relaxation time) otherwise inherit the grid's resolution as a bias."""
    from scipy.optimize import minimize_scalar

    for index in best.structure.hypers:
        hyper, value = best.structure.profiled(index)
        if len(hyper.grid) < 2 or index in fixed:
            continue
        grid = np.asarray(hyper.grid)
        i = int(np.argmin(np.abs(grid - value)))
        low, high = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
        forward, back = (np.log, np.exp) if hyper.log else (float, float)

        def sse(u: float, index=index, back=back, start=best) -> float:
            return fit_structure(start.structure.at(index, float(back(u))), signals, rows).sse

        found = minimize_scalar(sse, bounds=(forward(low), forward(high)), method="bounded",
                                options={"xatol": 1e-3})  # fmt: skip
        trial = fit_structure(best.structure.at(index, float(back(found.x))), signals, rows)
        if trial.sse < best.sse:
            best = trial
    return best


def profile(
    structure: Structure, signals: Signals, rows=None, *, sweeps: int = 3, fixed=(), step=1
) -> StructureFit:
    """The structure with every hyperparameter (but those of the terms at ``fixed`` indices)
    profiled over its whole grid (coordinate sweeps, each from the others' current values),
    then refined. ``step`` > 1 scans every step-th grid value and then walks the grid from the
    best (:func:`descend`): the whole range at a coarser resolution, for profiles repeated many
    times (the loop's candidates), whose SSE is smooth along the grid."""
    best = fit_structure(structure, signals, rows)
    indices = [i for i in best.structure.hypers if i not in fixed]
    for _ in range(sweeps if len(indices) > 1 else 1):
        before = [best.structure.terms[i].value for i in indices]
        for index in indices:
            best, _ = scan(best, index, signals, rows, step)
            if step > 1:
                best = descend(best, index, signals, rows)
        if [best.structure.terms[i].value for i in indices] == before:
            break
    return refine(best, signals, rows, fixed=fixed)


def _sensitivity(fitted: StructureFit, index: int, signals: Signals) -> np.ndarray | None:
    """d(prediction)/d(hyper) of term ``index`` with the coefficients held fixed (per unit of
    its logarithm for log grids): a Gauss-Newton column for the joint covariance."""
    hyper, value = fitted.structure.profiled(index)
    grid = np.asarray(hyper.grid)
    if hyper.log:
        h = 1e-3
        centre = float(np.clip(np.log(value), np.log(grid[0]) + h, np.log(grid[-1]) - h))
        values = (np.exp(centre + h), np.exp(centre - h))
    else:
        h = 1e-3 * float(grid[-1] - grid[0])
        centre = float(np.clip(value, grid[0] + h, grid[-1] - h))
        values = (centre + h, centre - h)
    predictions = []
    for shifted in values:
        columns = fitted.structure.at(index, shifted).columns(signals)
        if columns.names != fitted.columns.names:
            return None
        predictions.append(columns.values @ fitted.fit.coef)
    return (predictions[0] - predictions[1]) / (2 * h)


def parameters(fitted: StructureFit, signals: Signals, confidence: float) -> pd.DataFrame:
    """The fitted parameters with intervals (for errors correlated as the residual is, see
    :func:`~hmid.balance.inference.inference`), profiled ones
    included: their sensitivity columns enter the covariance (Gauss-Newton), so the linear
    parameters that trade off against them get honest intervals. Columns: parameter, value,
    std. error, lower, upper, unit, positive."""
    return estimated(fitted, signals, confidence)[0]


def estimated(
    fitted: StructureFit, signals: Signals, confidence: float
) -> tuple[pd.DataFrame, np.ndarray]:
    """:func:`parameters`' table, and the covariance of the columns' coefficients (in column
    order and units) from the same joint covariance: the profiled parameters' trade-off with
    them included."""
    indices = fitted.structure.hypers
    found = {i: _sensitivity(fitted, i, signals) for i in indices}
    extras = {i: e for i, e in found.items() if e is not None}
    columns = fitted.columns
    if extras:
        names = tuple(f"sensitivity {i}" for i in extras)
        columns = columns + Columns(
            names, ("1",) * len(extras), np.column_stack(list(extras.values()))
        )
    table, covariance = sandwich(columns, fitted.target, fitted.rows, signals, confidence)
    width = fitted.columns.width
    half = (table["upper"] - table["lower"]).to_numpy() / 2
    value = table["value"].to_numpy().copy()
    # a sensitivity column's coefficient is a Gauss-Newton step (~0 at the optimum): keep the
    # fitted values, take the half-widths from the joint covariance
    value[:width] = fitted.fit.coef
    table["value"], table["lower"], table["upper"] = value, value - half, value + half
    table["positive"] = [*fitted.columns.positive, *([False] * len(extras))]
    for row, index in zip(range(width, width + len(extras)), extras, strict=True):
        hyper, at = fitted.structure.profiled(index)
        table.loc[row, ["parameter", "unit"]] = [hyper.name, hyper.unit]
        if hyper.log:
            log_value = np.log(at)
            table.loc[row, "std. error"] *= at  # delta method, for reference
            with np.errstate(over="ignore"):  # an unidentified parameter: an unbounded interval
                bounds = np.exp([log_value, log_value - half[row], log_value + half[row]])
        else:
            bounds = np.array([at, at - half[row], at + half[row]])
        table.loc[row, ["value", "lower", "upper"]] = bounds
    return table.reset_index(drop=True), covariance[:width, :width]
