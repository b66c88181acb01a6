"""One tracking experiment: a plant, a controller, a reference -> the run and its scores.

The controllers (:mod:`hmid.control.controllers`) are named by what their feed-forward is:

* ``PD``: the PD set-point tracker with its operating point's pressure;
* ``FF+PD``: the identified model's inverse dynamics plus the same PD;
* ``FF+PID``: the same feed-forward plus a PID (:mod:`hmid.control.integral`: integral action
  for what the model misses, with anti-windup at the valves' limits);
* ``FF+DOB``: the same feed-forward and PD plus a disturbance observer
  (:mod:`hmid.control.observer`: the model's inverse estimates what the model misses, and the
  feed-forward is corrected by it);
* ``FF``: the inverse dynamics alone (no feedback: the perfect-model check).

A run simulates the plant's rig under the tracker in one compiled scan
(:func:`hmid.simulate.rig.closed_loop`); the sensor noise is drawn from an explicit seed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import jax.numpy as jnp
import numpy as np

from hmid.control.controllers import PD, PID, Tracker
from hmid.control.inverse import ForceLaw
from hmid.control.metrics import Metrics, tracking_score
from hmid.control.observer import DOB
from hmid.control.plant import Plant
from hmid.control.references import Reference
from hmid.control.tuning import Tuning
from hmid.simulate.rig import closed_loop

ControllerKind = Literal["PD", "FF+PD", "FF+PID", "FF+DOB", "FF"]
CONTROLLERS: tuple[ControllerKind, ...] = ("PD", "FF+PD", "FF+PID", "FF+DOB", "FF")


@dataclass(frozen=True)
class Tracking:
    """A closed-loop run: the output (truth) and the reference at the instants ``t``, the
    model's demanded pressure (at ``t``) and the controller's effort (Pa, per command), the
    pressure, the on/off
    valves' commands (None for a proportional valve), and the scores."""

    controller: ControllerKind
    reference: Reference
    t: np.ndarray
    output: np.ndarray
    demand: np.ndarray
    effort: np.ndarray
    pressure: np.ndarray
    valve: np.ndarray | None
    metrics: Metrics


def tracker(plant: Plant, tuning: Tuning, controller: ControllerKind = "FF+PD") -> Tracker:
    """The tracker of ``plant`` with the tuned gains (arrays: new gains do not recompile); a
    PID for ``FF+PID`` (``tuning`` then :func:`~hmid.control.integral.tune_pid`'s), its
    anti-windup at the plant's :attr:`~hmid.control.plant.Plant.limits`, its deadband half the
    sensor's step; the PD with a disturbance observer for ``FF+DOB`` (``tuning`` then
    :func:`~hmid.control.observer.tune_dob`'s), with the same limits and deadband."""
    pd = PD(*(jnp.asarray(v, dtype=float) for v in (tuning.kp, tuning.kd, tuning.tf,
                                                       tuning.dt)))  # fmt: skip
    law: PD | PID | DOB = pd
    if controller == "FF+PID":
        if tuning.ki == 0:
            raise ValueError("FF+PID needs a PID's tuning (hmid.control.integral.tune_pid)")
        law = PID(pd, *(jnp.asarray(v, dtype=float) for v in (tuning.ki, *plant.limits,
                                                              plant.resolution / 2)))  # fmt: skip
    if controller == "FF+DOB":
        obs = tuning.observer
        if obs is None:
            raise ValueError("FF+DOB needs an observer's tuning (hmid.control.observer.tune_dob)")
        law = DOB(pd, *(jnp.asarray(m, dtype=float) for m in (obs.A, obs.B, obs.C,
                                                               *plant.limits,
                                                               plant.resolution / 2)))  # fmt: skip
    return Tracker(law, plant.tracked, jnp.asarray(plant.resolution), plant.actuation,
                   jnp.asarray(0.0 if controller == "FF" else 1.0))  # fmt: skip


@dataclass(frozen=True)
class FeedForward:
    """The effort per command (one fewer than the reference's samples), the pressure the
    model demands at every sample of the reference, and the pressure the rig starts at, at rest
    (the one that holds the reference's start, by the model)."""

    commands: np.ndarray
    demand: np.ndarray
    start: float


def feedforward(
    plant: Plant, law: ForceLaw, ref: Reference, controller: ControllerKind, valve_tau: float
) -> FeedForward:
    """The feed-forward of ``controller``: the hold pressure for PD alone, the model's inverse
    dynamics otherwise."""
    start = plant.hold(law, ref)
    if controller == "PD":
        return FeedForward(np.full(len(ref.t) - 1, start), np.full(len(ref.t), start), start)
    return FeedForward(plant.feedforward(law, ref, valve_tau), plant.demand(law, ref), start)


def track(
    plant: Plant,
    tuning: Tuning,
    ff: FeedForward,
    ref: Reference,
    controller: ControllerKind,
    seed: int = 0,
) -> Tracking:
    """Run ``plant`` under ``controller`` with the feed-forward ``ff`` along ``ref`` (sampled
    at the plant's rate; command k acts from ref.t[k] to ref.t[k + 1]).

    Where ``ref`` starts with a hold (:class:`~hmid.control.references.Reference`), the loop
    runs through it, its states starting at zero at the hold's start (the rig at rest at the
    model's hold pressure: the effort that pressure plus the PD's answer to the first error,
    no derivative kick) and carried into the trajectory unreset: nothing switches at the hold's
    end, so the transfer is bumpless. The run returned, and scored, is what follows the hold,
    its time from the hold's end."""
    n = len(ref.t) - 1
    noise = plant.noise * np.random.default_rng(seed).standard_normal(n)
    references = {"r": ref.y[:-1], "ff": ff.commands, "noise": noise}
    traj, commands = closed_loop(
        plant.rig(ff.start), tracker(plant, tuning, controller), references, plant.rate,
        initial_inputs=plant.inputs(n, ff.start), initial_outputs=plant.outputs(ff.start),
        substeps=plant.substeps,
    )  # fmt: skip
    effort, pressure, valve = plant.commanded(traj, commands, ff)
    scored = ref.scored()
    k = len(ref.t) - len(scored.t)  # sample k on: after the hold's last command, on its grid
    t, output = traj.t[: len(traj.t) - k], getattr(traj, plant.tracked)[k:]  # the rig's clock
    valve = None if valve is None else valve[k:]
    metrics = tracking_score(scored, t, output, plant.resolution, valve)
    return Tracking(controller, scored, t, output, ff.demand[1 + k :], effort[k:],
                    pressure[k:], valve, metrics)  # fmt: skip
