"""Each muscle's data: its hidden parameters, its data set on the Ch. 4 rig, its identification.

A muscle of the population is manufactured from its specifications with a seeded scatter
(:meth:`~hmid.simulate.specs.MuscleSpec.draw`); the experimenter knows the specifications, not
the drawn parameters. A stiffer or narrower muscle needs other pressures to move the same
distance, so the dynamic logs' pressures, declared for a reference muscle, are retargeted by the
specifications (:func:`retarget`): each pressure is mapped to the one that gives the same
quasi-static elongation on the muscle's law parameters; the valve's slew limit is scaled alike
(the same elongation rate). The data sets are written once into ``<data>/<muscle>/``
(byte-reproducible from the population's seed) and identified by the standard pipeline, one
sweep run per muscle.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from hmid.population._config import Muscle, PopulationConfig
from hmid.population._law import PARAMETERS
from hmid.simulate.params import MuscleParams, RigParams, ValveParams
from hmid.simulate.profiles import Chirp, Constant, Cycles, RandomLevels, Sine, Steps
from hmid.simulate.rigs.hydro_muscle_dataset import DynamicLog, HydroMuscleDataset
from hmid.simulate.specs import MuscleSpec


def elongation(params: MuscleParams, pressure: float, load: float) -> float:
    """Quasi-static elongation (m) under ``pressure`` against ``load`` (N): the root of
    A_eff P + F0 - k1 x - k3 x^3 = load, or 0 where the muscle rests on the end stop."""
    drive = params.A_eff * pressure + params.F0 - load
    if drive <= 0:
        return 0.0
    roots = np.roots([params.k3, 0.0, params.k1, -drive]) if params.k3 > 0 else [drive / params.k1]
    return float(min(r.real for r in np.atleast_1d(roots) if abs(r.imag) < 1e-9 and r.real >= 0))


def pressure_for(params: MuscleParams, x: float, load: float) -> float:
    """The pressure (Pa) that holds the muscle at elongation ``x`` against ``load``."""
    return max(0.0, (load - params.F0 + params.k1 * x + params.k3 * x**3) / params.A_eff)


def retarget(profile: Any, reference: MuscleSpec, muscle: MuscleSpec, load: float) -> Any:
    """``profile`` (pressures for ``reference``) with the pressures that give ``muscle`` the same
    quasi-static elongations (both on their scaling law's parameters)."""
    ref, own = reference.params(), muscle.params()
    lift_ref, lift_own = pressure_for(ref, 0.0, load), pressure_for(own, 0.0, load)

    def one(p: float) -> float:
        x = elongation(ref, p, load)
        if x <= 0.0:  # below lift-off: in proportion to the lift-off pressures
            return p * lift_own / lift_ref if lift_ref > 0 else p
        return pressure_for(own, x, load)

    if isinstance(profile, Cycles | RandomLevels):
        return profile.model_copy(update={"low": one(profile.low), "high": one(profile.high)})
    if isinstance(profile, Steps):
        return profile.model_copy(update={"levels": tuple(one(p) for p in profile.levels)})
    if isinstance(profile, Sine | Chirp):
        lo, hi = one(profile.offset - profile.amplitude), one(profile.offset + profile.amplitude)
        return profile.model_copy(update={"offset": (lo + hi) / 2, "amplitude": (hi - lo) / 2})
    if isinstance(profile, Constant):
        return profile.model_copy(update={"value": one(profile.value)})
    raise TypeError(f"cannot retarget a {type(profile).__name__} profile")


def muscle_params(config: PopulationConfig, index: int) -> MuscleParams:
    """The ``index``-th muscle as manufactured (its hidden truth)."""
    return config.muscles[index].spec().draw(config.scatter, config.muscle_seed(index))


def muscle_dataset(config: PopulationConfig, index: int) -> HydroMuscleDataset:
    """The ``index``-th muscle's data set: the rig with its drawn muscle, the retargeted logs."""
    muscle, sim = config.muscles[index], config.simulate
    # the valve's slew limit too: the same elongation rate (a wide bore at the reference's slew
    # would jerk the block so hard that the string to the hanging mass goes slack)
    ref, own = sim.reference.params(), muscle.params()
    valve = ValveParams()
    slew = valve.slew * (own.k1 / own.A_eff) / (ref.k1 / ref.A_eff)
    rig = RigParams(
        muscle=muscle_params(config, index), valve=valve.model_copy(update={"slew": slew})
    )
    load = rig.m1 * rig.g
    logs = tuple(
        log.model_copy(update={"profile": retarget(log.profile, sim.reference, muscle, load)})
        if isinstance(log, DynamicLog)
        else log
        for log in sim.logs
    )
    return HydroMuscleDataset(
        seed=config.muscle_seed(index),
        rig=rig,
        sensors=sim.sensors,
        substeps=sim.substeps,
        output=sim.output,
        logs=logs,
    )


def ensure_data(config: PopulationConfig, progress=None) -> list[Path]:
    """Write each muscle's data set where it is missing; the folders, in the muscles' order.

    A folder that exists is read as it is (the shipped data); one that does not is simulated,
    the same bytes every time (seeded)."""
    from hmid.simulate.write import write_dataset

    folders = []
    for index, muscle in enumerate(config.muscles):
        folder = config.data_dir(muscle)
        if not (folder / "index.yaml").exists():
            if progress is not None:
                progress(f"simulating {muscle.name}")
            write_dataset(muscle_dataset(config, index), folder, replace=folder.exists())
        folders.append(folder)
    return folders


def experiment_overrides(config: PopulationConfig, muscle: Muscle, folder: Path) -> dict:
    """The sweep run that identifies ``muscle``: its logs in place of the template's."""

    index = yaml.safe_load((folder / "index.yaml").read_text(encoding="utf-8"))["logs"]
    role = {"dynamic": "dynamic", "free_fall": "free_fall"}
    logs = [
        {
            "path": os.fspath((folder / entry["file"]).resolve()),
            "columns": os.fspath((folder / entry["columns"]).resolve()),
            "role": role[entry["kind"]],
        }
        for entry in index
    ]
    return {"rig.name": f"Hydro Muscle {muscle.name} on the thesis Ch. 4 rig", "logs": logs}


def truth(folder: Path) -> MuscleParams:
    """A written muscle's true parameters (from any of its logs' truth records)."""

    record = json.loads(next(iter(sorted(folder.glob("*.truth.json")))).read_text())
    return MuscleParams(**record["rig"]["muscle"])


def truth_values(folder: Path) -> np.ndarray | None:
    """A written muscle's true parameters in PARAMETERS' order, or None where its data set has
    no truth records (not simulated)."""
    if not any(folder.glob("*.truth.json")):
        return None
    params = truth(folder).model_dump()
    return np.array([params[p] for p in PARAMETERS])
