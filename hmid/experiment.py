"""The experiment config: which logs, read how, on which rig, processed with which strategies.

Paths in the config are relative to the config file's folder. Later stages (friction, model
families, comparison) add their own sections here as typed models.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, SerializeAsAny, field_validator

from hmid.config import load_yaml_model
from hmid.errors import ConfigError
from hmid.families import FamilySpec, make_family
from hmid.io.log import RigConstants
from hmid.loop.config import LoopSpec
from hmid.signal import (
    Differentiator,
    MovingAverage,
    SavitzkyGolay,
    SmoothedFiniteDifference,
    Smoother,
    Window,
)
from hmid.split import SplitSpec

Positive = Annotated[float, Field(gt=0)]


class _Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class RigSection(_Frozen):
    """Rig constants of thesis Ch. 4 (SI units) and where the muscle force is read from."""

    M: Positive  # kg, block + force plate
    m1: Positive  # kg, hanging mass
    g: Positive = 9.80665
    # load_cell: F_m = F_l + friction (eqs. 4.1-4.2); acceleration: no load cell (eq. 5.1)
    force_source: Literal["load_cell", "acceleration"] = "load_cell"

    def constants(self) -> RigConstants:
        return RigConstants(M=self.M, m1=self.m1, g=self.g)


class LogEntry(_Frozen):
    """One log file, the column map that reads it, and its role in the experiment."""

    path: Path
    columns: Path
    role: Literal["dynamic", "free_fall"]


class MovingAverageSpec(_Frozen):
    """Moving-average smoother of P, x and F; the window in seconds is resolved per log."""

    kind: Literal["moving_average"] = "moving_average"
    window_s: Positive = 0.01
    mode: Literal["centred", "causal"] = "centred"

    def build(self) -> Smoother:
        return MovingAverage(Window(seconds=self.window_s), mode=self.mode, edge="shrink")


class SavitzkyGolaySpec(_Frozen):
    kind: Literal["savitzky_golay"] = "savitzky_golay"
    window_s: Positive = 0.05
    polyorder: Annotated[int, Field(ge=2, le=7)] = 3

    def build(self) -> Differentiator:
        return SavitzkyGolay(Window(seconds=self.window_s), polyorder=self.polyorder)


class SmoothedDifferenceSpec(_Frozen):
    kind: Literal["smoothed_difference"] = "smoothed_difference"
    window_s: Positive = 0.03

    def build(self) -> Differentiator:
        return SmoothedFiniteDifference(MovingAverage(Window(seconds=self.window_s)))


class DenoiseSection(_Frozen):
    """How signals are smoothed and how velocity and acceleration are estimated from x."""

    smoother: MovingAverageSpec = MovingAverageSpec()
    derivative: Annotated[
        SavitzkyGolaySpec | SmoothedDifferenceSpec, Field(discriminator="kind")
    ] = SavitzkyGolaySpec()


class FrictionSection(_Frozen):
    """Friction identification from the free-fall logs and its use in force reconstruction."""

    model: Literal["coulomb", "coulomb_viscous"] = "coulomb"
    v_min: Positive = 0.02  # m/s, sliding segment of a free fall: |v| above this
    confidence: Annotated[float, Field(gt=0.5, lt=1)] = 0.95
    v_deadband: Annotated[float, Field(ge=0)] = 0.002  # m/s, |v| below: stuck, friction unknown


class FitSection(_Frozen):
    """Which reconstructed samples the model families are fitted on."""

    exclude_stuck: bool = True  # static friction is indeterminate while the block sticks


class ExperimentConfig(_Frozen):
    """A whole experiment; ``base_dir`` (the config's folder) anchors relative paths."""

    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")]
    seed: Annotated[int, Field(ge=0)]
    rig: RigSection
    logs: Annotated[tuple[LogEntry, ...], Field(min_length=1)]
    denoise: DenoiseSection = DenoiseSection()
    friction: FrictionSection = FrictionSection()
    split: SplitSpec = SplitSpec()
    fit: FitSection = FitSection()
    models: tuple[SerializeAsAny[FamilySpec], ...] = ()
    loop: LoopSpec | None = None  # close the loop on the residual (hmid.loop); off if absent
    base_dir: Path = Path(".")

    @field_validator("models", mode="before")
    @classmethod
    def _families(cls, specs):
        return tuple(make_family(spec, f"models.{i}") for i, spec in enumerate(specs or ()))

    def logs_with_role(self, role: str) -> tuple[LogEntry, ...]:
        return tuple(entry for entry in self.logs if entry.role == role)

    def resolve(self, path: Path) -> Path:
        return path if path.is_absolute() else Path(os.path.normpath(self.base_dir / path))


def load_experiment(path: str | Path) -> ExperimentConfig:
    """Read and validate an experiment config; every listed file must exist."""
    path = Path(path)
    config = load_yaml_model(path, ExperimentConfig)
    config = config.model_copy(update={"base_dir": path.parent})
    for i, entry in enumerate(config.logs):
        for key in ("path", "columns"):
            target = config.resolve(getattr(entry, key))
            if not target.is_file():
                raise ConfigError(
                    f"{path}: key 'logs.{i}.{key}': file {target} does not exist "
                    f"(paths are relative to the config's folder {path.parent})"
                )
    return config
