"""The control study on the Ch. 6 ankle: its plant, recruitment and perturbed plants.

The ankle's task is the angle (the potentiometer's, 0.29 deg steps) between the config's two
angles: ``step_up`` is a plantarflexion (the engaged fibres vented: they shorten), ``step_down``
a dorsiflexion (filled: they relax and the tibialis pulls), the sine and the gait-like cycle
both ways. The controller's model is one identified model per fibre type (every gastrocnemius
fibre shares the gastrocnemius's). The perturbed plants: every active fibre drawn from its
type's posterior (each fibre its own draw), every fibre drawn from its build's manufacturing
scatter (:class:`~hmid.simulate.specs.Scatter`: the tibialis too, which the controller knows
only by its build), and the undeclared effects, each alone.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

from hmid.control.ankle import AnkleRig, FibreLaws, recruit
from hmid.control.config import ControlConfig
from hmid.control.robustness import posterior_muscles
from hmid.control.study import Perturbed, Study, references, run_tracking_task, valve_kinds
from hmid.simulate.effects import make_effect
from hmid.simulate.params import MuscleParams
from hmid.simulate.rigs.ankle_params import AnkleParams
from hmid.simulate.specs import Scatter


def ankle_plant(config: ControlConfig, laws: FibreLaws | None = None) -> AnkleRig:
    """The configured ankle with the proportional valve and its engaged fibres (named, or
    recruited for the torque and stiffness by ``laws``)."""
    section = config.ankle
    assert section is not None
    params = section.params(config.base_dir)
    everything = AnkleRig(params, (True,) * params.n_active, rate=config.rate,
                          substeps=section.substeps).proportional(section.proportional)  # fmt: skip
    if section.engaged is not None:
        engaged = tuple(name in section.engaged for name in params.fibre_names[: params.n_active])
    else:
        assert laws is not None
        angles = [math.radians(a) for a in (section.low_deg, section.high_deg)]
        engaged = recruit(everything, laws, section.torque or 0.0, angles,
                          section.stiffness or 0.0)  # fmt: skip
    return AnkleRig(everything.params, engaged, realisation=everything.realisation,
                    rate=config.rate, substeps=section.substeps)  # fmt: skip


def posterior_fibres(params: AnkleParams, models: Mapping[str, Any], draws: int,
                     seed: int) -> list[tuple[MuscleParams, ...]]:  # fmt: skip
    """``draws`` sets of fibres: each active fibre its own draw of its type's posterior, the
    tibialis its build; empty where a model has no posterior."""
    per_type = {}
    for k, name in enumerate(("gastrocnemius", "soleus")):
        count = getattr(params, name).count
        drawn = posterior_muscles(models[name], draws * count, seed + k)
        if len(drawn) < draws * count:
            return []
        per_type[name] = [drawn[d * count : (d + 1) * count] for d in range(draws)]
    tibialis = (params.tibialis.spec.params(),) * params.tibialis.count
    return [tuple(per_type["gastrocnemius"][d]) + tuple(per_type["soleus"][d]) + tibialis
            for d in range(draws)]  # fmt: skip


def scatter_fibres(params: AnkleParams, draws: int, seed: int) -> list[tuple[MuscleParams, ...]]:
    """``draws`` sets of manufactured fibres: every fibre drawn from its build's scatter."""
    specs = [g.spec for g in params.groups.values() for _ in range(g.count)]
    return [tuple(spec.draw(Scatter(), seed + 1000 * d + i) for i, spec in enumerate(specs))
            for d in range(draws)]  # fmt: skip


def run_ankle(
    config: ControlConfig, models: Mapping[str, Any], progress: Callable[[str], None] | None
) -> Study:
    """The ankle's control study with the models by fibre type (:class:`hmid.Model`)."""
    section = config.ankle
    assert section is not None
    params = section.params(config.base_dir)
    laws = FibreLaws.of(params, models)
    plant = ankle_plant(config, laws)
    perturbed: Perturbed = []
    drawn = posterior_fibres(params, models, config.robustness.draws, config.seed)
    if drawn:
        perturbed.append((f"posterior ({len(drawn)} draws)",
                          [plant.with_fibres(f) for f in drawn]))  # fmt: skip
    if section.scatter_draws:
        scattered = scatter_fibres(params, section.scatter_draws, config.seed)
        perturbed.append((f"build scatter ({len(scattered)} draws)",
                          [plant.with_fibres(f) for f in scattered]))  # fmt: skip
    effects = [make_effect(spec) for spec in config.robustness.effects]
    perturbed += [(effect.kind, [plant.with_effects((effect,))]) for effect in effects]
    refs = references(config, math.radians(section.low_deg), math.radians(section.high_deg))
    result = run_tracking_task("angle", plant, laws, refs, perturbed, config, 0, progress)
    return Study(laws.name, (result,), valve_kinds(config))
