"""Leave one muscle out: is a muscle predicted from its specifications alone?

For each muscle the population is fitted without it; its parameters are predicted from its
build (90 % predictive intervals, checked against the simulator's truth) and its held-out force
(the last part of each dynamic log, as the per-muscle split holds out) is predicted with the
predictive median. Three comparisons on the same rows: (a) its own fitted SLS model, (b) the
population's mean model without specifications (the other muscles' geometric-mean parameters),
(c) the thesis's way, one other muscle's model used as it is (the median over the others); and,
where the build's exact law is known (simulated muscles), (d) the law's own parameters without
the muscle's manufacturing scatter: the floor of any prediction from specifications alone.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from hmid.io import load_column_map, read_log
from hmid.population._law import ADDITIVE, PARAMETERS
from hmid.population._model import Engine, Priors, Sampler, fit_population
from hmid.population._predict import sls_document
from hmid.population._summary import MuscleFit
from hmid.simulate.specs import MuscleSpec


@dataclass(frozen=True)
class Member:
    """What leave-one-out reads of one muscle."""

    name: str
    spec: MuscleSpec
    fit: MuscleFit
    model: dict  # its own SLS model file's content
    logs: tuple  # its dynamic logs (hmid.Log)
    truth: np.ndarray | None  # the simulator's parameters (PARAMETERS' order), if known


def read_dynamic_logs(folder: Path) -> tuple:
    """A written data set's dynamic logs."""

    index = yaml.safe_load((folder / "index.yaml").read_text(encoding="utf-8"))["logs"]
    return tuple(
        read_log(folder / e["file"], load_column_map(folder / e["columns"]))
        for e in index
        if e["kind"] == "dynamic"
    )


def held_out_rmse(document: dict, logs, fraction: float) -> float:
    """RMSE of the model ``document``'s one-step force on the last ``fraction`` of each log
    (the rows the fit may use: moving, away from the filters' edges)."""
    from hmid.portable import Model

    model = Model(document, None)
    errors = []
    for log in logs:
        pred = model.predict(log)
        t = pred["t"].to_numpy()
        rows = (t >= t[0] + (1 - fraction) * (t[-1] - t[0])) & pred["usable"].to_numpy(bool)
        errors.append((pred["measured"] - pred["predicted"]).to_numpy()[rows])
    e = np.concatenate(errors)
    return float(np.sqrt(np.mean(e**2)))


def mean_model(fits) -> np.ndarray:
    """The population's mean without specifications: geometric means (F0: arithmetic)."""
    means = np.array([f.mean for f in fits])
    geo = np.exp(np.mean(np.log(np.maximum(np.abs(means), 1e-300)), axis=0))
    return np.where([p in ADDITIVE for p in PARAMETERS], means.mean(axis=0), geo)


def leave_one_out(
    muscles: tuple[Member, ...],
    *,
    priors: Priors | None = None,
    sampler: Sampler | None = None,
    interval: float = 0.90,
    fraction: float = 0.3,
    forces: bool = True,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Per fold: the force RMSEs (a table, one row per muscle) and the parameters' predictions
    (one row per muscle and parameter: median, interval, truth, covered)."""
    priors, sampler = priors or Priors(), sampler or Sampler()
    engine = Engine(sampler)
    lo_q, hi_q = (1 - interval) / 2, (1 + interval) / 2
    forces_rows, param_rows = [], []
    for i, out in enumerate(muscles):
        rest = tuple(m for j, m in enumerate(muscles) if j != i)
        fit = fit_population(
            tuple(m.spec for m in rest), tuple(m.fit for m in rest), priors=priors, engine=engine
        )
        draws = fit.predict(out.spec, seed=sampler.seed + i)
        median = np.median(draws, axis=0)
        lo, hi = np.quantile(draws, lo_q, axis=0), np.quantile(draws, hi_q, axis=0)
        param_rows += _parameter_rows(out, median, lo, hi)
        row = {
            "muscle": out.name,
            "r_hat max": float(fit.diagnostics["r_hat"].max()),
            "ess_bulk min": float(fit.diagnostics["ess_bulk"].min()),
            "fit_s": fit.wall_s,
        }
        if forces:
            row |= _force_columns(out, rest, median, fraction)
        forces_rows.append(row)
    return pd.DataFrame(forces_rows), pd.DataFrame(param_rows)


def _parameter_rows(out: Member, median: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> list:
    """The left-out muscle's parameters: predicted, interval, own fit, truth and covered."""
    rows = []
    for k, p in enumerate(PARAMETERS):
        truth = None if out.truth is None else float(out.truth[k])
        rows.append(
            {
                "muscle": out.name,
                "parameter": p,
                "predicted": float(median[k]),
                "lower": float(lo[k]),
                "upper": float(hi[k]),
                "own fit": float(out.fit.mean[k]),
                "truth": truth,
                "covered": None if truth is None else bool(lo[k] <= truth <= hi[k]),
            }
        )
    return rows


def _force_columns(
    out: Member, rest: tuple[Member, ...], median: np.ndarray, fraction: float
) -> dict[str, float]:
    """The left-out muscle's held-out force RMSE by each model: (a)-(d) of the module docstring."""
    own = held_out_rmse(out.model, out.logs, fraction)
    spec = held_out_rmse(sls_document(out.model, "loo", median), out.logs, fraction)
    mean = held_out_rmse(
        sls_document(out.model, "mean", mean_model([m.fit for m in rest])),
        out.logs,
        fraction,
    )
    others = [held_out_rmse(m.model, out.logs, fraction) for m in rest]
    columns = {
        "own model RMSE [N]": own,
        "from specs RMSE [N]": spec,
        "population mean RMSE [N]": mean,
        "one other muscle RMSE [N] (median)": float(np.median(others)),
        "specs / own": spec / own,
        "specs / one other": spec / float(np.median(others)),
    }
    if out.truth is not None:  # simulated: the build's exact law is the simulator's
        exact = out.spec.params()
        law = sls_document(out.model, "law", np.array([getattr(exact, p) for p in PARAMETERS]))
        columns["exact law, no scatter RMSE [N]"] = held_out_rmse(law, out.logs, fraction)
    return columns
