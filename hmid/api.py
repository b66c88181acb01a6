"""hmid from Python: run an experiment, or load a finished run, and use its models.

::

    import hmid
    run = hmid.load_run("results/demo/<run-id>")     # or hmid.run("configs/demo.yaml")
    sls = run.models["sls"]
    sls.parameters                    # value, unit, interval, method, calibration
    sls.predict(log)                  # one-step: the explained quantity on a hmid.Log
    sls.free_run(log).scores()        # free run from the log's inputs and first state
    sls.simulate(t, {"P": p}, x0=0.01)  # free run from any state and input
    sls.posterior                     # ArviZ InferenceData (families with a posterior)

A run's models are read from its model files (``models/<name>.json``), so what Python sees is
what a controller or another language reads.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import pandas as pd
import yaml

from hmid.errors import ConfigError
from hmid.portable import Model, load_model


@dataclass(frozen=True)
class Run:
    """A finished run folder (``results/<experiment>/<run-id>``)."""

    folder: Path
    metrics: dict = field(repr=False)

    @cached_property
    def models(self) -> dict[str, Model]:
        """Every exported model, by name (``run.models["sls"]``)."""
        files = self.metrics.get("model_files") or {}
        return {
            name: load_model(self.folder / where)
            for name, where in files.items()
            if where.endswith(".json")
        }

    @property
    def best(self) -> str:
        """The model with the lowest held-out one-step RMSE."""
        return self.metrics["best_model"]

    @cached_property
    def scores(self) -> pd.DataFrame:
        """Held-out scores per model: one-step, and free-run where the rig has a motion."""
        one_step = pd.read_csv(self.folder / "tables" / "held_out_scores.csv")
        free = self.folder / "tables" / "free_run_scores.csv"
        if not free.exists():
            return one_step
        return one_step.merge(pd.read_csv(free), on="model", how="left", suffixes=("", " (free)"))

    @property
    def loop(self) -> dict | None:
        """What the loop added and the held-out error before and after (None without a loop)."""
        return self.metrics.get("loop")

    @cached_property
    def rig(self):
        """The rig section the run declared (:class:`~hmid.balance.RigSection`)."""
        from hmid.balance import RigSection

        config = yaml.safe_load((self.folder / "config.yaml").read_text(encoding="utf-8"))
        return RigSection.model_validate(config["rig"])


def load_run(folder: str | Path) -> Run:
    """A finished run from its folder; a folder that is not one is a one-line ConfigError."""
    folder = Path(folder)
    metrics = folder / "metrics.json"
    if not metrics.is_file():
        raise ConfigError(f"{folder}: no metrics.json; is it a complete hmid run folder?")
    return Run(folder.resolve(), json.loads(metrics.read_text(encoding="utf-8")))


def run(config: str | Path, *, results: str | Path = "results", force: bool = False) -> Run:
    """Run the experiment ``config`` (a new run folder under ``results``) and load it."""
    from pipelines.identify import run as identify

    folder, _ = identify(Path(config), results=Path(results), force=force)
    return load_run(folder)
