"""Data sets of the Hydro Muscle rig: dynamic-loading and free-fall logs, and Ch. 2 relaxations.

A :class:`HydroMuscleDataset` (the :class:`~hmid.simulate.dataset.RigDataset` of this rig) lists
the logs; each is integrated (:mod:`hmid.simulate.rigs.hydro_muscle`) and measured by the 10-bit
sensor chain (:mod:`hmid.simulate.sensors`). A written set holds, per log, its data file and
truth; a column map per sensor set (``columns-dynamic.yaml``, ``columns-free_fall.yaml``, or
``<name>.columns.yaml`` for a log with its own sensors); and for a Ch. 2 relaxation entry its
curves (CSV), figure (PNG) and numbers (``<name>.truth.json``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import pandas as pd
from pydantic import Field, field_validator, model_validator

from hmid.config import Positive
from hmid.io.log import Log
from hmid.simulate.dataset import (
    Name,
    RigDataset,
    Simulated,
    column_name,
    from_si,
    truth_record,
    unique_names,
)
from hmid.simulate.effects import Effect, make_effect
from hmid.simulate.params import Glitches, RigParams, Sensors, SensorSpec, _Frozen
from hmid.simulate.profiles import Constant, Profile
from hmid.simulate.relaxation import RelaxationRun, write_relaxation
from hmid.simulate.rig import Trajectory, integrate
from hmid.simulate.rigs.hydro_muscle import HydroMuscle
from hmid.simulate.sensors import measure, to_values


class _LogSpec(_Frozen):
    name: Name
    duration: Annotated[float, Field(gt=0, le=3600)]  # s
    effects: tuple[dict[str, Any], ...] = ()  # undeclared extra physics, see hmid.simulate.effects
    sensors: Sensors | None = None  # overrides the data set's sensors for this log
    seed: Annotated[int, Field(ge=0)] | None = None  # overrides the derived seed

    @field_validator("effects")
    @classmethod
    def _known_effects(cls, specs):
        for spec in specs:
            make_effect(spec)  # raises a ConfigError naming the bad kind or key
        return specs

    def built_effects(self) -> tuple[Effect, ...]:
        return tuple(make_effect(spec) for spec in self.effects)


class DynamicLog(_LogSpec):
    """A dynamic-loading test (thesis Ch. 4): the muscle drives the block, pressure commanded."""

    kind: Literal["dynamic"] = "dynamic"
    profile: Profile


class FreeFallLog(_LogSpec):
    """A free-fall friction test: muscle disconnected, the hanging mass drags the block from x0."""

    kind: Literal["free_fall"] = "free_fall"
    x0: Positive = 0.15  # m, start position on the rail
    release: Annotated[float, Field(ge=0)] = 0.1  # s, the block is held until then

    @model_validator(mode="after")
    def _released_in_time(self) -> FreeFallLog:
        if self.release >= self.duration:
            raise ValueError(
                f"release={self.release} s must come before duration={self.duration} s"
            )
        return self


LogSpec = Annotated[DynamicLog | FreeFallLog | RelaxationRun, Field(discriminator="kind")]

#: Free-fall travel is ~0.15 m, beyond the dynamic tests' 20 mm span; the end stop (x = 0) sits
#: inside the span so a block at rest there is not read as saturation.
FREE_FALL_SENSORS = Sensors(x=SensorSpec(lo=-0.01, hi=0.1948, noise=1.0e-4))


class LoggerUnits(_Frozen):
    """The unit the logger writes each channel in (checked against the channel's dimension)."""

    t: str = "ms"
    P: str = "kPa"
    x: str = "mm"
    F: str = "N"

    @model_validator(mode="after")
    def _known_units(self) -> LoggerUnits:
        from hmid.io.units import si_unit

        for channel in ("t", "P", "x", "F"):
            si_unit(getattr(self, channel), channel)  # UnitError (a ValueError) names the problem
        return self

    def __getitem__(self, channel: str) -> str:
        return getattr(self, channel)


class Output(_Frozen):
    """How the logger writes files: format and the unit of each column."""

    format: Literal["csv", "parquet"] = "csv"
    units: LoggerUnits = LoggerUnits()


class HydroMuscleDataset(RigDataset):
    """A simulated data set of the Hydro Muscle rig: rig, sensors, output format and the logs."""

    seed: Annotated[int, Field(ge=0)]
    rig: RigParams = RigParams()
    sensors: Sensors = Sensors()
    free_fall_sensors: Sensors = FREE_FALL_SENSORS
    substeps: Annotated[int, Field(ge=1, le=1000)] = 20
    output: Output = Output()
    logs: tuple[LogSpec, ...]  # rig logs, and Ch. 2 relaxation runs (curves + figure)

    @model_validator(mode="after")
    def _consistent(self) -> HydroMuscleDataset:
        unique_names(self.logs)
        for spec in self.logs:
            if isinstance(spec, RelaxationRun):
                continue
            sensors = self.sensors_for(spec)
            if spec.duration * sensors.rate < 10:
                raise ValueError(f"log {spec.name!r}: duration gives fewer than 10 samples")
            if isinstance(spec, FreeFallLog) and not (
                self.rig.x_min < spec.x0 <= self.rig.x_max and sensors.x.lo < spec.x0 < sensors.x.hi
            ):
                raise ValueError(
                    f"log {spec.name!r}: x0={spec.x0} m must lie on the rail "
                    f"({self.rig.x_min}, {self.rig.x_max}] and inside the x sensor's span"
                )
        # the explicit valve and SLS steps are exact, but one substep must resolve the rig's
        # fastest mechanics (~12 Hz ringing): keep the substep well below the relaxation times
        dt_sub = 1.0 / (self.sensors.rate * self.substeps)
        if dt_sub > 0.1 * min(self.rig.muscle.tau, self.rig.valve.tau):
            raise ValueError(
                f"substep {dt_sub:.2g} s is too long for the muscle/valve time constants; "
                "raise substeps"
            )
        return self

    def sensors_for(self, spec: DynamicLog | FreeFallLog) -> Sensors:
        """The log's own sensors, or the data set's for its kind."""
        if spec.sensors is not None:
            return spec.sensors
        return self.free_fall_sensors if isinstance(spec, FreeFallLog) else self.sensors

    def simulate(self, spec: DynamicLog | FreeFallLog) -> Simulated:
        """Simulate, measure and package one log of this set."""
        return _simulate(self, spec)

    def column_map(self, spec: DynamicLog | FreeFallLog) -> tuple[str, dict]:
        channels = ("x", "F") if isinstance(spec, FreeFallLog) else ("P", "x", "F")
        mapping = column_map(self.sensors_for(spec), self.output.units, channels)
        if spec.sensors is not None:
            return f"{spec.name}.columns.yaml", mapping
        return f"columns-{spec.kind}.yaml", mapping

    def write_extra(self, spec: Any, folder: Path) -> Path | None:
        if not isinstance(spec, RelaxationRun):
            return None
        write_relaxation(spec, folder)
        return folder / f"{spec.name}.csv"


def column_map(sensors: Sensors, units: LoggerUnits, channels: tuple[str, ...]) -> dict:
    """The column map (``hmid.io.columns.ColumnMap`` schema) that reads written logs back.

    Each sensed channel carries its ADC's reachable span (lo to hi - 1 LSB) as ``range`` so the
    loader flags saturated samples.
    """
    out: dict[str, dict[str, Any]] = {
        "t": {"column": column_name("t", units["t"]), "unit": units["t"]}
    }
    for name in channels:
        spec = getattr(sensors, name)
        lo, hi = from_si(np.array([spec.lo, spec.hi - spec.lsb]), name, units[name])
        out[name] = {
            "column": column_name(name, units[name]),
            "unit": units[name],
            # rounded like the written data, so a sample at a rail compares equal to the limit
            "range": [float(f"{lo:.10g}"), float(f"{hi:.10g}")],
        }
    return {"delimiter": ",", "header": True, "channels": out}


def _trajectory(config: HydroMuscleDataset, spec, effects, t, P_cmd) -> Trajectory:
    free_fall = isinstance(spec, FreeFallLog)
    rig = HydroMuscle(
        config.rig, effects, connected=not free_fall, x0=spec.x0 if free_fall else None
    )
    inputs = {"P_cmd": P_cmd} | ({"held": t < spec.release} if free_fall else {})
    return integrate(rig, inputs, config.sensors_for(spec).rate, substeps=config.substeps)


def _simulate(config: HydroMuscleDataset, spec: DynamicLog | FreeFallLog) -> Simulated:
    seed = config.seed_for(spec)
    rng = np.random.default_rng(seed)
    free_fall = isinstance(spec, FreeFallLog)
    sensors = config.sensors_for(spec)
    n = round(spec.duration * sensors.rate)
    t = np.arange(1, n + 1) / sensors.rate
    profile = Constant(value=0.0) if isinstance(spec, FreeFallLog) else spec.profile
    effects = spec.built_effects()
    traj = _trajectory(config, spec, effects, t, profile.command(t - t[0], rng))
    rig = config.rig
    load_cell = (rig.M + rig.m1) * traj.a + rig.m1 * rig.g  # thesis eq. 4.2
    # The muscle is disconnected in a free-fall test: no pressure channel is logged.
    specs = (
        {"x": sensors.x, "F": sensors.F}
        if free_fall
        else {"P": sensors.P, "x": sensors.x, "F": sensors.F}
    )
    counts, keep = measure(
        t, {"P": traj.P, "x": traj.x, "F": load_cell}, specs, sensors.glitches, effects, rng
    )
    frame = pd.DataFrame({"t": t} | {k: to_values(c, specs[k]) for k, c in counts.items()})
    log = Log(frame.loc[keep], source=f"simulated:{spec.name}", meta={"simulator_seed": seed})
    truth = _truth(config, spec, seed, sensors, effects, traj, counts, keep)
    return Simulated(log=log, trajectory=traj, truth=truth)


def _truth(config, spec, seed, sensors, effects, traj, counts, keep) -> dict[str, Any]:
    top = {k: 2 ** getattr(sensors, k).bits - 1 for k in counts}
    rails = {k: int(np.sum((c == 0) | (c == top[k]))) for k, c in counts.items()}
    friction = config.rig.friction
    params = {
        "rig": config.rig.model_dump(mode="json"),
        "sensors": sensors.model_dump(mode="json"),
        "substeps": config.substeps,
        "effects": [{"kind": e.kind, **e.params()} for e in effects],
    }
    checks = {
        "min_string_tension_N": float(np.min(traj.tension_min)),
        "stuck_fraction": float(np.mean(traj.stuck)),
        "samples_at_adc_rails": rails,
        "dropped_samples": int(np.sum(~keep)),
        "x_range_m": [float(traj.x.min()), float(traj.x.max())],
        "P_range_Pa": [float(traj.P.min()), float(traj.P.max())],
    }
    law = {"coulomb_N": friction.coulomb, "breakaway_N": friction.coulomb * friction.static_ratio}
    return truth_record(config, spec, seed, params, {"friction_truth": law, "checks": checks})


__all__ = [
    "FREE_FALL_SENSORS",
    "DynamicLog",
    "FreeFallLog",
    "Glitches",
    "HydroMuscleDataset",
    "LoggerUnits",
    "Output",
    "column_map",
]
