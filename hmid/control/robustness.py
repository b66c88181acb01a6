"""Robustness: the same controller on plants it was not designed for.

The controller (its feed-forward from the nominal model, its gains; FF+PD, or FF+PID whose
integral takes back the steady error the model's miss leaves) stays as it is; the plant
changes: its muscle is drawn from the identified model's posterior (what the data allow the
muscle to be), or an undeclared effect of :mod:`hmid.simulate.effects` is switched on (physics
the model lacks). The score is the ratio of the tracking RMSE to the nominal plant's (same
controller, same valves), the issue's target being <= 1.5. Where the nominal error is a
fraction of the sensor's step, that ratio measures how close the feed-forward happens to land
more than the loop: the report gives the worst RMSE in sensor steps beside it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hmid.simulate.params import MuscleParams

#: The posterior's names that are the simulator's muscle parameters
MUSCLE = ("A_eff", "F0", "k1", "k3", "k2", "tau")


@dataclass(frozen=True)
class Spread:
    """RMSEs of the perturbed plants against the nominal one."""

    case: str  # "posterior (n draws)" or the effect's kind
    nominal_rmse: float
    rmse: np.ndarray
    controller: str = "FF+PD"
    valves: str = "proportional"

    @property
    def ratios(self) -> np.ndarray:
        return self.rmse / self.nominal_rmse

    @property
    def worst(self) -> float:
        return float(np.max(self.ratios))

    @property
    def median(self) -> float:
        return float(np.median(self.ratios))


def posterior_muscles(model, draws: int, seed: int) -> list[MuscleParams]:
    """``draws`` muscles from ``model``'s posterior (drawn without replacement, seeded); an
    empty list where the model has no posterior or its parameters are not the simulator's."""
    posterior = model.posterior
    if posterior is None or draws == 0:
        return []
    data = posterior.posterior
    if any(name not in data for name in MUSCLE):
        return []
    values = {name: np.asarray(data[name]).reshape(-1) for name in MUSCLE}
    total = len(values["k1"])
    rows = np.random.default_rng(seed).choice(total, size=min(draws, total), replace=False)
    return [MuscleParams(**{name: float(values[name][i]) for name in MUSCLE}) for i in rows]
