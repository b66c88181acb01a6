"""Simulated data sets of the linear-motor stage: a config lists logs, hmid simulates them.

Each log is simulated from its own seed (the data set's seed mixed with the log's name, so adding
or reordering logs does not change the others) and returned as a :class:`~hmid.io.log.Log` with
channels t, x (encoder) and u (motor force, N) plus a ground-truth record that never enters the
log. Draw order from the log's generator is fixed: reference, position noise, force noise.

The logged force at t_k is the mean force actually applied over [t_k - dt/2, t_k + dt/2): with the
command held over each sample, (u[k-1] + u[k]) / 2. It is then time-aligned with the position
sample, so M a + Fv v + Fc sign(v) + offset matches it on the true motion (``balance_check``).
"""

from __future__ import annotations

import zlib
from typing import Annotated, Any, Literal, NamedTuple

import numpy as np
import pandas as pd
from pydantic import Field, field_validator, model_validator

from hmid.io.log import Log
from hmid.simulate.dataset import Name
from hmid.simulate.params import _Frozen
from hmid.simulate.reference import Reference
from hmid.simulate.stage import (
    PDController,
    StageParams,
    Trajectory,
    balance_residual,
    integrate,
)

NonNegative = Annotated[float, Field(ge=0)]


class StageSensors(_Frozen):
    """Logging rate, the encoder and the drive's force reading."""

    rate: Annotated[float, Field(gt=0)] = 1000.0  # Hz, also the controller's rate
    encoder_step: Annotated[float, Field(gt=0)] = 1.0e-6  # m, position rounded to this
    position_noise: NonNegative = 0.0  # m, standard deviation before the encoder rounds
    force_noise: NonNegative = 0.0  # N, standard deviation on the logged force


class StageUnits(_Frozen):
    """The unit the logger writes each channel in (checked against the channel's dimension)."""

    t: str = "ms"
    x: str = "mm"
    u: str = "N"

    @model_validator(mode="after")
    def _known_units(self) -> StageUnits:
        from hmid.io.units import si_unit

        si_unit(self.t, "t")  # UnitError (a ValueError) names the problem
        si_unit(self.x, "x")
        if si_unit(self.u, "u") != "N":
            raise ValueError(f"u={self.u!r} is not a force unit; write N, kN or lbf")
        return self

    def __getitem__(self, channel: str) -> str:
        return getattr(self, channel)


class StageOutput(_Frozen):
    """How the logger writes files: format and the unit of each column."""

    format: Literal["csv", "parquet"] = "csv"
    units: StageUnits = StageUnits()


class StageLog(_Frozen):
    """One log: the stage tracks a band-limited random reference for ``duration`` seconds."""

    name: Name
    duration: Annotated[float, Field(gt=0, le=3600)]  # s
    reference: Reference = Reference()
    seed: Annotated[int, Field(ge=0)] | None = None  # overrides the derived seed

    @model_validator(mode="after")
    def _fade_fits(self) -> StageLog:
        if self.reference.fade_in >= self.duration:
            raise ValueError(
                f"reference.fade_in={self.reference.fade_in} s must be shorter than "
                f"duration={self.duration} s"
            )
        return self


class StageDatasetConfig(_Frozen):
    """A simulated data set of the linear-motor positioning stage."""

    kind: Literal["linear_motor"] = "linear_motor"
    seed: Annotated[int, Field(ge=0)]
    stage: StageParams = StageParams()
    controller: PDController = PDController()
    sensors: StageSensors = StageSensors()
    substeps: Annotated[int, Field(ge=1, le=1000)] = 20
    output: StageOutput = StageOutput()
    logs: tuple[StageLog, ...]

    @field_validator("logs")
    @classmethod
    def _some_logs(cls, logs: tuple[StageLog, ...]) -> tuple[StageLog, ...]:
        # a validator rather than min_length, which would also fire when a log entry is invalid
        if not logs:
            raise ValueError("list at least one log")
        return logs

    @model_validator(mode="after")
    def _consistent(self) -> StageDatasetConfig:
        names = [log.name for log in self.logs]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise ValueError(f"log names must be unique; repeated: {dupes}")
        nyquist = self.sensors.rate / 2
        if self.controller.derivative_cutoff_hz >= nyquist:
            raise ValueError(
                f"controller.derivative_cutoff_hz={self.controller.derivative_cutoff_hz} must be "
                f"below half the sampling rate ({nyquist:g} Hz)"
            )
        for i, spec in enumerate(self.logs):
            if spec.duration * self.sensors.rate < 10:
                raise ValueError(f"logs.{i} ({spec.name!r}): duration gives fewer than 10 samples")
            if spec.reference.cutoff_hz >= nyquist:
                raise ValueError(
                    f"logs.{i}.reference.cutoff_hz={spec.reference.cutoff_hz} must be below half "
                    f"the sampling rate ({nyquist:g} Hz)"
                )
        return self

    def seed_for(self, spec: StageLog) -> int:
        return spec.seed if spec.seed is not None else self.seed ^ zlib.crc32(spec.name.encode())


class SimulatedStage(NamedTuple):
    """One simulated log with its true trajectory and the truth record."""

    log: Log
    trajectory: Trajectory
    truth: dict[str, Any]


def simulate_stage_log(config: StageDatasetConfig, spec: StageLog) -> SimulatedStage:
    """Simulate, measure and package one log of ``config``."""
    seed = config.seed_for(spec)
    rng = np.random.default_rng(seed)
    sensors = config.sensors
    n = round(spec.duration * sensors.rate)
    r = spec.reference.positions(n, sensors.rate, rng)
    position_noise = sensors.position_noise * rng.standard_normal(n)
    force_noise = sensors.force_noise * rng.standard_normal(n)
    traj = integrate(
        config.stage, config.controller, r, sensors.rate, encoder_step=sensors.encoder_step,
        position_noise=position_noise, substeps=config.substeps,
    )  # fmt: skip
    frame = pd.DataFrame({"t": traj.t, "x": traj.x_meas, "u": traj.u_mean + force_noise})
    log = Log(
        frame, source=f"simulated:{spec.name}", units={"u": "N"}, meta={"simulator_seed": seed}
    )
    return SimulatedStage(log, traj, _truth(config, spec, seed, traj))


def _truth(config: StageDatasetConfig, spec: StageLog, seed: int, traj: Trajectory) -> dict:
    from hmid import __version__

    stage = config.stage
    residual = balance_residual(stage, traj)[traj.sliding]
    moving = np.sign(traj.v[~traj.stuck])
    return {
        "generator": f"hmid {__version__}",
        "kind": config.kind,
        "name": spec.name,
        "seed": seed,
        "log": spec.model_dump(mode="json"),
        "stage": stage.model_dump(mode="json"),
        "controller": config.controller.model_dump(mode="json"),
        "sensors": config.sensors.model_dump(mode="json"),
        "substeps": config.substeps,
        "effects": stage.effects(),
        "law_truth": {
            "M_kg": stage.M,
            "Fv_positive_Ns_per_m": stage.Fv,
            "Fv_negative_Ns_per_m": stage.Fv_neg,
            "coulomb_N": stage.Fc,
            "breakaway_N": stage.Fc * stage.static_ratio,
            "offset_N": stage.offset,
        },
        "logging": "u at t_k is the mean force applied over [t_k - dt/2, t_k + dt/2) = "
        "(u[k-1] + u[k]) / 2 for the zero-order-held command; x is the encoder reading at t_k",
        "checks": {
            "stuck_fraction": float(np.mean(traj.stuck)),
            "sliding_fraction": float(np.mean(traj.sliding)),
            "stops": int(np.sum(traj.stuck[1:] & ~traj.stuck[:-1])),
            "direction_reversals": int(np.sum(moving[1:] != moving[:-1])),
            "tracking_error_rms_m": float(np.sqrt(np.mean((traj.r - traj.x) ** 2))),
            "tracking_error_max_m": float(np.max(np.abs(traj.r - traj.x))),
            "reference_rms_m": float(np.sqrt(np.mean(traj.r**2))),
            "x_range_m": [float(traj.x.min()), float(traj.x.max())],
            "max_abs_v_m_per_s": float(np.max(np.abs(traj.v))),
            "max_abs_u_N": float(np.max(np.abs(traj.u))),
            "rms_u_N": float(np.sqrt(np.mean(traj.u**2))),
            # u_log - (M a + Fv v + Fc sign(v) + offset) on the true motion at sliding samples
            "balance_check": {
                "rms_N": float(np.sqrt(np.mean(residual**2))) if residual.size else None,
                "max_abs_N": float(np.max(np.abs(residual))) if residual.size else None,
                "samples": int(residual.size),
            },
        },
    }
