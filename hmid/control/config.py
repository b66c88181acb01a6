"""The config of ``hmid control``: which model, which plant, which tasks, which controllers.

Validated by pydantic at load time: an unknown key or a bad value is a one-line
:class:`~hmid.errors.ConfigError` naming the key. Paths are relative to the config file's
folder. ``model.run`` is a run folder of ``hmid run`` (``results/demo/<run-id>``) or an
experiment's folder (``results/demo``: its newest complete run).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from hmid._messages import format_validation_error
from hmid.config import read_yaml
from hmid.control.references import KINDS, Kind
from hmid.errors import ConfigError
from hmid.simulate.effects import make_effect
from hmid.simulate.params import RigParams
from hmid.simulate.valves import OnOffValves

Positive = Annotated[float, Field(gt=0)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class ModelSection(_Strict):
    """The identified model the controller inverts (and whose posterior the plant is drawn
    from)."""

    run: Path
    name: str = "sls"


class TaskSection(_Strict):
    """A tracking task's range: references go between ``low`` and ``high`` (N for force, m for
    position); the force task clamps the block at ``hold_at`` (m)."""

    low: float
    high: float
    hold_at: Positive = 0.006

    @model_validator(mode="after")
    def _range(self) -> TaskSection:
        if self.high <= self.low:
            raise ValueError(f"high={self.high} must exceed low={self.low}")
        return self


class Tasks(_Strict):
    force: TaskSection | None = TaskSection(low=5.0, high=25.0)
    position: TaskSection | None = TaskSection(low=0.004, high=0.009)


class ControllerSection(_Strict):
    """The PD's tuning rule (:mod:`hmid.control.tuning`) and what the controller knows of its
    valve (its datasheet's lag, inverted by the feed-forward)."""

    gain_margin_db: Positive = 6.0
    phase_margin_deg: Annotated[float, Field(gt=0, lt=90)] = 45.0
    derivative_filter_s: Positive = 0.001
    valve_tau: Positive = 0.03


class OnOffSection(_Strict):
    """On/off valves on the same plant, realised by switching or PWM
    (:mod:`hmid.control.actuation`)."""

    realisation: Literal["switching", "pwm"] = "switching"
    band: Positive = 3.0e3  # Pa, switching
    period: Annotated[int, Field(ge=2, le=1000)] = 20  # samples, PWM
    span: Positive = 5.0e4  # Pa of error for a full duty, PWM
    valves: OnOffValves = OnOffValves()


class RobustnessSection(_Strict):
    """The plant drawn from the model's posterior (``draws`` muscles) and with undeclared
    effects switched on (each alone); the controller stays the nominal model's."""

    draws: Annotated[int, Field(ge=0, le=10000)] = 100
    effects: tuple[dict[str, Any], ...] = ()

    @field_validator("effects")
    @classmethod
    def _known(cls, specs):
        for spec in specs:
            make_effect(spec)
        return specs


class ControlConfig(_Strict):
    """A control study: ``hmid control CONFIG``."""

    name: str
    seed: Annotated[int, Field(ge=0)] = 0
    model: ModelSection
    rig: RigParams = RigParams()
    rate: Positive = 1000.0
    duration: Annotated[float, Field(gt=0, le=600)] = 4.0
    step_at: Annotated[float, Field(ge=0)] = 1.0
    transition: Positive = 0.25
    frequency: Positive = 1.0
    references: tuple[Kind, ...] = KINDS
    noise: bool = True  # the sensors' noise (the demo's: 15 um, 6 mN)
    tasks: Tasks = Tasks()
    controller: ControllerSection = ControllerSection()
    on_off: OnOffSection | None = OnOffSection()
    robustness: RobustnessSection = RobustnessSection()
    base_dir: Path = Field(default=Path("."), exclude=True)

    @model_validator(mode="after")
    def _timing(self) -> ControlConfig:
        if self.step_at + self.transition >= self.duration:
            raise ValueError(
                f"step_at + transition = {self.step_at + self.transition} s must end before "
                f"duration = {self.duration} s"
            )
        return self

    def run_folder(self) -> Path:
        """The model's run folder: the one named, or the newest complete run under it."""
        path = (self.base_dir / self.model.run).resolve()
        hint = "run `make demo` (or `hmid run configs/demo.yaml`) first"
        if (path / "metrics.json").is_file():
            return path
        runs = sorted(p.parent for p in path.glob("*/metrics.json")) if path.is_dir() else []
        complete = [p for p in runs if _complete(p)]
        if not complete:
            raise ConfigError(f"model.run {path}: no finished run of hmid there; {hint}")
        return complete[-1]


def _complete(folder: Path) -> bool:
    try:
        manifest = json.loads((folder / "manifest.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return manifest.get("status") == "complete"


def load_control_config(path: str | Path) -> ControlConfig:
    """The config at ``path``, validated (a one-line ConfigError naming the key)."""
    data = read_yaml(path, "control config")
    try:
        return ControlConfig.model_validate({**data, "base_dir": Path(path).resolve().parent})
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, str(path), ControlConfig)) from None
