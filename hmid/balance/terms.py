"""The one contract of everything that contributes a force to a balance: :class:`Term`.

A rig's declared terms (a mass times acceleration, Coulomb friction, a viscoelastic memory), the
terms of a model family's force (the monomials of a polynomial, the SLS's springs and arm) and
the loop's candidate effects (viscous friction, a pressure lag) are all terms. A term

* returns design :class:`~hmid.balance.columns.Columns` whose coefficients *are* its physical
  parameters (the sign with which it enters the balance is built into the column, so a mass or a
  friction level comes out positive), with units and the channels they read;
* has at most one nonlinear parameter (:class:`Hyper`: a relaxation time, a delay), profiled on
  a grid by whoever fits it, the others entering linearly;
* may change what the other terms see (:meth:`Term.transform`: a lag on a sensor shifts that
  channel for every term), and may leave a few rows at segment ends unusable (:attr:`margins`).

Because every term speaks this language, the loop can add candidate effects to *any* fitted model
and refit the whole balance by least squares (:mod:`hmid.balance.structure`).
"""

from __future__ import annotations

import itertools
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from hmid.balance.columns import Columns
from hmid.balance.signals import Signals


@dataclass(frozen=True)
class Hyper:
    """A term's nonlinear parameter: ``name`` [``unit``], profiled over ``grid``.

    ``edges_identified``: whether a value on the grid's lower / upper edge still identifies the
    effect (a delay of zero is no delay; a Stribeck velocity at the top of its range is friction
    falling over all speeds, not a Stribeck curve). ``log``: the grid is log-spaced (refine in
    the logarithm).
    """

    name: str
    unit: str
    grid: tuple[float, ...]
    edges_identified: tuple[bool, bool] = (True, True)
    log: bool = True

    def __post_init__(self) -> None:
        grid = tuple(float(g) for g in self.grid)
        if len(grid) < 1 or any(b <= a for a, b in itertools.pairwise(grid)):
            raise ValueError(f"hyperparameter {self.name}: grid must increase, got {grid}")
        if self.log and grid[0] <= 0:
            raise ValueError(f"hyperparameter {self.name}: a log grid must be positive")
        object.__setattr__(self, "grid", grid)

    def on_edge(self, value: float) -> bool:
        """Whether ``value`` sits on a grid edge that does not identify the effect."""
        if len(self.grid) < 2:
            return False
        low, high = self.edges_identified
        return (not low and value <= self.grid[0]) or (not high and value >= self.grid[-1])


class Term(ABC):
    """One physical term of a force balance; see the module docstring.

    Subclasses provide :attr:`name`, :meth:`columns` and, where they have one, :attr:`hyper`.
    """

    # ``name`` (the parameter or effect), ``title`` and ``physics`` (for reports) are set by
    # subclasses, as fields, class or instance attributes; none is annotated here at run time,
    # where pydantic would take it for a field of TermSpec (and put it first)
    if TYPE_CHECKING:
        name: str
    title = ""
    physics = ""
    #: whether the term refines earlier ones: their columns that its own span are dropped
    refines: ClassVar[bool] = False

    @property
    def hyper(self) -> Hyper | None:
        return None

    @property
    def reads(self) -> tuple[str, ...]:
        """The channels the term reads (for applicability and for tracing a wrong sign)."""
        return ()

    @property
    def margins(self) -> tuple[float, float]:
        """Seconds at the start / end of each segment where the term's columns are unreliable
        (a delay reaches before the start, a lead past the end), over its whole grid."""
        return (0.0, 0.0)

    @abstractmethod
    def columns(self, signals: Signals, value: float | None) -> Columns:
        """The term's columns on every row of ``signals``, at hyperparameter ``value``."""

    def transform(self, signals: Signals, value: float | None) -> Signals:
        """The signals as every term should see them (identity unless the term is a sensor
        effect, such as a lagging pressure reading)."""
        return signals

    def identified(self, value: float | None) -> bool:
        return self.hyper is None or value is None or not self.hyper.on_edge(value)

    def label(self) -> str:
        return self.title or self.name


def _implied(target: str, regressor: tuple[tuple[str, float], ...]):
    from hmid.io.units import unit_registry

    ureg = unit_registry()
    unit = ureg.parse_units(target)
    for part, power in regressor:
        unit = unit / ureg.parse_units(part) ** power
    return unit


@lru_cache(maxsize=1024)
def implied_unit(target: str, regressor: tuple[tuple[str, float], ...]) -> str:
    """Unit of a coefficient that multiplies a regressor with ``regressor`` = ((unit, power), ...)
    to give ``target``: ``implied_unit("N", (("m/s", 1),))`` is ``'N·s/m'``."""
    from hmid.io.units import format_unit

    return format_unit(_implied(target, regressor))


@lru_cache(maxsize=1024)
def display_unit(
    declared: str | None, target: str, regressor: tuple[tuple[str, float], ...]
) -> str:
    """The declared unit where it is the implied one by another name (kg for N·s²/m), else the
    implied unit: coefficients are always in SI."""
    if declared:
        from hmid.io.units import unit_registry

        ureg = unit_registry()
        try:
            factor = ureg.Quantity(1.0, ureg.parse_units(declared)).to(_implied(target, regressor))
            if abs(factor.magnitude - 1.0) < 1e-12:
                return declared
        except Exception:
            pass
    return implied_unit(target, regressor)


def unit_of(signals: Signals, powers: Mapping[str, int], declared: str | None = None) -> str:
    """The coefficient unit for a product of channels (``{"x": 3}``) in ``signals``."""
    parts = tuple((signals.unit(c), float(p)) for c, p in sorted(powers.items()))
    return display_unit(declared, signals.unit("target"), parts)


def log_grid(low: float, high: float, points: int) -> tuple[float, ...]:
    return tuple(float(g) for g in np.geomspace(low, high, points))
