"""Data sets of the linear-motor rig: logs of the stage tracking random references.

A :class:`LinearMotorDataset` (the :class:`~hmid.simulate.dataset.RigDataset` of this rig) lists
the logs; each is integrated (:mod:`hmid.simulate.rigs.linear_motor`) and logged with channels
t, x (encoder) and u (motor force, N). Draw order from the log's generator is fixed: reference,
position noise, force noise. A written set holds, per log, its data file and truth, and one
column map ``columns-dynamic.yaml`` (no ranges: the encoder has no rails).

The logged force at t_k is the mean force actually applied over [t_k - dt/2, t_k + dt/2): with the
command held over each sample, (u[k-1] + u[k]) / 2. It is then time-aligned with the position
sample, so M a + Fv v + Fc sign(v) + offset matches it on the true motion (``balance_check``).
"""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

import numpy as np
import pandas as pd
from pydantic import Field, field_validator, model_validator

from hmid.config import NonNegative
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
from hmid.simulate.params import _Frozen
from hmid.simulate.reference import RandomReference
from hmid.simulate.rig import Trajectory, integrate
from hmid.simulate.rigs.linear_motor import (
    LinearMotor,
    LinearMotorParams,
    PDController,
    balance_residual,
)


class LinearMotorSensors(_Frozen):
    """Logging rate, the encoder and the drive's force reading."""

    rate: Annotated[float, Field(gt=0)] = 1000.0  # Hz, also the controller's rate
    encoder_step: Annotated[float, Field(gt=0)] = 1.0e-6  # m, position rounded to this
    position_noise: NonNegative = 0.0  # m, standard deviation before the encoder rounds
    force_noise: NonNegative = 0.0  # N, standard deviation on the logged force


class LinearMotorUnits(_Frozen):
    """The unit the logger writes each channel in (checked against the channel's dimension)."""

    t: str = "ms"
    x: str = "mm"
    u: str = "N"

    @model_validator(mode="after")
    def _known_units(self) -> LinearMotorUnits:
        from hmid.io.units import si_unit

        si_unit(self.t, "t")  # UnitError (a ValueError) names the problem
        si_unit(self.x, "x")
        if si_unit(self.u, "u") != "N":
            raise ValueError(f"u={self.u!r} is not a force unit; write N, kN or lbf")
        return self

    def __getitem__(self, channel: str) -> str:
        return getattr(self, channel)


class LinearMotorOutput(_Frozen):
    """How the logger writes files: format and the unit of each column."""

    format: Literal["csv", "parquet"] = "csv"
    units: LinearMotorUnits = LinearMotorUnits()


class LinearMotorLog(_Frozen):
    """One log: the stage tracks a band-limited random reference for ``duration`` seconds."""

    kind: ClassVar[str] = "dynamic"  # as the written index lists it
    name: Name
    duration: Annotated[float, Field(gt=0, le=3600)]  # s
    reference: RandomReference = RandomReference()
    seed: Annotated[int, Field(ge=0)] | None = None  # overrides the derived seed

    @model_validator(mode="after")
    def _fade_fits(self) -> LinearMotorLog:
        if self.reference.fade_in >= self.duration:
            raise ValueError(
                f"reference.fade_in={self.reference.fade_in} s must be shorter than "
                f"duration={self.duration} s"
            )
        return self


class LinearMotorDataset(RigDataset):
    """A simulated data set of the linear-motor positioning stage."""

    kind: Literal["linear_motor"] = "linear_motor"
    seed: Annotated[int, Field(ge=0)]
    stage: LinearMotorParams = LinearMotorParams()
    controller: PDController = PDController()
    sensors: LinearMotorSensors = LinearMotorSensors()
    substeps: Annotated[int, Field(ge=1, le=1000)] = 20
    output: LinearMotorOutput = LinearMotorOutput()
    logs: tuple[LinearMotorLog, ...]

    @field_validator("logs")
    @classmethod
    def _some_logs(cls, logs: tuple[LinearMotorLog, ...]) -> tuple[LinearMotorLog, ...]:
        # a validator rather than min_length, which would also fire when a log entry is invalid
        if not logs:
            raise ValueError("list at least one log")
        return logs

    @model_validator(mode="after")
    def _consistent(self) -> LinearMotorDataset:
        unique_names(self.logs)
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

    def simulate(self, spec: LinearMotorLog) -> Simulated:
        """Simulate, measure and package one log of this set."""
        seed = self.seed_for(spec)
        rng = np.random.default_rng(seed)
        sensors = self.sensors
        n = round(spec.duration * sensors.rate)
        r = spec.reference.positions(n, sensors.rate, rng)
        position_noise = sensors.position_noise * rng.standard_normal(n)
        force_noise = sensors.force_noise * rng.standard_normal(n)
        rig = LinearMotor(self.stage, self.controller, sensors.encoder_step)
        inputs = {"r": r, "position_noise": position_noise}
        traj = integrate(rig, inputs, sensors.rate, substeps=self.substeps)
        frame = pd.DataFrame({"t": traj.t, "x": traj.x_meas, "u": traj.u_mean + force_noise})
        log = Log(
            frame, source=f"simulated:{spec.name}", units={"u": "N"}, meta={"simulator_seed": seed}
        )
        return Simulated(log, traj, _truth(self, spec, seed, traj))

    def column_map(self, spec: LinearMotorLog) -> tuple[str, dict]:
        units = self.output.units
        channels = {c: {"column": column_name(c, units[c]), "unit": units[c]} for c in CHANNELS}
        return "columns-dynamic.yaml", {"delimiter": ",", "header": True, "channels": channels}

    def logged(self, channel: str, values: np.ndarray) -> np.ndarray:
        if channel != "x":
            return super().logged(channel, values)
        # whole encoder steps, converted from exact integers so the text stays short
        step = self.sensors.encoder_step
        return np.round(values / step) * from_si(np.array([step]), "x", self.output.units.x)[0]

    def truth_kind(self) -> dict[str, str]:
        return {"kind": self.kind}


#: The logged channels, in their order in a written file.
CHANNELS = ("t", "x", "u")


def _truth(config: LinearMotorDataset, spec: LinearMotorLog, seed: int, traj: Trajectory) -> dict:
    stage = config.stage
    params = {
        "stage": stage.model_dump(mode="json"),
        "controller": config.controller.model_dump(mode="json"),
        "sensors": config.sensors.model_dump(mode="json"),
        "substeps": config.substeps,
        "effects": stage.effects(),
    }
    law = {
        "M_kg": stage.M,
        "Fv_positive_Ns_per_m": stage.Fv,
        "Fv_negative_Ns_per_m": stage.Fv_neg,
        "coulomb_N": stage.Fc,
        "breakaway_N": stage.Fc * stage.static_ratio,
        "offset_N": stage.offset,
    }
    logging = (
        "u at t_k is the mean force applied over [t_k - dt/2, t_k + dt/2) = "
        "(u[k-1] + u[k]) / 2 for the zero-order-held command; x is the encoder reading at t_k"
    )
    tail = {"law_truth": law, "logging": logging, "checks": _checks(stage, traj)}
    return truth_record(config, spec, seed, params, tail)


def _checks(stage: LinearMotorParams, traj: Trajectory) -> dict:
    residual = balance_residual(stage, traj)[traj.sliding]
    moving = np.sign(traj.v[~traj.stuck])
    return {
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
    }
