"""Monomials of channels (``x^2*v``, ``x*v*P``): the products that a rig's ``channel`` terms and
the polynomial families' terms are made of.

A :class:`Monomial` is a product of variables raised to positive integer powers; ``Monomial()``
is the constant. It is parsed from and written as text (``Monomial.parse("x^2*v").name``), in a
canonical variable order so that equal monomials compare equal. The balance reads the powers of
its declared channels from it; :mod:`hmid.models.terms` builds the polynomial term sets from it.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from hmid.errors import ConfigError

#: Order of variables inside a term name; other variables follow alphabetically.
_VARIABLE_ORDER = ("x", "v", "a", "P", "t")
_SUPERSCRIPTS = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")
_FACTOR = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(?:\^(\d+))?$")


def variable_order(variable: str) -> tuple[int, str]:
    """Sort key of variables: x, v, a, P, t, then the others alphabetically."""
    known = variable in _VARIABLE_ORDER
    return (_VARIABLE_ORDER.index(variable) if known else len(_VARIABLE_ORDER), variable)


@dataclass(frozen=True)
class Monomial:
    """A monomial: ``powers`` pairs each variable with its (positive integer) power.

    Build one with ``Monomial.of(x=2, v=1)`` or ``Monomial.parse("x^2*v")``; pairs are kept in a
    canonical variable order (x, v, a, P, t, then others), so equal monomials compare equal.
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
    def of(cls, **powers: int) -> Monomial:
        """``Monomial.of(x=2, v=1)`` is x²·v; zero powers are dropped; ``Monomial.of()`` is 1."""
        return cls(tuple((v, p) for v, p in powers.items() if p != 0))

    @classmethod
    def parse(cls, name: str) -> Monomial:
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
