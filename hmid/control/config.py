"""The config of ``hmid control``: which model, which plant, which tasks, which controllers.

Validated by pydantic at load time: an unknown key or a bad value is a one-line
:class:`~hmid.errors.ConfigError` naming the key. Paths are relative to the config file's
folder. ``model.run`` is a run folder of ``hmid run`` (``results/demo/<run-id>``) or an
experiment's folder (``results/demo``: its newest complete run); ``model.path`` a model file.

The plant is the Ch. 4 rig (``model``, ``rig``, ``tasks``) or, with an ``ankle`` section
instead of ``model``, the multi-fibre ankle of thesis Ch. 6 with a model per fibre type.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from hmid._messages import format_validation_error
from hmid.config import Positive, read_yaml
from hmid.control.experiments import ControllerKind
from hmid.control.references import REFERENCE_KINDS, ReferenceKind
from hmid.errors import ConfigError
from hmid.simulate.effects import make_effect
from hmid.simulate.params import RigParams
from hmid.simulate.rigs.ankle_params import AnkleParams, load_ankle_params
from hmid.simulate.valves import OnOffValves, ProportionalValve


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


DEMO = "run `make demo` (or `hmid run configs/demo.yaml`) first"
FIBRES = "run `make fibre-models` (hmid simulate + hmid run of configs/fibre-*.yaml) first"


class ModelSection(_Strict):
    """The identified model the controller inverts (and whose posterior the plant is drawn
    from): ``name`` in the run folder ``run``, or the model file ``path``."""

    run: Path | None = None
    name: str = "sls"
    path: Path | None = None

    @model_validator(mode="after")
    def _one(self) -> ModelSection:
        if (self.run is None) == (self.path is None):
            raise ValueError("give the model's run folder (run) or its file (path), one of them")
        return self

    def run_folder(self, base_dir: Path, hint: str = DEMO) -> Path:
        """The run folder: the one named, or the newest complete run under it."""
        assert self.run is not None
        path = (base_dir / self.run).resolve()
        if (path / "metrics.json").is_file():
            return path
        runs = sorted(p.parent for p in path.glob("*/metrics.json")) if path.is_dir() else []
        complete = [p for p in runs if _complete(p)]
        if not complete:
            raise ConfigError(f"model.run {path}: no finished run of hmid there; {hint}")
        return complete[-1]


FIBRE_TYPES = ("gastrocnemius", "soleus")


class AnkleSection(_Strict):
    """The Ch. 6 ankle as the plant: its YAML (:class:`~hmid.simulate.rigs.ankle_params.
    AnkleParams`), a model per active fibre type, which fibres are engaged (named, or the fewest
    whose full torque and joint stiffness by the models reach ``torque`` N m and ``stiffness``
    N m/rad over the task's angles), the task's
    angles (deg, + plantarflexion), the proportional valve, and manufactured fibres drawn with
    the build's scatter for the robustness study."""

    plant: Path = Path("ankle-plant.yaml")
    models: dict[Literal["gastrocnemius", "soleus"], ModelSection]
    engaged: tuple[str, ...] | None = None
    torque: Positive | None = None  # N m
    stiffness: Positive | None = None  # N m/rad
    low_deg: float = 0.0
    high_deg: float = 20.0
    substeps: Annotated[int, Field(ge=1, le=100)] = 10
    proportional: ProportionalValve = ProportionalValve()
    scatter_draws: Annotated[int, Field(ge=0, le=10000)] = 0

    @model_validator(mode="after")
    def _check(self) -> AnkleSection:
        missing = [name for name in FIBRE_TYPES if name not in self.models]
        if missing:
            raise ValueError(f"models: give a model for {missing}")
        if (self.engaged is None) == (self.torque is None and self.stiffness is None):
            raise ValueError(
                "give the engaged fibres (engaged) or a torque and/or stiffness to recruit for"
            )
        if not -20.0 <= self.low_deg < self.high_deg <= 40.0:
            raise ValueError(f"low_deg={self.low_deg}, high_deg={self.high_deg}: want "
                             "-20 <= low < high <= 40 (the end stops)")  # fmt: skip
        return self

    def params(self, base_dir: Path) -> AnkleParams:
        return load_ankle_params(base_dir / self.plant)


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


class TrackingTasks(_Strict):
    force: TaskSection | None = TaskSection(low=5.0, high=25.0)
    position: TaskSection | None = TaskSection(low=0.004, high=0.009)


class ControllerSection(_Strict):
    """The PD's tuning rule (:mod:`hmid.control.tuning`; FF+PID's, :mod:`hmid.control.integral`,
    and FF+DOB's, :mod:`hmid.control.observer`, ask the same margins) and what the controller
    knows of its valve (its datasheet's lag, inverted by the feed-forward)."""

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
    model: ModelSection | None = None
    ankle: AnkleSection | None = None
    rig: RigParams = RigParams()
    rate: Positive = 1000.0
    duration: Annotated[float, Field(gt=0, le=600)] = 4.0
    # s of the reference's start held, the controller engaged, before the scored trajectory
    # (a pre-roll: hmid.control.references); the same for every controller, valve and plant
    hold: Annotated[float, Field(ge=0, le=60)] = 0.0
    step_at: Annotated[float, Field(ge=0)] = 1.0
    transition: Positive = 0.25
    frequency: Positive = 1.0
    references: tuple[ReferenceKind, ...] = REFERENCE_KINDS
    # PD alone and FF+PD always (the comparison); FF+PID adds integral action to FF+PD, FF+DOB
    # a disturbance observer (hmid.control.observer)
    controllers: tuple[ControllerKind, ...] = ("PD", "FF+PD")
    noise: bool = True  # the sensors' noise (the demo's: 15 um, 6 mN)
    tasks: TrackingTasks = TrackingTasks()
    controller: ControllerSection = ControllerSection()
    on_off: OnOffSection | None = OnOffSection()
    robustness: RobustnessSection = RobustnessSection()
    base_dir: Path = Field(default=Path("."), exclude=True)

    @model_validator(mode="after")
    def _timing(self) -> ControlConfig:
        missing = [c for c in ("PD", "FF+PD") if c not in self.controllers]
        if (
            missing
            or "FF" in self.controllers
            or len(set(self.controllers)) < len(self.controllers)
        ):
            raise ValueError(f"controllers: {list(self.controllers)}: want PD and FF+PD, and "
                             "FF+PID or FF+DOB if asked, each once")  # fmt: skip
        if (self.model is None) == (self.ankle is None):
            raise ValueError("give a model (the Ch. 4 rig) or an ankle section, one of them")
        if self.ankle is not None and self.ankle.engaged is not None:
            params = self.ankle.params(self.base_dir)
            active = params.fibre_names[: params.n_active]
            unknown = [n for n in self.ankle.engaged if n not in active]
            if unknown or not self.ankle.engaged:
                raise ValueError(f"ankle.engaged: {unknown} are not active fibres {active}")
        if self.step_at + self.transition >= self.duration:
            raise ValueError(
                f"step_at + transition = {self.step_at + self.transition} s must end before "
                f"duration = {self.duration} s"
            )
        return self

    def run_folder(self) -> Path:
        """The model's run folder: the one named, or the newest complete run under it."""
        assert self.model is not None
        return self.model.run_folder(self.base_dir)


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
