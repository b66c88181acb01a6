"""Monomial terms (``x^2*v``, ``x*v*P``) of polynomial force models, their units and term sets.

A :class:`Term` is a product of variables raised to positive integer powers; ``Term()`` is the
constant. :func:`polynomial_terms` generates every term up to a total degree (with optional caps
per variable) in the thesis's order: by total degree, then P-free terms first, then falling
powers of x. The four term sets compared in the thesis (Ch. 4, Table 4.1) are named in
:data:`VARIANTS`; ``"cubic_xvP"`` is the chosen 16-term model C0 ... C15.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache, lru_cache
from itertools import product
from types import MappingProxyType

import numpy as np

from hmid.errors import ConfigError
from hmid.io.log import CANONICAL_UNITS
from hmid.io.units import unit_registry

#: Order of variables inside a term name; other variables follow alphabetically.
_VARIABLE_ORDER = ("x", "v", "a", "P", "t")
_SUPERSCRIPTS = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")
_FACTOR = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(?:\^(\d+))?$")


def variable_order(variable: str) -> tuple[int, str]:
    """Sort key of variables: x, v, a, P, t, then the others alphabetically."""
    known = variable in _VARIABLE_ORDER
    return (_VARIABLE_ORDER.index(variable) if known else len(_VARIABLE_ORDER), variable)


@dataclass(frozen=True)
class Term:
    """A monomial: ``powers`` pairs each variable with its (positive integer) power.

    Build one with ``Term.of(x=2, v=1)`` or ``Term.parse("x^2*v")``; pairs are kept in a canonical
    variable order (x, v, a, P, t, then others), so equal monomials compare equal.
    """

    powers: tuple[tuple[str, int], ...] = ()

    def __post_init__(self) -> None:
        seen = set()
        for pair in self.powers:
            if not (isinstance(pair, tuple) and len(pair) == 2):
                raise ConfigError(f"term powers must be (variable, power) pairs, got {pair!r}")
            variable, power = pair
            if not (isinstance(variable, str) and variable.isidentifier()):
                raise ConfigError(f"term variable must be a name such as 'x', got {variable!r}")
            if isinstance(power, bool) or not isinstance(power, int | np.integer) or power < 1:
                raise ConfigError(
                    f"power of {variable!r} must be a positive integer, got {power!r}"
                )
            if variable in seen:
                raise ConfigError(f"variable {variable!r} appears twice in one term")
            seen.add(variable)
        pairs = ((v, int(p)) for v, p in self.powers)
        canonical = tuple(sorted(pairs, key=lambda vp: variable_order(vp[0])))
        object.__setattr__(self, "powers", canonical)

    @classmethod
    def of(cls, **powers: int) -> Term:
        """``Term.of(x=2, v=1)`` is x²·v; zero powers are dropped; ``Term.of()`` is 1."""
        return cls(tuple((v, p) for v, p in powers.items() if p != 0))

    @classmethod
    def parse(cls, name: str) -> Term:
        """The term named like :attr:`name` (``'1'``, ``'x'``, ``'x^2*v'``, ``'x*v*P'``)."""
        text = name.replace(" ", "")
        if text == "1":
            return cls()
        powers = []
        for factor in text.split("*"):
            match = _FACTOR.match(factor)
            if match is None:
                raise ConfigError(f"cannot read term {name!r}; write terms like '1', 'x', 'x^2*v'")
            powers.append((match.group(1), int(match.group(2) or 1)))
        return cls(tuple(powers))

    @property
    def variables(self) -> tuple[str, ...]:
        return tuple(v for v, _ in self.powers)

    @property
    def degree(self) -> int:
        return sum(p for _, p in self.powers)

    def power(self, variable: str) -> int:
        return dict(self.powers).get(variable, 0)

    def exponents(self, variables: tuple[str, ...]) -> tuple[int, ...]:
        """The powers as an exponent tuple over ``variables``, e.g. (2, 1, 0) for x²v."""
        return tuple(self.power(v) for v in variables)

    @property
    def name(self) -> str:
        """ASCII name: ``'1'``, ``'x'``, ``'x^2*v'``, ``'x*v*P'``."""
        factors = [v if p == 1 else f"{v}^{p}" for v, p in self.powers]
        return "*".join(factors) or "1"

    @property
    def pretty(self) -> str:
        """Name with superscripts and middle dots: ``'x²·v'``."""
        factors = [v if p == 1 else v + str(p).translate(_SUPERSCRIPTS) for v, p in self.powers]
        return "·".join(factors) or "1"

    def evaluate(
        self,
        columns: Mapping[str, np.ndarray],
        scales: Mapping[str, float] | None = None,
        n: int | None = None,
    ) -> np.ndarray:
        """The term's values, each variable divided by its scale first (if ``scales`` given).

        ``n`` is the number of rows, needed only for the constant when ``columns`` is empty.
        """
        if n is None:
            n = len(next(iter(columns.values()))) if columns else 0
        out = np.ones(n)
        for variable, power in self.powers:
            values = columns[variable]
            if scales is not None:
                values = values / scales[variable]
            out = out * values**power
        return out

    def scale_factor(self, scales: Mapping[str, float]) -> float:
        """Product of ``scale**power``: the scaled-feature coefficient over the physical one."""
        return float(np.prod([scales[v] ** p for v, p in self.powers]))

    def __str__(self) -> str:
        return self.name


def variable_unit(variable: str, units: Mapping[str, str] | None = None) -> str:
    """The SI unit of a model variable: from ``units`` (a rig's channels), else the canonical
    channel units (x m, v m/s, P Pa, ...)."""
    if units is not None and variable in units:
        return units[variable]
    if variable not in CANONICAL_UNITS:
        raise ConfigError(
            f"variable {variable!r} has no known unit; model variables are channels "
            f"{', '.join(CANONICAL_UNITS)}"
        )
    return CANONICAL_UNITS[variable]


def coefficient_unit(term: Term, target: str = "N", units: Mapping[str, str] | None = None) -> str:
    """Unit of the coefficient that multiplies ``term`` to give ``target``: 'N·s/(m²·Pa)';
    ``units`` gives the variables' units where they are not the canonical channels'."""
    pairs = tuple(sorted(units.items())) if units else ()
    return _coefficient_unit(term, target, pairs)


@lru_cache(maxsize=512)
def _coefficient_unit(term: Term, target: str, units: tuple[tuple[str, str], ...]) -> str:
    ureg = unit_registry()
    unit = ureg.parse_units(target)
    known = dict(units) if units else None
    for variable, power in term.powers:
        unit = unit / ureg.parse_units(variable_unit(variable, known)) ** power
    return format_unit(unit)


def format_unit(unit: object) -> str:
    """A pint unit as compact text: 'N', 'N/m', 'N·s²/m²', 'N/(m·Pa)'; '1' if dimensionless."""
    ureg = unit_registry()

    def factor(name: str, power: float) -> str:
        symbol = ureg.get_symbol(name)
        power = abs(power)
        if power == 1:
            return symbol
        text = str(int(power)) if float(power).is_integer() else f"^{power:g}"
        return symbol + text.translate(_SUPERSCRIPTS)

    items = list(unit._units.items())  # pint's UnitsContainer: {'newton': 1, 'meter': -2, ...}
    numerator = "·".join(factor(n, p) for n, p in items if p > 0) or "1"
    negative = [factor(n, p) for n, p in items if p < 0]
    if not negative:
        return numerator
    denominator = negative[0] if len(negative) == 1 else "(" + "·".join(negative) + ")"
    return f"{numerator}/{denominator}"


#: Default per-variable caps of :func:`polynomial_terms`: pressure enters at most linearly.
P_LINEAR: Mapping[str, int] = MappingProxyType({"P": 1})


def polynomial_terms(
    variables: tuple[str, ...] = ("x", "v", "P"),
    degree: int = 3,
    max_degree_per_variable: Mapping[str, int] = P_LINEAR,
) -> tuple[Term, ...]:
    """Every monomial in ``variables`` of total degree <= ``degree``, the constant included.

    ``max_degree_per_variable`` caps single variables (by default P enters at most linearly, as in
    the thesis; the default cap is ignored when P is not among ``variables``). Terms come in the
    thesis's order: by total degree, then by the exponent tuple read from the last variable to the
    first, so ``('x','v','P'), 3`` gives 1, x, v, P, x², xv, v², xP, vP, x³, x²v, xv², v³, x²P, xvP,
    v²P (C0 ... C15).
    """
    variables = tuple(variables)
    if not variables or len(set(variables)) != len(variables):
        raise ConfigError(f"variables must be distinct names, got {variables!r}")
    if isinstance(degree, bool) or not isinstance(degree, int) or degree < 0:
        raise ConfigError(f"degree must be a non-negative integer, got {degree!r}")
    caps = dict(max_degree_per_variable)
    if max_degree_per_variable is P_LINEAR:
        caps = {v: c for v, c in caps.items() if v in variables}
    for variable, cap in caps.items():
        if variable not in variables:
            raise ConfigError(
                f"max_degree_per_variable names {variable!r}, which is not one of {variables}"
            )
        if isinstance(cap, bool) or not isinstance(cap, int) or cap < 0:
            raise ConfigError(f"max degree of {variable!r} must be an integer >= 0, got {cap!r}")
    ranges = [range(min(degree, caps.get(v, degree)) + 1) for v in variables]
    exponents = [e for e in product(*ranges) if sum(e) <= degree]
    exponents.sort(key=lambda e: (sum(e), e[::-1]))
    return tuple(Term.of(**dict(zip(variables, e, strict=True))) for e in exponents)


#: The four term sets of the thesis (Ch. 4, Table 4.1), by name.
VARIANTS: Mapping[str, tuple[tuple[str, ...], int]] = MappingProxyType(
    {
        "quadratic_xv": (("x", "v"), 2),  # 6 terms
        "cubic_xv": (("x", "v"), 3),  # 10 terms
        "quadratic_xvP": (("x", "v", "P"), 2),  # 9 terms
        "cubic_xvP": (("x", "v", "P"), 3),  # 16 terms, the thesis's chosen model
    }
)


@cache
def variant_terms(name: str) -> tuple[Term, ...]:
    """The terms of a named variant (see :data:`VARIANTS`), in the thesis's order."""
    if name not in VARIANTS:
        raise ConfigError(f"unknown polynomial variant {name!r}; choose one of {list(VARIANTS)}")
    variables, degree = VARIANTS[name]
    return polynomial_terms(variables, degree)


def resolve_terms(terms: object) -> tuple[Term, ...]:
    """A variant name or a tuple of :class:`Term` (or names like ``'x^2*v'``), checked."""
    if isinstance(terms, str):
        return variant_terms(terms)
    try:
        items = tuple(terms)  # type: ignore[arg-type]
    except TypeError:
        raise ConfigError(
            f"terms must be a variant name ({', '.join(VARIANTS)}) or a tuple of Term, "
            f"got {type(terms).__name__}"
        ) from None
    resolved = tuple(Term.parse(t) if isinstance(t, str) else t for t in items)
    for term in resolved:
        if not isinstance(term, Term):
            raise ConfigError(f"terms must be Term objects or names like 'x^2*v', got {term!r}")
    if not resolved:
        raise ConfigError("terms must not be empty")
    if all(not term.powers for term in resolved):
        raise ConfigError("terms must involve at least one variable (x, v, P, ...), not only '1'")
    names = [t.name for t in resolved]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise ConfigError(f"terms repeat {duplicates}; list each monomial once")
    return resolved
