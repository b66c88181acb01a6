"""The seam between the controllers and a simulated rig: what a plant adaptor provides.

The controllers, experiments, tuning and robustness code never touch a rig's physics: they ask
a :class:`Plant` for the rig to run (:class:`~hmid.simulate.rig.SimulatedRig`, driven by
:func:`~hmid.simulate.rig.closed_loop`), the output to track and its sensor, the rig's inputs
and outputs at the start, the feed-forward an identified model gives along a reference, and the
plant linearised for the tuning rule. :class:`MuscleRig` adapts the thesis Ch. 4 rig, for force
tracking (block clamped: the muscle's force at a fixed length) and for position tracking.

A new rig is a new adaptor of about this size: the multi-fibre ankle's is
:class:`hmid.control.ankle.AnkleRig` (the potentiometer's angle tracked, one pressure to the
engaged fibres, the joint's torque balance inverted and linearised).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any, Literal, Protocol

import numpy as np

from hmid.control.actuation import Actuation, Proportional
from hmid.control.inverse import ForceLaw, lead
from hmid.control.references import Reference
from hmid.simulate.effects import Effect
from hmid.simulate.params import MuscleParams, RigParams, Sensors
from hmid.simulate.rig import SimulatedRig, Trajectory
from hmid.simulate.rigs.hydro_muscle import HydroMuscle
from hmid.simulate.valves import OnOffValves


class Plant(Protocol):
    """What the controllers need of a rig (an adaptor per rig; see the module's docstring)."""

    @property
    def task(self) -> str: ...  # what is tracked, in words ("force", "position", "angle")

    @property
    def tracked(self) -> str: ...  # the rig output the controller reads

    @property
    def unit(self) -> str: ...

    @property
    def resolution(self) -> float: ...  # the tracked output's sensor step

    @property
    def noise(self) -> float: ...  # its sensor noise (standard deviation)

    @property
    def rate(self) -> float: ...  # Hz, the controller's and the log's

    @property
    def substeps(self) -> int: ...  # the rig's integration steps per sample

    @property
    def actuation(self) -> Any: ...  # one effort -> the rig's input commands (an Actuation)

    @property
    def limits(self) -> tuple[float, float]: ...  # the effort the valves can give (Pa)

    def rig(self, effort0: float = 0.0) -> SimulatedRig: ...  # at rest with the effort effort0

    def inputs(self, n: int, effort0: float) -> dict[str, np.ndarray]: ...

    def outputs(self, effort0: float) -> dict[str, float]: ...

    def commanded(
        self, traj: Trajectory, commands: Mapping[str, np.ndarray], ff: Any
    ) -> tuple: ...  # (effort per command, the pressure, the on/off valves' commands or None)

    # ``law``: the plant's model (a ForceLaw; for the ankle the fibres' laws)
    def demand(self, law: Any, ref: Reference) -> np.ndarray: ...

    def feedforward(self, law: Any, ref: Reference, valve_tau: float) -> np.ndarray: ...

    def hold(self, law: Any, ref: Reference) -> float: ...

    def linear(self, law: Any, ref: Reference, valve_tau: float) -> Any: ...

    def with_effects(self, effects: tuple[Effect, ...]) -> Plant: ...

    def with_on_off(self, valves: OnOffValves, actuation: Actuation) -> Plant: ...


#: The Ch. 4 rig's outputs (what the controller may read) before the first sample


@dataclass(frozen=True)
class MuscleRig:
    """The thesis Ch. 4 rig as a plant: ``task`` "force" (the block clamped at ``hold_at``,
    the muscle force tracked; the load cell's 0.01 N) or "position" (the block's elongation
    tracked; the IR sensor's 0.02 mm)."""

    params: RigParams
    task: Literal["force", "position"]
    effects: tuple[Effect, ...] = ()
    valves: OnOffValves | None = None
    actuation: Actuation = field(default_factory=Proportional)
    hold_at: float = 0.006  # m, where the force task clamps the block
    rate: float = 1000.0
    noise: float = 0.0
    substeps: int = 20
    sensor_step: float | None = None  # None: the rig's sensor's resolution; 0: exact

    @property
    def tracked(self) -> str:
        return "F_m" if self.task == "force" else "x"

    @property
    def unit(self) -> str:
        return "N" if self.task == "force" else "m"

    @property
    def resolution(self) -> float:
        if self.sensor_step is not None:
            return self.sensor_step
        sensors = Sensors()  # the demo's 10-bit sensors: 0.01 N, 0.02 mm
        return sensors.F.lsb if self.task == "force" else sensors.x.lsb

    @property
    def limits(self) -> tuple[float, float]:
        """(lowest, highest) pressure the valves give: the proportional valve's command range,
        or vented to the on/off valves' supply."""
        if self.valves is not None:
            return 0.0, float(self.valves.supply)
        actuation = self.actuation
        assert isinstance(actuation, Proportional)
        return float(actuation.lowest), float(actuation.highest)

    def rig(self, effort0: float = 0.0) -> HydroMuscle:
        x0 = self.hold_at if self.task == "force" else None
        return HydroMuscle(self.params, self.effects, x0=x0, valves=self.valves)

    def inputs(self, n: int, effort0: float) -> dict[str, np.ndarray]:
        out = {"P_cmd": np.full(n, float(effort0)), "valve": np.zeros(n)}
        return out | {"held": np.full(n, self.task == "force")}

    def outputs(self, effort0: float) -> dict[str, float]:
        """What the controller reads before the first sample: the rig at rest at the start."""
        return self.rig().initial_outputs(self.inputs(2, effort0), self.rate)

    def commanded(self, traj: Trajectory, commands: Mapping[str, np.ndarray], ff: Any) -> tuple:
        """(the effort per command, the pressure, the on/off valve's commands or None)."""
        effort = commands.get("P_cmd", ff.commands)
        return effort, traj.signals.get("P", np.full(len(traj.t), np.nan)), commands.get("valve")

    def demand(self, law: ForceLaw, ref: Reference) -> np.ndarray:
        """The pressure the model says the reference needs, at the sample instants (the
        inverse dynamics)."""
        if self.task == "force":
            x = np.full_like(ref.y, self.hold_at)
            zero = np.zeros_like(ref.y)
            return law.pressure_for(ref.y, x, zero, np.zeros((law.eq.n_memory, len(ref.y))))
        return law.pressure_for_motion(ref.t, ref.y, ref.dy, ref.ddy)

    def feedforward(self, law: ForceLaw, ref: Reference, valve_tau: float) -> np.ndarray:
        """The model's pressure along the reference, through the valve's inverted lag (one
        command per sample of the reference but the last); on/off valves are switched on the
        pressure itself, so they get it as it is."""
        P = self.demand(law, ref)
        if self.valves is not None:
            return P[:-1]
        return lead(P, valve_tau, 1.0 / self.rate)

    def hold(self, law: ForceLaw, ref: Reference) -> float:
        """The pressure that holds the reference's start (PD alone's operating point)."""
        start = replace(ref, t=ref.t[:2], y=np.full(2, ref.y[0]), dy=np.zeros(2),
                        ddy=np.zeros(2))  # fmt: skip
        return float(self.demand(law, start)[0])

    def linear(self, law: ForceLaw, ref: Reference, valve_tau: float) -> Any:
        """The plant linearised at the reference's start (``control.StateSpace``, continuous:
        pressure command -> tracked output), the valve a first-order lag; friction, having no
        linear part, left out."""
        import control

        P0 = self.hold(law, ref)
        if self.task == "force":
            at, zero = np.array([self.hold_at]), np.zeros(1)
            gain = law.coefficients(at, zero, np.zeros((law.eq.n_memory, 1)))[1][0]
            return control.ss([[-1 / valve_tau]], [[1 / valve_tau]], [[gain]], [[0.0]])
        eq = law.eq
        mass = sum(c for kind, _, c in eq.lhs if kind == "accel")
        m = eq.n_memory
        arms = {data[0]: (data[1], c) for kind, data, c in eq.rhs if kind == "memory"}

        def force(x: float, v: float, P: float) -> float:
            return float(law.force(np.array([x]), np.array([v]), P, np.zeros((m, 1)))[0])

        x0, h = float(ref.y[0]), 1e-7
        dx = (force(x0 + h, 0, P0) - force(x0 - h, 0, P0)) / (2 * h)
        dv = (force(x0, 1e-4, P0) - force(x0, -1e-4, P0)) / 2e-4
        dP = (force(x0, 0, P0 + 1.0) - force(x0, 0, P0 - 1.0)) / 2.0
        n = 3 + m  # x, v, the memory arms, P
        A = np.zeros((n, n))
        A[0, 1] = 1.0
        A[1, 0], A[1, 1], A[1, n - 1] = dx / mass, dv / mass, dP / mass
        for arm, (tau, c) in arms.items():
            A[1, 2 + arm] = c / mass
            A[2 + arm, 2 + arm], A[2 + arm, 1] = -1 / tau, 1.0
        return lagged(A, valve_tau)

    def with_muscle(self, muscle: MuscleParams) -> MuscleRig:
        return replace(self, params=self.params.model_copy(update={"muscle": muscle}))

    def with_effects(self, effects: tuple[Effect, ...]) -> MuscleRig:
        return replace(self, effects=tuple(effects))

    def with_on_off(self, valves: OnOffValves, actuation: Actuation) -> MuscleRig:
        return replace(self, valves=valves, actuation=actuation)


def lagged(A: np.ndarray, valve_tau: float) -> Any:
    """The linearised plant as python-control's state space: ``A``'s mechanical rows, its last
    state the pressure, which follows the command through the valve's first-order lag; the
    output is the first state (the tracked position or angle)."""
    import control

    n = len(A)
    A = A.copy()
    A[n - 1, n - 1] = -1 / valve_tau
    B = np.zeros((n, 1))
    B[n - 1, 0] = 1 / valve_tau
    C = np.zeros((1, n))
    C[0, 0] = 1.0
    return control.ss(A, B, C, np.zeros((1, 1)))
