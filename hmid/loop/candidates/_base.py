"""Candidate effects: physics a base model may lack, each a small class that adds columns (or
transforms an input) and names its parameters with units.

A candidate may have one nonlinear parameter (a Stribeck velocity, a lag, a drift time) that the
loop profiles over :attr:`grid`; its other parameters enter linearly, with their signs built into
the columns so that every fitted coefficient is the physical parameter itself. The residual the
candidates explain is the *reconstructed* force's: friction the rig has but the reconstruction
does not subtract appears there with the opposite sign of the friction (F_m,rec = F_m - f_extra).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from hmid.errors import ConfigError
from hmid.loop.data import LoopData
from hmid.loop.design import Columns

CANDIDATES: dict[str, type[Candidate]] = {}


class Candidate:
    """Base class; subclasses set ``name`` (registry key), ``title`` and ``physics``."""

    name: ClassVar[str] = ""
    title: ClassVar[str] = ""
    physics: ClassVar[str] = ""
    hyper: ClassVar[tuple[str, str] | None] = None  # (name, unit) of the profiled parameter
    grid: ClassVar[tuple[float | None, ...]] = (None,)
    tail_s: ClassVar[float] = 0.0  # reaches this far past a segment's end (a lead)
    # whether a profiled value on the grid's lower / upper edge still identifies the effect
    # (a Stribeck velocity at the top of its range is a friction falling over all speeds,
    # not a Stribeck curve; a lag of zero is no lag)
    edges_identified: ClassVar[tuple[bool, bool]] = (True, True)
    # parameters that physics makes positive (a friction that *grows* with speed is not a
    # negative Stribeck bump): a fit with another sign is not this effect. "Positive" means the
    # sign of friction in the base's convention (Base.friction_sign)
    positive: ClassVar[tuple[str, ...]] = ()
    friction: ClassVar[bool] = False  # its linear parameters are friction coefficients

    def identified(self, value: float | None) -> bool:
        if value is None or len(self.grid) < 2:
            return True
        low, high = self.edges_identified
        return (low or value != self.grid[0]) and (high or value != self.grid[-1])

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.name:
            CANDIDATES[cls.name] = cls

    def transform(self, data: LoopData, value: float | None) -> LoopData:
        """The data as the base model should see it (e.g. pressure advanced by a lag)."""
        return data

    def columns(self, data: LoopData, value: float | None, elastic: np.ndarray) -> Columns:
        """Extra columns; ``elastic`` is the fitted base's elongation-dependent force."""
        return Columns.empty(len(data))

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


def make_candidates(names: tuple[str, ...]) -> tuple[Candidate, ...]:
    unknown = [n for n in names if n not in CANDIDATES]
    if unknown:
        raise ConfigError(
            f"loop.candidates: unknown effect(s) {unknown}; known: {sorted(CANDIDATES)}"
        )
    return tuple(CANDIDATES[n]() for n in names)


def direction(data: LoopData) -> np.ndarray:
    return np.sign(data["v"])
