"""Terms of polynomial force models (``x^2*v``, ``x*v*P``): their units and term sets.

A term is a :class:`~hmid.balance.monomial.Monomial`, a product of variables raised to positive
integer powers (``Monomial()`` is the constant). :func:`polynomial_terms` generates every term
up to a total degree (with optional caps per variable) in the thesis's order: by total degree,
then P-free terms first, then falling powers of x. The four term sets compared in the thesis
(Ch. 4, Table 4.1) are named in :data:`VARIANTS`; ``"cubic_xvP"`` is the chosen 16-term model
C0 ... C15.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from functools import cache
from itertools import product
from types import MappingProxyType

from hmid.balance.monomial import Monomial
from hmid.balance.terms import implied_unit
from hmid.errors import ConfigError
from hmid.io.log import CANONICAL_UNITS


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


def coefficient_unit(
    term: Monomial, target: str = "N", units: Mapping[str, str] | None = None
) -> str:
    """Unit of the coefficient that multiplies ``term`` to give ``target``: 'N·s/(m²·Pa)';
    ``units`` gives the variables' units where they are not the canonical channels'."""
    return implied_unit(target, tuple((variable_unit(v, units), p) for v, p in term.powers))


#: Default per-variable caps of :func:`polynomial_terms`: pressure enters at most linearly.
P_LINEAR: Mapping[str, int] = MappingProxyType({"P": 1})


def polynomial_terms(
    variables: tuple[str, ...] = ("x", "v", "P"),
    degree: int = 3,
    max_degree_per_variable: Mapping[str, int] = P_LINEAR,
) -> tuple[Monomial, ...]:
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
    return tuple(Monomial.of(**dict(zip(variables, e, strict=True))) for e in exponents)


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
def variant_terms(name: str) -> tuple[Monomial, ...]:
    """The terms of a named variant (see :data:`VARIANTS`), in the thesis's order."""
    if name not in VARIANTS:
        raise ConfigError(f"unknown polynomial variant {name!r}; choose one of {list(VARIANTS)}")
    variables, degree = VARIANTS[name]
    return polynomial_terms(variables, degree)


def resolve_terms(terms: str | Iterable[Monomial | str]) -> tuple[Monomial, ...]:
    """A variant name or a tuple of :class:`~hmid.balance.monomial.Monomial` (or names like
    ``'x^2*v'``), checked."""
    if isinstance(terms, str):
        return variant_terms(terms)
    try:
        items = tuple(terms)
    except TypeError:
        raise ConfigError(
            f"terms must be a variant name ({', '.join(VARIANTS)}) or a tuple of Monomial, "
            f"got {type(terms).__name__}"
        ) from None
    resolved = tuple(Monomial.parse(t) if isinstance(t, str) else t for t in items)
    for term in resolved:
        if not isinstance(term, Monomial):
            raise ConfigError(f"terms must be Monomial objects or names like 'x^2*v', got {term!r}")
    if not resolved:
        raise ConfigError("terms must not be empty")
    if all(not term.powers for term in resolved):
        raise ConfigError("terms must involve at least one variable (x, v, P, ...), not only '1'")
    names = [t.name for t in resolved]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise ConfigError(f"terms repeat {duplicates}; list each monomial once")
    return resolved
