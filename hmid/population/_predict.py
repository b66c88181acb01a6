"""A new muscle's force model from its specifications: an SLS model file that ``hmid.load_model``
reads, with the population's predictive uncertainty.

The file is the standard ``hmid-model/1`` document of the SLS family (the rig, units, smoother
and friction of the population's per-muscle experiment, taken from one muscle's exported model):
its coefficients are the predictive medians of A_eff, F0, k1, k3 and k2 with their predictive
covariance, its memory term's tau the predictive median, its parameter table the predictive
intervals. A controller (the ankle's) reads it like any fitted model; ``population`` in the
file says where it came from.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np

from hmid.population._law import PARAMETERS, UNITS
from hmid.population._model import PopulationFit
from hmid.simulate.specs import MuscleSpec

#: The model file's coefficient names (the SLS terms, in order); tau sits in the memory term.
COEFFICIENTS = ("A_eff", "F0", "k1", "k3", "k2")


def parameter_table(draws: np.ndarray, interval: float, label: str) -> list[dict[str, Any]]:
    """Median, interval, mean and sd of each parameter's draws (the model file's records)."""
    lo, hi = (1 - interval) / 2, (1 + interval) / 2
    out = []
    for k, name in enumerate(PARAMETERS):
        col = draws[:, k]
        out.append(
            {
                "parameter": name,
                "median": float(np.median(col)),
                "lower": float(np.quantile(col, lo)),
                "upper": float(np.quantile(col, hi)),
                "mean": float(np.mean(col)),
                "sd": float(np.std(col, ddof=1)),
                "unit": UNITS[name],
                "interval": label,
                "calibration": "leave-one-out coverage in the population report",
            }
        )
    return out


def sls_document(template: dict, name: str, values: np.ndarray, covariance=None) -> dict:
    """``template`` (an SLS model file's content) with the parameters ``values`` (PARAMETERS'
    order) and the coefficients' ``covariance`` (5 x 5, or None)."""
    doc = copy.deepcopy(template)
    doc["name"] = name
    for term in doc["terms"]:
        if term["kind"] == "memory":
            term["tau"] = float(values[PARAMETERS.index("tau")])
    coef = [float(values[PARAMETERS.index(c)]) for c in COEFFICIENTS]
    doc["coefficients"] = {
        "names": list(COEFFICIENTS),
        "values": coef,
        "covariance": None if covariance is None else np.asarray(covariance).tolist(),
        "source": "the population's prediction from the muscle's specifications",
    }
    doc["agreement"] = {"rows": 0, "max_abs": 0.0, "relative_rms": 0.0}
    doc["posterior"] = None
    shown = ", ".join(f"{p} = {v:.4g} {UNITS[p]}" for p, v in zip(PARAMETERS, values, strict=True))
    doc["equation"] = "F_m = A_eff·P + F0 − (k1·x + k3·x³ + q), dq/dt = −q/τ + k2·dx/dt; " + shown
    return doc


def predicted_document(
    fit: PopulationFit,
    spec: MuscleSpec,
    template: dict,
    *,
    name: str = "population",
    interval: float = 0.90,
    seed: int = 0,
) -> dict:
    """The model file's content of a new muscle of build ``spec``, predicted by ``fit``."""
    draws = fit.predict(spec, seed)
    median = np.median(draws, axis=0)
    cols = [PARAMETERS.index(c) for c in COEFFICIENTS]
    doc = sls_document(template, name, median, np.cov(draws[:, cols], rowvar=False))
    label = f"{round(100 * interval)} % posterior predictive (population)"
    doc["parameters"] = parameter_table(draws, interval, label)
    doc["interval"] = {"interval": label, "calibration": "see the population report"}
    doc["population"] = {
        "specifications": spec.model_dump(mode="json"),
        "muscles": list(fit.names),
        "draws": len(draws),
    }
    return doc


def predict_muscle(population_run: str | Path, spec: MuscleSpec | dict, *, seed: int = 0):
    """The predicted force model (:class:`hmid.Model`) of a new muscle of build ``spec``, from a
    finished ``hmid population`` run folder (its saved population posterior)."""
    from hmid.population._store import load_fit
    from hmid.portable import Model

    spec = spec if isinstance(spec, MuscleSpec) else MuscleSpec(**spec)
    folder = Path(population_run)
    fit, template = load_fit(folder)
    doc = predicted_document(fit, spec, template, seed=seed)
    return Model(doc, (folder / "models" / "predicted.json").resolve())
