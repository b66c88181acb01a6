"""The experiment config: which logs, read how, on which rig, processed with which strategies.

One model for every command (``run``, ``summary``, ``sweep``, ``blind``): :func:`experiment_from`
validates a mapping completely at load, the rig against its logs' column maps included, so a
typo fails in one line before any work. Paths are relative to the config file's folder.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    SerializeAsAny,
    ValidationError,
    field_validator,
    model_validator,
)

from hmid._messages import format_validation_error
from hmid.balance.rig import RigSection
from hmid.config import Positive, read_yaml
from hmid.errors import ConfigError
from hmid.families import FamilySpec, make_family
from hmid.io import load_column_map
from hmid.loop.config import LoopSpec
from hmid.signal import (
    DerivativeOfSmoothed,
    Differentiator,
    MovingAverage,
    SavitzkyGolay,
    SmoothedFiniteDifference,
    Smoother,
    Window,
)
from hmid.split import SplitSpec


class _Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class LogEntry(_Frozen):
    """One log file, the column map that reads it, and its role in the experiment."""

    path: Path
    columns: Path
    role: Literal["dynamic", "free_fall"]


class MovingAverageSpec(_Frozen):
    """Centred moving average, applied ``passes`` times: the zero-phase smoother of both sides of
    the balance. Three passes (a quadratic B-spline, close to a Gaussian of standard deviation
    ``window_s / 2``) keep the derivatives of the smoothed position smooth; one pass is the
    thesis's filter."""

    kind: Literal["moving_average"] = "moving_average"
    window_s: Positive = 0.011
    passes: Annotated[int, Field(ge=1, le=5)] = 3

    def build(self) -> Smoother:
        return MovingAverage(Window(seconds=self.window_s), "centred", "shrink", self.passes)

    @property
    def span_s(self) -> float:
        return self.window_s * self.passes


class DerivativeOfSmoothedSpec(_Frozen):
    """Velocity and acceleration as derivatives of the smoothed position: they see exactly the
    smoother every other signal of the balance sees, so its window does not bias parameters."""

    kind: Literal["smoothed"] = "smoothed"

    def build(self, smoother: Smoother) -> Differentiator:
        return DerivativeOfSmoothed(smoother)

    def span_s(self, smoother: MovingAverageSpec) -> float:
        return smoother.span_s


class SavitzkyGolaySpec(_Frozen):
    """Savitzky-Golay derivatives of the raw position. Their own low-pass is not the one the
    explained quantity sees (the second derivative's is much stronger), so parameters that
    multiply v or a then depend on the windows; prefer ``smoothed`` for a balance."""

    kind: Literal["savitzky_golay"] = "savitzky_golay"
    window_s: Positive = 0.05
    polyorder: Annotated[int, Field(ge=2, le=7)] = 3

    def build(self, smoother: Smoother | None = None) -> Differentiator:
        return SavitzkyGolay(Window(seconds=self.window_s), polyorder=self.polyorder)

    def span_s(self, smoother: MovingAverageSpec) -> float:
        return self.window_s


class SmoothedDifferenceSpec(_Frozen):
    """Moving average, then differences (uneven sampling is fine); as for Savitzky-Golay, its
    smoothing is its own."""

    kind: Literal["smoothed_difference"] = "smoothed_difference"
    window_s: Positive = 0.03

    def build(self, smoother: Smoother | None = None) -> Differentiator:
        return SmoothedFiniteDifference(MovingAverage(Window(seconds=self.window_s)))

    def span_s(self, smoother: MovingAverageSpec) -> float:
        return self.window_s


class DenoiseSection(_Frozen):
    """The smoother both sides of the balance pass through, how velocity and acceleration are
    estimated from the position, and where logs are split at logger pauses (``split_gaps_s``:
    a step longer than this starts a new piece; no filter runs across it)."""

    smoother: MovingAverageSpec = MovingAverageSpec()
    derivative: Annotated[
        DerivativeOfSmoothedSpec | SavitzkyGolaySpec | SmoothedDifferenceSpec,
        Field(discriminator="kind"),
    ] = DerivativeOfSmoothedSpec()
    split_gaps_s: Positive | None = None

    def build(self) -> tuple[Smoother, Differentiator]:
        smoother = self.smoother.build()
        return smoother, self.derivative.build(smoother)

    @property
    def longest_window_s(self) -> float:
        return max(self.derivative.span_s(self.smoother), self.smoother.span_s)


class FrictionSection(_Frozen):
    """Friction identified from the free-fall logs, for balance terms ``from: free_fall``."""

    model: Literal["coulomb", "coulomb_viscous"] = "coulomb"
    v_min: Positive = 0.02  # m/s, sliding segment of a free fall: |v| above this
    confidence: Annotated[float, Field(gt=0.5, lt=1)] = 0.95


class FitSection(_Frozen):
    """Which rows the balance is fitted on."""

    #: leave out the rows where the motion stops or nearly does: static friction is
    #: indeterminate there. None (the default): only on a rig that declares friction (a coulomb
    #: or smooth_coulomb term, or one from: free_fall); resolved when the experiment is loaded
    exclude_stuck: bool | None = None
    v_deadband: Annotated[float, Field(ge=0)] = 0.002  # m/s: below it the motion counts as stopped


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
    models: Annotated[tuple[SerializeAsAny[FamilySpec], ...], Field(min_length=1)]
    loop: LoopSpec | None = None  # close the loop on the residual (hmid.loop); off if absent
    base_dir: Path = Path(".")

    @field_validator("models", mode="before")
    @classmethod
    def _families(cls, specs):
        return tuple(make_family(spec, f"models.{i}") for i, spec in enumerate(specs or ()))

    @model_validator(mode="after")
    def _consistent(self) -> ExperimentConfig:
        free_falls = self.logs_with_role("free_fall")
        if self.rig.from_free_fall and not free_falls:
            names = [t.name for t in self.rig.from_free_fall]
            raise ValueError(
                f"rig terms {names} are from: free_fall, but no log has role free_fall"
            )
        if free_falls and not self.rig.from_free_fall:
            raise ValueError(
                "logs with role free_fall are read only for a rig term {kind: coulomb, from: "
                "free_fall}; add one or drop those logs"
            )
        if not self.logs_with_role("dynamic"):
            raise ValueError("no log has role dynamic: there is nothing to identify")
        names = []
        for i, spec in enumerate(self.models):
            try:
                spec.check(self.rig)
            except ValueError as err:
                raise ValueError(f"models.{i}: {err}") from None
            names += spec.model_names()
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(
                f"several models are named {repeated}; give each entry its own name "
                "(e.g. name: cubic for a second sls entry)"
            )
        if self.loop is not None:
            self.loop.check(self.rig, names)
        if self.fit.exclude_stuck is None:  # the low-speed rule is meant for friction
            fit = self.fit.model_copy(update={"exclude_stuck": self.rig.declares_friction})
            object.__setattr__(self, "fit", fit)  # resolved once, before anything reads it
        return self

    def logs_with_role(self, role: str) -> tuple[LogEntry, ...]:
        return tuple(entry for entry in self.logs if entry.role == role)

    def resolve(self, path: Path) -> Path:
        return path if path.is_absolute() else Path(os.path.normpath(self.base_dir / path))

    def model_names(self) -> list[str]:
        return [n for spec in self.models for n in spec.model_names()]


def experiment_from(data: Mapping[str, Any], source: str, base_dir: Path) -> ExperimentConfig:
    """Validate ``data`` as an experiment whose relative paths start at ``base_dir``: every
    listed file exists and every column map gives the channels the rig reads, in units that fit
    its balance. Problems are one-line ConfigErrors naming ``source`` and the key."""
    try:
        config = ExperimentConfig.model_validate(dict(data))
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, source, ExperimentConfig)) from None
    config = config.model_copy(update={"base_dir": Path(base_dir)})
    for i, entry in enumerate(config.logs):
        for key in ("path", "columns"):
            target = config.resolve(getattr(entry, key))
            if target.is_dir():
                raise ConfigError(
                    f"{source}: key 'logs.{i}.{key}': {target} is a folder, not a file; give the "
                    f"path of one {'log' if key == 'path' else 'column map'} file in it"
                )
            if not target.is_file():
                raise ConfigError(
                    f"{source}: key 'logs.{i}.{key}': file {target} does not exist "
                    f"(paths are relative to the config's folder {base_dir})"
                )
    config.rig.check_units(log_units(config), source)
    return config


def log_units(config: ExperimentConfig) -> dict[str, str]:
    """SI units of the rig's channels and of the explained quantity, read from the column maps
    of the dynamic logs (which must all give them, in units of the same dimension)."""
    from hmid.io.units import si_unit

    found: dict[str, str] = {}
    for i, entry in enumerate(config.logs):
        path = config.resolve(entry.columns)
        channels = load_column_map(path).channels
        wanted = config.rig.log_channels if entry.role == "dynamic" else (config.rig.position,)
        for channel in wanted:
            if channel not in channels:
                raise ConfigError(
                    f"{path}: channel {channel!r} is missing; the rig reads "
                    f"{list(wanted)} (logs.{i}, role {entry.role})"
                )
            unit = si_unit(channels[channel].unit, channel)
            if found.setdefault(channel, unit) != unit:
                raise ConfigError(
                    f"{path}: channel {channel!r} is in {unit}, in other logs {found[channel]}"
                )
    return config.rig.units(found)


def load_experiment(path: str | Path) -> ExperimentConfig:
    """Read and validate an experiment config (see :func:`experiment_from`)."""
    path = Path(path)
    return experiment_from(read_yaml(path), str(path), path.parent)
