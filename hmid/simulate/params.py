"""Physical parameters of the simulated Ch. 4 rig, as typed, frozen, validated configs.

Defaults are in the thesis's order of magnitude (see ``shared/design/thesis.md``): a short latex
core (k ~ 10^3-10^4 N/m) with a standard-linear-solid memory, a 0.5 kg hanging mass, sub-newton
Coulomb friction, 10-bit sensors with the thesis's resolutions (1171 Pa, 0.02 mm, 0.01 N).
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, model_validator

from hmid.config import NonNegative, Positive


class _Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class MuscleParams(_Frozen):
    """Hydro Muscle force: F_m = A_eff P + F0 - s(t) (k1 x + k3 x^3 + q), dq/dt = -q/tau + k2 dx/dt.

    ``q`` is the force in the Maxwell arm of a standard linear solid (spring k2 in series with a
    dashpot eta = k2 tau), k1 the equilibrium spring, k3 its stiffening, s(t) = 1 unless an effect
    drifts it.
    """

    A_eff: Positive = 2.0e-4  # m^2, effective pressure area of the core's bore
    F0: float = 0.0  # N, force at x = 0, P = 0
    k1: Positive = 3000.0  # N/m
    k3: NonNegative = 2.0e6  # N/m^3
    k2: NonNegative = 1500.0  # N/m, Maxwell arm spring
    tau: Positive = 0.2  # s, Maxwell arm relaxation time


class FrictionParams(_Frozen):
    """Coulomb friction of the rig (block on rail + pulley), with optional breakaway excess."""

    F_block: NonNegative = 0.25  # N, rail friction of the block
    F_pulley: NonNegative = 0.10  # N, pulley friction referred to the block
    static_ratio: Annotated[float, Field(ge=1.0)] = 1.0  # breakaway / kinetic level

    @property
    def coulomb(self) -> float:
        return self.F_block + self.F_pulley


class ValveParams(_Frozen):
    """Supply valve and line: P follows the command through a slew-limited first-order lag."""

    tau: Positive = 0.03  # s, line/compliance time constant
    slew: Positive = 1.5e6  # Pa/s, flow-limited maximum rate of change


class RigParams(_Frozen):
    """The dynamic-loading rig of thesis Ch. 4 (eqs. 4.1, 4.2)."""

    M: Positive = 0.25  # kg, block + force plate
    m1: Positive = 0.5  # kg, hanging mass over the pulley
    g: Positive = 9.80665
    x_min: float = 0.0  # m, end stop (muscle fully retracted)
    x_max: float = 0.2  # m, end of the rail travel
    muscle: MuscleParams = MuscleParams()
    friction: FrictionParams = FrictionParams()
    valve: ValveParams = ValveParams()

    @model_validator(mode="after")
    def _travel(self) -> RigParams:
        if self.x_max <= self.x_min:
            raise ValueError(f"x_max={self.x_max} must exceed x_min={self.x_min}")
        return self


class SensorSpec(_Frozen):
    """One sensor: true value + Gaussian noise -> ADC over [lo, hi] -> engineering value."""

    lo: float
    hi: float
    bits: Annotated[int, Field(ge=2, le=24)] = 10
    noise: NonNegative = 0.0  # standard deviation, SI units

    @model_validator(mode="after")
    def _range(self) -> SensorSpec:
        if self.hi <= self.lo:
            raise ValueError(f"sensor range hi={self.hi} must exceed lo={self.lo}")
        return self

    @property
    def lsb(self) -> float:
        """Resolution: one ADC count in SI units."""
        return (self.hi - self.lo) / 2**self.bits


class Glitches(_Frozen):
    """Occasional logger faults: single-sample spikes and dropped samples (rows missing)."""

    spike_rate: Annotated[float, Field(ge=0, le=0.1)] = 0.0  # probability per sample and channel
    dropout_rate: Annotated[float, Field(ge=0, le=0.1)] = 0.0  # probability per sample


class Sensors(_Frozen):
    """The rig's sensors, at the thesis's resolutions (1171 Pa, 0.02 mm, 0.01 N per count)."""

    rate: Positive = 1000.0  # Hz
    P: SensorSpec = SensorSpec(lo=0.0, hi=1.2e6, noise=600.0)
    x: SensorSpec = SensorSpec(lo=0.0, hi=0.02048, noise=1.5e-5)
    F: SensorSpec = SensorSpec(lo=0.0, hi=10.24, noise=0.006)
    glitches: Glitches = Glitches()
