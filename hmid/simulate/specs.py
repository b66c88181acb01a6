"""A Hydro Muscle from its specifications: the physical scaling from dimensions to parameters.

The simulator's muscle (:class:`~hmid.simulate.params.MuscleParams`) is
F_m = A_eff P + F0 - (k1 x + k3 x^3 + q), dq/dt = -q/tau + k2 dx/dt. A muscle declared by its
build (latex core length L, bore d_i, outer diameter d_o, sheath, latex modulus E) has
parameters that follow from it (thesis §8.1: the specifications as variables of the model):

* A_eff = c_A * pi d_i^2 / 4: the pressure pushes on the bore's end cap; the sheath blocks radial
  growth, so the bore sets the area (c_A absorbs the end fittings);
* k1 = E A_w / L, with A_w = pi (d_o^2 - d_i^2) / 4 the wall's cross-section: a bar in tension;
* k3 = beta E A_w / L^3: the latex's stiffening, F = E A_w (eps + beta eps^3) with eps = x / L;
* k2 = r k1 and tau: the standard linear solid's Maxwell arm, a material property (r and tau do
  not depend on the dimensions);
* F0 = sigma0 A_w: a preload stress from the clamping, carried by the wall.

So the expected exponents are A_eff ~ d_i^2, k1 ~ k2 ~ A_w / L, k3 ~ A_w / L^3, tau ~ 1. No
real muscle sits exactly on the law: :meth:`MuscleSpec.draw` adds a manufacturing scatter, a
log-normal factor per parameter from an explicit seed.
"""

from __future__ import annotations

import math
from typing import Annotated

import numpy as np
from pydantic import Field, model_validator

from hmid.simulate.params import MuscleParams, NonNegative, Positive, _Frozen

#: The muscle parameters the scaling law sets, in MuscleParams' order.
SCALED = ("A_eff", "F0", "k1", "k3", "k2", "tau")


class Scatter(_Frozen):
    """Muscle-to-muscle scatter: the log-normal standard deviation of each parameter's factor
    (0.05 ~ 5 %), and the absolute scatter of the preload F0 (N)."""

    A_eff: NonNegative = 0.03
    k1: NonNegative = 0.08
    k3: NonNegative = 0.15
    k2: NonNegative = 0.10
    tau: NonNegative = 0.10
    F0: NonNegative = 0.0  # N, additive (F0 can be zero or negative)


class MuscleSpec(_Frozen):
    """A Hydro Muscle's build, SI units. The defaults give the thesis Ch. 4 muscle (a 35 mm
    core, ~16 mm bore) with the simulator's default parameters to within a few per cent."""

    length: Positive = 0.035  # m, latex core's relaxed length
    inner_diameter: Positive = 0.016  # m, the core's bore
    outer_diameter: Positive = 0.0186  # m, the core's outside
    sheath_diameter: Positive | None = None  # m, the sheath's inside (>= outer diameter)
    modulus: Positive = 1.5e6  # Pa, latex Young's modulus
    stiffening: NonNegative = 0.8  # beta, cubic stiffening of the latex (dimensionless)
    memory_ratio: NonNegative = 0.5  # r = k2 / k1
    relaxation_time: Positive = 0.2  # s, tau of the Maxwell arm
    prestress: float = 0.0  # Pa, clamping preload over the wall's cross-section
    area_factor: Annotated[float, Field(gt=0.5, lt=1.5)] = 1.0  # c_A

    @model_validator(mode="after")
    def _geometry(self) -> MuscleSpec:
        if self.outer_diameter <= self.inner_diameter:
            raise ValueError(
                f"outer_diameter={self.outer_diameter} must exceed "
                f"inner_diameter={self.inner_diameter} (the latex wall has a thickness)"
            )
        if self.sheath_diameter is not None and self.sheath_diameter < self.outer_diameter:
            raise ValueError(
                f"sheath_diameter={self.sheath_diameter} must be at least "
                f"outer_diameter={self.outer_diameter} (the sheath goes over the core)"
            )
        return self

    @property
    def bore_area(self) -> float:
        """pi d_i^2 / 4 (m^2)."""
        return math.pi * self.inner_diameter**2 / 4

    @property
    def wall_area(self) -> float:
        """The latex wall's cross-section, pi (d_o^2 - d_i^2) / 4 (m^2)."""
        return math.pi * (self.outer_diameter**2 - self.inner_diameter**2) / 4

    def params(self) -> MuscleParams:
        """The muscle exactly on the scaling law."""
        EA = self.modulus * self.wall_area
        k1 = EA / self.length
        return MuscleParams(
            A_eff=self.area_factor * self.bore_area,
            F0=self.prestress * self.wall_area,
            k1=k1,
            k3=self.stiffening * EA / self.length**3,
            k2=self.memory_ratio * k1,
            tau=self.relaxation_time,
        )

    def draw(self, scatter: Scatter, seed: int) -> MuscleParams:
        """One manufactured muscle of this build: the law's parameters times a log-normal
        factor each (seeded: the same seed gives the same muscle)."""
        law = self.params()
        rng = np.random.default_rng(seed)
        values = law.model_dump()
        for name in ("A_eff", "k1", "k3", "k2", "tau"):
            values[name] = float(values[name] * np.exp(rng.normal(0.0, getattr(scatter, name))))
        values["F0"] = float(values["F0"] + rng.normal(0.0, scatter.F0))
        return MuscleParams(**values)
