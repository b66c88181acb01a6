"""The bionic ankle of thesis Ch. 6 as typed, frozen configs: the foot, the joint, the fibres.

Frame: the shank's, SI units, x anterior (toward the toes), y up, the joint at the origin. The
angle ``theta`` is positive in plantarflexion (toes down) and zero with the foot square to the
shank; a point ``p`` of the foot (given in the foot's frame, which is the shank's at theta = 0)
sits at ``R(-theta) p``. The range of motion is the thesis's: 20 deg dorsiflexion, 40 deg
plantarflexion (end stops).

Each fibre is a Hydro Muscle of the simulator's model with parameters from its build
(:class:`~hmid.simulate.specs.MuscleSpec`); a straight line (latex core plus an inextensible
tendon) from its origin on the shank to its insertion on the foot. How a fibre is mounted sets
its relaxed length (core plus tendon): an active fibre is just taut at full dorsiflexion when it
holds the supply pressure (so pressurised fibres let the tibialis pull the foot up to the
dorsiflexion stop, and vented ones pull it down to the plantarflexion stop); a passive fibre is
just taut at its ``mount_deg``. Mounting follows the nominal build (``spec``), as a builder cuts
tendons by the design: manufactured fibres (``fibres``, e.g. drawn with
:meth:`~hmid.simulate.specs.MuscleSpec.draw`) then differ from it in force, not in tendon.

The defaults: bores from the thesis's designed forces at the supply pressure (327 N, 516 N at
600 kPa); the area factors calibrated to its measured full forces (307 N, 356 N); the heel
lever from its torque (109 N m over 1,682 N: about 0.065 m at full force); one latex stock
(2 mm wall, 1.5 MPa) for every active fibre. What follows from these is in
:mod:`hmid.simulate.ankle_ch6`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

from pydantic import Field, model_validator

from hmid.config import load_yaml_model
from hmid.simulate.params import MuscleParams, NonNegative, Positive, _Frozen
from hmid.simulate.specs import MuscleSpec
from hmid.simulate.valves import OnOffValves, ProportionalValve

Point = tuple[float, float]

#: The supply pressure behind every inlet valve (Pa, gauge), the valves' default.
SUPPLY = 6.0e5
#: The designed full forces of thesis Ch. 6 (N): the bore's area at the supply pressure.
DESIGNED = {"gastrocnemius": 327.0, "soleus": 516.0}
#: The measured full forces of thesis Ch. 6 (N): what the area factors are calibrated to.
MEASURED = {"gastrocnemius": 307.0, "soleus": 356.0}


def _bore(force: float) -> float:
    """The bore diameter (m) whose area at the supply pressure carries ``force``."""
    return math.sqrt(4 * force / (math.pi * SUPPLY))


def _active(name: str, length: float) -> MuscleSpec:
    bore = _bore(DESIGNED[name])
    return MuscleSpec(
        length=length,
        inner_diameter=bore,
        outer_diameter=bore + 2 * 0.002,  # one latex stock: a 2 mm wall
        area_factor=MEASURED[name] / DESIGNED[name],  # the calibration
    )


class FibreGroup(_Frozen):
    """The fibres of one muscle: how many, their build, where they attach (m)."""

    count: Annotated[int, Field(ge=1, le=5)]
    spec: MuscleSpec
    origin: Point  # on the shank
    insertion: Point  # on the foot, in the foot's frame
    mount_deg: float | None = None  # passive fibres: the angle at which they are just taut

    def designed_force(self, supply: float) -> float:
        """The bore's area times the supply pressure (N): the force the design promises."""
        return self.spec.bore_area * supply


class Potentiometer(_Frozen):
    """The angle sensor: a pot of ``span_deg`` electrical travel read by a ``bits`` ADC."""

    span_deg: Positive = 300.0
    bits: Annotated[int, Field(ge=4, le=24)] = 10

    @property
    def lsb(self) -> float:
        """One count (rad)."""
        return math.radians(self.span_deg) / 2**self.bits


GASTROCNEMIUS = FibreGroup(
    count=2, spec=_active("gastrocnemius", 0.12), origin=(-0.03, 0.45), insertion=(-0.073, -0.003)
)
SOLEUS = FibreGroup(
    count=3, spec=_active("soleus", 0.12), origin=(-0.04, 0.30), insertion=(-0.073, -0.003)
)
TIBIALIS = FibreGroup(
    count=3,
    spec=MuscleSpec(length=0.20, inner_diameter=0.008, outer_diameter=0.011),
    origin=(0.03, 0.30),
    insertion=(0.055, -0.035),
    mount_deg=-45.0,
)


class AnkleParams(_Frozen):
    """The planar one-degree-of-freedom ankle of thesis Ch. 6 (SI units; angles in degrees)."""

    foot_mass: Positive = 1.0  # kg
    foot_inertia: Positive = 0.01  # kg m^2, about the joint
    foot_com: Point = (0.05, -0.03)  # m, foot frame
    hook: Point = (-0.07, -0.03)  # m, foot frame: where a mass hangs ("on the back": the heel)
    damping: NonNegative = 0.3  # N m s/rad, joint viscous damping
    coulomb: NonNegative = 0.05  # N m, joint Coulomb friction (stick-slip)
    static_ratio: Annotated[float, Field(ge=1.0)] = 1.2  # breakaway / Coulomb level
    dorsiflexion_deg: Positive = 20.0  # end stop
    plantarflexion_deg: Positive = 40.0  # end stop
    g: Positive = 9.80665
    supply: Positive = SUPPLY  # Pa, the mounting pressure (the on/off valves' supply)
    valve: OnOffValves | ProportionalValve = OnOffValves(supply=SUPPLY)
    gastrocnemius: FibreGroup = GASTROCNEMIUS
    soleus: FibreGroup = SOLEUS
    tibialis: FibreGroup = TIBIALIS  # passive
    potentiometer: Potentiometer = Potentiometer()
    fibres: tuple[MuscleParams, ...] | None = None  # manufactured fibres, in fibre order

    @model_validator(mode="after")
    def _consistent(self) -> AnkleParams:
        if isinstance(self.valve, OnOffValves) and self.valve.supply != self.supply:
            raise ValueError(
                f"valve.supply={self.valve.supply} must equal supply={self.supply} "
                "(the fibres are mounted at the supply pressure)"
            )
        if self.tibialis.mount_deg is None:
            raise ValueError("tibialis.mount_deg: a passive fibre needs its mounting angle")
        n = self.n_fibres
        if self.fibres is not None and len(self.fibres) != n:
            raise ValueError(f"fibres: {len(self.fibres)} given, the ankle has {n}")
        return self

    @property
    def groups(self) -> dict[str, FibreGroup]:
        """The muscles in fibre order: the active ones first."""
        return {"gastrocnemius": self.gastrocnemius, "soleus": self.soleus,
                "tibialis": self.tibialis}  # fmt: skip

    @property
    def n_active(self) -> int:
        return self.gastrocnemius.count + self.soleus.count

    @property
    def n_fibres(self) -> int:
        return self.n_active + self.tibialis.count

    @property
    def fibre_names(self) -> tuple[str, ...]:
        """'gastrocnemius 1', ..., 'tibialis 3': the order of every per-fibre array."""
        return tuple(f"{m} {i + 1}" for m, g in self.groups.items() for i in range(g.count))

    @property
    def theta_range(self) -> tuple[float, float]:
        """(full dorsiflexion, full plantarflexion) in rad."""
        return -math.radians(self.dorsiflexion_deg), math.radians(self.plantarflexion_deg)

    def muscles(self) -> tuple[MuscleParams, ...]:
        """Each fibre's parameters: the manufactured ones if given, else the build's."""
        if self.fibres is not None:
            return self.fibres
        return tuple(g.spec.params() for g in self.groups.values() for _ in range(g.count))


def load_ankle_params(path: str | Path) -> AnkleParams:
    """An ankle plant from YAML (``configs/control/ankle-plant.yaml``); unknown keys and bad
    values are one-line ConfigErrors naming the key."""
    return load_yaml_model(path, AnkleParams, "ankle plant config")
