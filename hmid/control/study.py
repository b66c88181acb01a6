"""The control study of a config: tune, track every reference with every controller and valve,
and shake the plant; typed results for the report (:mod:`pipelines.control` writes them).

Per task (force, position on the Ch. 4 rig; angle on the ankle) the PD is tuned once on the
model's linearisation at the first reference's start and keeps its gains for every reference,
valve and plant: PD alone and feed-forward + PD run at the same gains. With on/off valves the
same PD's effort is switched on the valves (:mod:`hmid.control.actuation`). FF+PID, where the
config asks for it, is tuned on the same linearisation per valve kind (the on/off loop behind
the valves' switching delay: :mod:`hmid.control.integral`). The robustness study runs every
model-based controller on every valve kind. The perturbed plants
(robustness) are each rig's own: the muscle drawn from the model's posterior on the Ch. 4 rig,
every fibre drawn from its type's posterior (or the build's scatter) on the ankle
(:mod:`hmid.control.ankle_study`), and undeclared effects on both.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from hmid.control.actuation import PWM, Switching
from hmid.control.config import ControlConfig
from hmid.control.experiments import ControllerKind, FeedForward, Tracking, feedforward, track
from hmid.control.integral import delayed, tune_pid
from hmid.control.inverse import ForceLaw
from hmid.control.observer import tune_dob
from hmid.control.plant import MuscleRig, Plant
from hmid.control.references import Reference, reference
from hmid.control.robustness import Spread, posterior_muscles
from hmid.control.tuning import Tuning, TuningError, tune
from hmid.errors import SimulationError
from hmid.simulate.effects import make_effect
from hmid.simulate.params import Sensors


@dataclass(frozen=True)
class TaskResult:
    """One task: its plant, tuning, and runs by (reference kind, valves, controller)."""

    task: str
    unit: str
    resolution: float
    plant: Plant
    tuning: Tuning
    gain: float  # the linearised plant's static gain (tracked unit per Pa)
    runs: dict[tuple[str, str, ControllerKind], Tracking]
    spreads: dict[str, list[Spread]]  # reference kind -> robustness cases
    integral: dict[str, Tuning] = field(default_factory=dict)  # valves -> FF+PID's gains
    observers: dict[str, Tuning] = field(default_factory=dict)  # valves -> FF+DOB's tuning

    def reduction(self, kind: str, valves: str) -> float:
        """1 - RMSE(FF+PD) / RMSE(PD) (the issue's target: >= 0.5)."""
        pd = self.runs[(kind, valves, "PD")].metrics.rmse
        return 1.0 - self.runs[(kind, valves, "FF+PD")].metrics.rmse / pd


@dataclass(frozen=True)
class Study:
    model: str
    tasks: tuple[TaskResult, ...]
    valves: tuple[str, ...]  # "proportional", and "on/off (switching)" where configured


#: Perturbed plants by case ("posterior (100 draws)", an effect's kind), for the robustness study
Perturbed = list[tuple[str, list[Plant]]]


def plants(config: ControlConfig) -> dict[str, MuscleRig]:
    """The configured tasks' plants, with the proportional valve."""
    sensors = Sensors()
    out = {}
    if config.tasks.force is not None:
        noise = sensors.F.noise if config.noise else 0.0
        out["force"] = MuscleRig(config.rig, "force", hold_at=config.tasks.force.hold_at,
                                 rate=config.rate, noise=noise)  # fmt: skip
    if config.tasks.position is not None:
        noise = sensors.x.noise if config.noise else 0.0
        out["position"] = MuscleRig(config.rig, "position", rate=config.rate, noise=noise)
    return out


def references(config: ControlConfig, low: float, high: float) -> dict[str, Reference]:
    """Every configured reference between ``low`` and ``high`` (the tracked output's unit),
    after the config's hold (a whole number of samples)."""
    held = round(config.hold * config.rate)
    t = np.arange(0, held + round(config.duration * config.rate) + 1) / config.rate
    return {
        kind: reference(kind, t, low, high, step_at=config.step_at,
                        transition=config.transition, frequency=config.frequency,
                        hold=held / config.rate)
        for kind in config.references
    }  # fmt: skip


def on_off(plant: Plant, config: ControlConfig) -> Plant:
    section = config.on_off
    assert section is not None
    actuation = (
        Switching(band=section.band)
        if section.realisation == "switching"
        else PWM(period=section.period, span=section.span)
    )
    return plant.with_on_off(section.valves, actuation)


def valve_kinds(config: ControlConfig) -> tuple[str, ...]:
    if config.on_off is None:
        return ("proportional",)
    return ("proportional", f"on/off ({config.on_off.realisation})")


def _rmse(plant: Plant, tuning: Tuning, ff: FeedForward, ref: Reference, seed: int,
          controller: ControllerKind = "FF+PD") -> float:  # fmt: skip
    """A model-based controller's RMSE on a perturbed plant; infinite where the run breaks the
    rig's physics (the string goes slack): the controller failed there."""
    try:
        return track(plant, tuning, ff, ref, controller, seed).metrics.rmse
    except SimulationError:
        return float("inf")


def switching_delay(config: ControlConfig, valves: str) -> float:
    """The dead time the on/off valves add to the loop (s; 0 for the proportional valve)."""
    if valves == "proportional" or config.on_off is None:
        return 0.0
    return config.on_off.valves.opening_time + config.on_off.valves.closing_time


def run_tracking_task(
    task: str,
    plant: Plant,
    law,
    refs: dict[str, Reference],
    perturbed: Perturbed,
    config: ControlConfig,
    seed: int,
    progress: Callable[[str], None] | None = None,
) -> TaskResult:
    """Tune the PD (and FF+PID's PID per valve kind) on ``plant``'s linearisation by ``law``,
    track every reference with every controller on every valve kind, and the perturbed plants
    with the model-based ones."""
    ctl = config.controller
    first = next(iter(refs.values()))
    linear = plant.linear(law, first, ctl.valve_tau)
    margins = {"gain_margin_db": ctl.gain_margin_db, "phase_margin_deg": ctl.phase_margin_deg,
               "tf": ctl.derivative_filter_s}  # fmt: skip
    tuning = tune(linear, 1.0 / config.rate, **margins)
    integral = {
        name: tune_pid(delayed(linear, switching_delay(config, name)), 1.0 / config.rate,
                       **margins)
        for name in valve_kinds(config)
        if "FF+PID" in config.controllers
    }  # fmt: skip
    observers = _observers(linear, tuning, config) if "FF+DOB" in config.controllers else {}
    gains = {c: tuning for c in ("PD", "FF+PD")}
    runs: dict[tuple[str, str, ControllerKind], Tracking] = {}
    spreads: dict[str, list[Spread]] = {}
    for kind, ref in refs.items():
        if progress:
            progress(f"{task}: {kind}")
        spreads[kind] = []
        for name in valve_kinds(config):
            target = plant if name == "proportional" else on_off(plant, config)
            gains["FF+PID"] = integral.get(name, tuning)
            gains["FF+DOB"] = observers.get(name, tuning)
            # FF+DOB only on the valves where an observer keeps the margins
            asked = [c for c in config.controllers if c != "FF+DOB" or name in observers]
            for controller in asked:
                ff = feedforward(target, law, ref, controller, ctl.valve_tau)
                runs[(kind, name, controller)] = track(target, gains[controller], ff, ref,
                                                       controller, seed)  # fmt: skip
            for controller in (c for c in asked if c != "PD"):
                nominal = runs[(kind, name, controller)].metrics.rmse
                ff = feedforward(target, law, ref, controller, ctl.valve_tau)
                for case, cases in perturbed:
                    shaken = [p if name == "proportional" else on_off(p, config) for p in cases]
                    rmse = [_rmse(p, gains[controller], ff, ref, seed, controller)
                            for p in shaken]  # fmt: skip
                    spreads[kind].append(Spread(case, nominal, np.array(rmse), controller, name))
    gain = float(np.squeeze(linear.dcgain()))
    return TaskResult(task, plant.unit, plant.resolution, plant, tuning, gain, runs, spreads,
                      integral, observers)  # fmt: skip


def _observers(linear, tuning: Tuning, config: ControlConfig) -> dict[str, Tuning]:
    """FF+DOB's observer per valve kind (:func:`~hmid.control.observer.tune_dob`, the on/off
    loop behind the valves' switching delay); a valve kind where none keeps the margins is left
    out (its FF+DOB is not run: the report's tuning table says so)."""
    ctl = config.controller
    out = {}
    for name in valve_kinds(config):
        try:
            out[name] = tune_dob(linear, tuning, 1.0 / config.rate,
                                 delay=switching_delay(config, name),
                                 gain_margin_db=ctl.gain_margin_db,
                                 phase_margin_deg=ctl.phase_margin_deg)  # fmt: skip
        except TuningError:
            continue
    return out


def run_study(config: ControlConfig, model, progress: Callable[[str], None] | None = None) -> Study:
    """Every task of ``config`` with the loaded ``model`` (:class:`hmid.Model`; for the ankle a
    mapping of fibre type to model)."""
    if config.ankle is not None:
        from hmid.control.ankle_study import run_ankle

        return run_ankle(config, model, progress)
    law = ForceLaw.of(model)
    muscles = posterior_muscles(model, config.robustness.draws, config.seed)
    effects = [make_effect(spec) for spec in config.robustness.effects]
    results = []
    for seed, (task, plant) in enumerate(plants(config).items()):
        section = getattr(config.tasks, task)
        perturbed: Perturbed = []
        if muscles:
            perturbed.append((f"posterior ({len(muscles)} draws)",
                              [plant.with_muscle(m) for m in muscles]))  # fmt: skip
        perturbed += [(effect.kind, [plant.with_effects((effect,))]) for effect in effects]
        refs = references(config, section.low, section.high)
        results.append(run_tracking_task(task, plant, law, refs, perturbed, config, seed, progress))
    return Study(model.name, tuple(results), valve_kinds(config))
