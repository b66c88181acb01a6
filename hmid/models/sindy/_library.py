"""The candidate terms of the force map: pysindy's polynomial library in x, v, P plus tanh(v/v0).

The library is a pysindy ``GeneralizedLibrary`` of a ``PolynomialLibrary`` over the configured
variables (each divided by its largest absolute training value, so every monomial lies in
[-1, 1]) and, for friction, a ``CustomLibrary`` with the smooth sign ``tanh(v / v0)`` of the
physical velocity. Monomials whose power of a variable exceeds its cap (pressure enters only
linearly by default, as in the thesis) are dropped, and so is any column that repeats an earlier
one exactly (by name or value), so no term is counted twice. Each kept column is a
:class:`Feature` that knows its unit and its term (the monomial that the model file states).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from hmid.balance.monomial import Monomial
from hmid.errors import ConfigError
from hmid.models.terms import coefficient_unit, polynomial_terms

#: Name of the smooth friction column.
TANH_NAME = "tanh(v/v0)"


@dataclass(frozen=True)
class Feature:
    """One library column: a monomial ``term`` (physical variables), or ``tanh(v/v0)``.

    ``factor`` converts a coefficient of the scaled column (variables divided by their scales)
    to the physical coefficient: ``c_physical = c_scaled * factor``.
    """

    name: str  # 'x^2*v', 'tanh(v/v0)'
    pretty: str  # 'x²·v', 'tanh(v/v0)'
    unit: str  # unit of the coefficient that multiplies it to give N
    factor: float
    term: Monomial | None = None  # None for tanh(v/v0)

    @property
    def is_friction(self) -> bool:
        return self.term is None


def _exponent_term(variables: tuple[str, ...], powers: np.ndarray) -> Monomial:
    return Monomial.of(**{v: int(p) for v, p in zip(variables, powers, strict=True)})


class FeatureLibrary:
    """Builds, fits and evaluates the candidate library (see the module docstring).

    Its arguments are trusted: :meth:`SINDySettings.library
    <hmid.models.sindy.SINDySettings.library>` builds it from validated settings.
    """

    def __init__(
        self,
        variables: tuple[str, ...] = ("x", "v", "P"),
        degree: int = 3,
        max_degree: Mapping[str, int] | None = None,
        friction_term: bool = True,
        v0: float = 1e-3,
    ) -> None:
        # the values are those of a validated SINDySettings (its library()): not checked again
        variables = tuple(variables)
        caps = {"P": 1} if max_degree is None else dict(max_degree)
        self.variables = variables
        self.degree = degree
        self.caps = {v: c for v, c in caps.items() if v in variables}
        self.friction_term = friction_term
        self.v0 = float(v0)

    def candidate_names(self) -> tuple[str, ...]:
        """Names of every term the library can hold (before duplicates are dropped)."""
        names = [t.name for t in polynomial_terms(self.variables, self.degree, self.caps)]
        return (*names, TANH_NAME) if self.friction_term else tuple(names)

    # -- fitting ---------------------------------------------------------------------------------
    def fit(self, columns: Mapping[str, np.ndarray]) -> FeatureLibrary:
        """Scales from the training rows, the pysindy library, the kept columns (``features_``)."""
        self._fit_design(columns)
        return self

    def fit_transform(self, columns: Mapping[str, np.ndarray]) -> np.ndarray:
        """:meth:`fit`, then :meth:`transform` of the same rows (their design built once)."""
        return self._fit_design(columns)[:, self.columns_]

    def _fit_design(self, columns: Mapping[str, np.ndarray]) -> np.ndarray:
        self.scales_ = {v: _scale_of(columns[v]) for v in self.required}
        inputs = self._inputs(columns)
        poly = self.pysindy_library(inputs[:2]).libraries[0]
        # pysindy's products, in its order: kept rather than its library, so that a fitted
        # model transforms (and unpickles) without importing pysindy
        self._combos = tuple(
            poly._combinations(len(self.variables), self.degree, True, False, True)
        )
        design = self._design(inputs)
        powers = np.asarray(poly.powers_)
        candidates: list[tuple[int, Feature]] = []
        for j, row in enumerate(powers):
            if any(row[i] > self.caps.get(v, self.degree) for i, v in enumerate(self.variables)):
                continue
            term = _exponent_term(self.variables, row)
            factor = 1.0 / term.scale_factor(self.scales_)
            candidates.append(
                (j, Feature(term.name, term.pretty, coefficient_unit(term), factor, term))
            )
        if self.friction_term:
            candidates.append((len(powers), Feature(TANH_NAME, TANH_NAME, "N", 1.0)))
        kept: list[tuple[int, Feature]] = []
        dropped: list[tuple[int, Feature]] = []
        size = np.max(np.abs(design), axis=0) if len(design) else np.zeros(design.shape[1])
        probe = design[:: max(1, len(design) // 64)]  # a column unlike another differs here first
        for j, feature in candidates:
            duplicate = any(
                feature.name == f.name or _same(design, probe, size, j, i) for i, f in kept
            )
            (dropped if duplicate else kept).append((j, feature))
        self.columns_ = np.array([j for j, _ in kept])
        self.features_ = tuple(f for _, f in kept)
        self.dropped_ = tuple(f.name for _, f in dropped)
        return design

    def pysindy_library(self, inputs: np.ndarray):
        """pysindy's ``GeneralizedLibrary`` of these terms (polynomials of the scaled variables,
        then tanh of v / v0), fitted to ``inputs`` (what it learns is their number)."""
        import pysindy as ps

        libraries = [ps.PolynomialLibrary(degree=self.degree, include_bias=True)]
        inputs_per_library = [list(range(len(self.variables)))]
        if self.friction_term:
            libraries.append(
                ps.CustomLibrary(library_functions=[_tanh], function_names=[_tanh_name])
            )
            inputs_per_library.append([len(self.variables)])  # v / v0 (physical v), appended last
        library = ps.GeneralizedLibrary(libraries, inputs_per_library=inputs_per_library)
        return library.fit(inputs)

    def _inputs(self, columns: Mapping[str, np.ndarray]) -> np.ndarray:
        scaled = [columns[v] / self.scales_[v] for v in self.variables]
        if self.friction_term:
            scaled.append(columns["v"] / self.v0)
        return np.column_stack(scaled)

    def _design(self, inputs: np.ndarray) -> np.ndarray:
        """pysindy's transform of ``inputs`` (scaled variables, then v / v0) without its
        per-column array wrapping (two thirds of a design's cost; tested equal to it)."""
        combos = self._combos
        # each product is the previous one with one more factor: the same left-to-right
        # multiplications as a product over the combination
        products = {(): np.ones(len(inputs))}
        for combo in combos:
            if combo not in products:
                products[combo] = products[combo[:-1]] * inputs[:, combo[-1]]
        design = [products[combo] for combo in combos]
        if self.friction_term:
            design.append(_tanh(inputs[:, len(self.variables)]))
        return np.column_stack(design) if design else np.empty((len(inputs), 0))

    def transform(self, columns: Mapping[str, np.ndarray]) -> np.ndarray:
        """The design (rows x kept features) in the scaled basis; see :attr:`Feature.factor`."""
        return self._design(self._inputs(columns))[:, self.columns_]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(f.name for f in self.features_)

    @property
    def required(self) -> tuple[str, ...]:
        """Columns a design needs: the variables, and v for the friction term."""
        return tuple(dict.fromkeys((*self.variables, *(("v",) if self.friction_term else ()))))


def canonical_name(name: str) -> str:
    """A term's name in the library's spelling: ``'P*x'`` -> ``'x*P'``; ``tanh(v/v0)`` as is."""
    text = name.replace(" ", "")
    if text == TANH_NAME:
        return TANH_NAME
    try:
        return Monomial.parse(text).name
    except ConfigError:
        return text


def _scale_of(values: np.ndarray) -> float:
    scale = float(np.max(np.abs(values))) if values.size else 0.0
    return scale if scale > 0 else 1.0


def _same(design: np.ndarray, probe: np.ndarray, size: np.ndarray, j: int, i: int) -> bool:
    """Columns ``j`` and ``i`` of ``design`` equal to rounding (a library that adds the same
    column twice); ``probe`` is a subset of its rows, ``size`` its columns' largest magnitudes:
    a difference there already decides (most pairs), and only a pair alike there is compared
    whole."""
    tol = 1e-12 * max(float(size[j]), float(size[i]), 1e-300)
    if np.max(np.abs(probe[:, j] - probe[:, i]), initial=0.0) > tol:
        return False
    return bool(np.max(np.abs(design[:, j] - design[:, i]), initial=0.0) <= tol)


def _tanh(u: np.ndarray) -> np.ndarray:
    """The friction column, of ``u = v / v0`` (a named function: pysindy reads its arity, and
    fitted models are pickled by the pipeline's stage cache)."""
    return np.tanh(u)


def _tanh_name(*_: str) -> str:
    return TANH_NAME
