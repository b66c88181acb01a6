"""The population config: the muscles (their specifications), their data, and the population fit.

A population file (``configs/population/muscles.yaml``) declares::

    name: muscles
    seed: 20170427                  # the data's and the sampler's
    experiment: muscle.yaml         # the per-muscle identification (an experiment config whose
                                    # logs are replaced by each muscle's)
    data: ../../data/population     # each muscle's simulated data set, <data>/<muscle>/
    simulate: {...}                 # the data set of one muscle: sensors, logs (pressures for
                                    # the reference muscle; retargeted to each muscle's specs)
    scatter: {...}                  # the hidden manufacturing scatter (hmid.simulate.specs)
    muscles:                        # name + specifications (hmid.simulate.specs.MuscleSpec)
      - {name: soleus, length: 0.16, inner_diameter: 0.030, outer_diameter: 0.037}
    law: {exponent_sd: 0.5, ...}    # the hierarchical model's priors
    sampler: {chains: 2, warmup: 500, draws: 500}
    executor: {kind: process, workers: 2}

Paths are relative to the file's folder; unknown keys and bad values are one-line ConfigErrors.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, model_validator

from hmid.config import load_yaml_model
from hmid.simulate.dataset import Name
from hmid.simulate.params import Sensors
from hmid.simulate.rigs.hydro_muscle_dataset import LogSpec, Output
from hmid.simulate.specs import MuscleSpec, Scatter
from hmid.sweep import ExecutorSection


class _Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Muscle(MuscleSpec):
    """One muscle of the population: a name and its specifications."""

    name: Name
    description: str = ""

    def spec(self) -> MuscleSpec:
        """The specifications alone (what a prediction reads)."""
        return MuscleSpec(**self.model_dump(exclude={"name", "description"}))


class SimulateSection(_Frozen):
    """One muscle's data set on the Ch. 4 rig. The dynamic logs' pressures are those that move
    the ``reference`` muscle; each muscle gets the pressures that give the same elongations on
    its own specifications (:func:`hmid.population.retarget`)."""

    reference: MuscleSpec = MuscleSpec()
    sensors: Sensors = Sensors()
    substeps: Annotated[int, Field(ge=1, le=1000)] = 20
    output: Output = Output()
    logs: Annotated[tuple[LogSpec, ...], Field(min_length=1)]


class LawSection(_Frozen):
    """Priors of the hierarchical model: exponents centred on the physically expected values
    with ``exponent_sd``; log-intercepts N(0, ``intercept_sd``) around the population's typical
    value; the muscle-to-muscle scatter log-normal about ``scatter_typical`` with
    ``scatter_log_sd`` (log scale; F0's, which is additive, in units of its typical value; why
    this prior: :mod:`hmid.population._model`)."""

    exponent_sd: Annotated[float, Field(gt=0)] = 0.5
    intercept_sd: Annotated[float, Field(gt=0)] = 3.0
    scatter_typical: Annotated[float, Field(gt=0)] = 0.1
    scatter_log_sd: Annotated[float, Field(gt=0)] = 1.0
    interval: Annotated[float, Field(gt=0.5, lt=1)] = 0.90


class SamplerSection(_Frozen):
    """NumPyro NUTS: chains (run one after the other), warm-up and kept draws per chain."""

    chains: Annotated[int, Field(ge=1, le=16)] = 2
    warmup: Annotated[int, Field(ge=50)] = 500
    draws: Annotated[int, Field(ge=50)] = 500
    target_accept: Annotated[float, Field(gt=0.5, lt=1)] = 0.9


class PopulationConfig(_Frozen):
    """A population study: muscles with specifications, their data and the population fit."""

    name: Name
    seed: Annotated[int, Field(ge=0)]
    experiment: Path
    data: Path
    simulate: SimulateSection
    scatter: Scatter = Scatter()
    muscles: Annotated[tuple[Muscle, ...], Field(min_length=1)]
    law: LawSection = LawSection()
    sampler: SamplerSection = SamplerSection()
    leave_one_out: bool = True
    executor: ExecutorSection = ExecutorSection()
    base_dir: Path = Path(".")

    @model_validator(mode="after")
    def _unique(self) -> PopulationConfig:
        names = [m.name for m in self.muscles]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise ValueError(f"muscle names must be unique; repeated: {dupes}")
        if self.leave_one_out and len(self.muscles) < 3:
            raise ValueError("leave_one_out needs at least 3 muscles (set it false)")
        return self

    def resolve(self, path: Path) -> Path:
        return path if path.is_absolute() else (self.base_dir / path)

    def data_dir(self, muscle: Muscle) -> Path:
        """Where ``muscle``'s data set lies."""
        return self.resolve(self.data) / muscle.name

    def muscle_seed(self, index: int) -> int:
        """The seed of the ``index``-th muscle's data and scatter (from the population's)."""
        return (self.seed * 1_000_003 + 7919 * (index + 1)) % 2**31


def load_population(path: str | Path) -> PopulationConfig:
    """Read a population config (paths relative to its folder)."""
    path = Path(path)
    config = load_yaml_model(path, PopulationConfig, "population config")
    return config.model_copy(update={"base_dir": path.resolve().parent})
