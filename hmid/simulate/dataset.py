"""Simulated data sets: a config lists logs (dynamic-loading and free-fall), hmid writes them.

Each log is simulated from its own seed (the data set's seed mixed with the log's name, so adding
or reordering logs does not change the others), measured by the sensor chain, and returned as a
:class:`~hmid.io.log.Log` in SI units plus a ground-truth record. The truth never goes into the log
that the pipeline reads; :func:`write_dataset` puts it in ``<name>.truth.json`` beside the data.
"""

from __future__ import annotations

import zlib
from typing import Annotated, Any, Literal

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from hmid.io.log import Log
from hmid.simulate.effects import Effect, make_effect
from hmid.simulate.params import Glitches, RigParams, Sensors, SensorSpec
from hmid.simulate.profiles import Constant, Profile
from hmid.simulate.relaxation import RelaxationRun
from hmid.simulate.rig import Trajectory, integrate
from hmid.simulate.sensors import measure, to_values

Name = Annotated[str, Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$", max_length=80)]
Positive = Annotated[float, Field(gt=0)]


class _Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


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


class DatasetConfig(_Frozen):
    """A simulated data set: rig, sensors, output format and the logs to generate."""

    seed: Annotated[int, Field(ge=0)]
    rig: RigParams = RigParams()
    sensors: Sensors = Sensors()
    free_fall_sensors: Sensors = FREE_FALL_SENSORS
    substeps: Annotated[int, Field(ge=1, le=1000)] = 20
    output: Output = Output()
    logs: tuple[LogSpec, ...]  # rig logs, and Ch. 2 relaxation runs (curves + figure)

    @model_validator(mode="after")
    def _consistent(self) -> DatasetConfig:
        names = [log.name for log in self.logs]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise ValueError(f"log names must be unique; repeated: {dupes}")
        for spec in self.logs:
            if isinstance(spec, RelaxationRun):
                continue
            sensors = spec.sensors or (
                self.free_fall_sensors if isinstance(spec, FreeFallLog) else self.sensors
            )
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

    def seed_for(self, spec: DynamicLog | FreeFallLog) -> int:
        return spec.seed if spec.seed is not None else self.seed ^ zlib.crc32(spec.name.encode())


class Simulated(BaseModel):
    """One simulated log with the truth it came from."""

    model_config = ConfigDict(arbitrary_types_allowed=True, frozen=True)

    log: Log
    trajectory: Trajectory
    truth: dict[str, Any]


def simulate_log(config: DatasetConfig, spec: DynamicLog | FreeFallLog) -> Simulated:
    """Simulate, measure and package one log of ``config``."""
    seed = config.seed_for(spec)
    rng = np.random.default_rng(seed)
    free_fall = isinstance(spec, FreeFallLog)
    sensors = spec.sensors or (config.free_fall_sensors if free_fall else config.sensors)
    n = round(spec.duration * sensors.rate)
    t = np.arange(1, n + 1) / sensors.rate
    profile = Constant(value=0.0) if free_fall else spec.profile
    P_cmd = profile.command(t - t[0], rng)
    effects = spec.built_effects()
    traj = integrate(
        config.rig, P_cmd, sensors.rate, effects=effects, connected=not free_fall,
        x0=spec.x0 if free_fall else None, held=(t < spec.release) if free_fall else None,
        substeps=config.substeps,
    )  # fmt: skip
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
    log = Log(
        frame.loc[keep],
        source=f"simulated:{spec.name}",
        meta={"simulator_seed": seed},
    )
    truth = _truth(config, spec, seed, sensors, effects, traj, counts, keep)
    return Simulated(log=log, trajectory=traj, truth=truth)


def _truth(config, spec, seed, sensors, effects, traj, counts, keep) -> dict[str, Any]:
    from hmid import __version__

    top = {k: 2 ** getattr(sensors, k).bits - 1 for k in counts}
    rails = {k: int(np.sum((c == 0) | (c == top[k]))) for k, c in counts.items()}
    friction = config.rig.friction
    return {
        "generator": f"hmid {__version__}",
        "name": spec.name,
        "seed": seed,
        "log": spec.model_dump(mode="json"),
        "rig": config.rig.model_dump(mode="json"),
        "sensors": sensors.model_dump(mode="json"),
        "substeps": config.substeps,
        "effects": [{"kind": e.kind, **e.params()} for e in effects],
        "friction_truth": {
            "coulomb_N": friction.coulomb,
            "breakaway_N": friction.coulomb * friction.static_ratio,
        },
        "checks": {
            "min_string_tension_N": float(np.min(traj.tension_min)),
            "stuck_fraction": float(np.mean(traj.stuck)),
            "samples_at_adc_rails": rails,
            "dropped_samples": int(np.sum(~keep)),
            "x_range_m": [float(traj.x.min()), float(traj.x.max())],
            "P_range_Pa": [float(traj.P.min()), float(traj.P.max())],
        },
    }


__all__ = [
    "FREE_FALL_SENSORS",
    "DatasetConfig",
    "DynamicLog",
    "FreeFallLog",
    "Glitches",
    "Output",
    "Simulated",
    "simulate_log",
]
