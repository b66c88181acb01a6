"""A fitted model as a model file's content (:mod:`hmid.portable.file`).

Every family states its model as balance terms (:meth:`~hmid.families.FittedModel.structure`).
The file fixes each term's time constant at its fitted value and gives the coefficients that
multiply the terms' columns. A family that keeps them (the ``balance`` family) gives them as
fitted, with their covariance; for the others they are the least-squares solution of the
columns against the model's own predictions on the training rows, which reproduces a model that
is linear in its terms to rounding. Either way the file states the agreement it reaches, so a
model that the terms do not capture (a SINDy variant with its own velocity estimate) says so
rather than being exported as something it is not.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from hmid import __version__
from hmid.balance import Structure
from hmid.balance.kinds import Grid, TermSpec
from hmid.families import FitData, Fitted
from hmid.portable.file import FORMAT


def fixed_terms(structure: Structure) -> tuple[TermSpec, ...]:
    """The structure's terms, each profiled one at its value (its grid field replaced by it)."""
    out = []
    for placed in structure.terms:
        term = placed.term
        assert isinstance(term, TermSpec)  # a balance of declared terms (not loop candidates)
        grids = [name for name in type(term).model_fields if isinstance(getattr(term, name), Grid)]
        if grids and placed.value is not None:
            term = term.model_copy(update={grids[0]: float(placed.value)})
        out.append(term)
    return tuple(out)


def term_dicts(terms) -> list[dict]:
    return [t.model_dump(mode="json", by_alias=True) for t in terms]


def _coefficients(fitted: Fitted, data: FitData, terms) -> tuple[dict, dict]:
    """The coefficients of ``terms``' columns, and their agreement with the model's own
    one-step predictions on the training rows."""
    # only the training rows, and nothing kept for the next model: the terms' columns of a long
    # log, held for every model, cost several times the log
    with data.signals.scoped():
        columns = Structure.of(terms).columns(data.signals, rows=data.rows)
    values = columns.values
    predicted = fitted.predict(data)
    own = getattr(fitted.model, "coef", None)
    if own is not None and tuple(getattr(fitted.model, "names", ())) == tuple(columns.names):
        coef, source = np.asarray(own, dtype=float), "as fitted"
    else:
        # columns scaled to unit norm first: x³ in m³ beside a constant is otherwise ill-posed
        norms = np.linalg.norm(values, axis=0)
        norms[norms == 0] = 1.0
        coef = np.linalg.lstsq(values / norms, predicted, rcond=None)[0] / norms
        source = "least squares of the terms' columns on the model's training predictions"
    gap = values @ coef - predicted
    scale = float(np.sqrt(np.mean(predicted**2))) or 1.0
    agreement = {
        "rows": len(predicted),
        "max_abs": float(np.max(np.abs(gap))) if len(gap) else 0.0,
        "relative_rms": float(np.sqrt(np.mean(gap**2)) / scale) if len(gap) else 0.0,
    }
    covariance = getattr(fitted.model, "covariance", None)
    coefficients = {
        "names": list(columns.names),
        "values": [float(c) for c in coef],
        "covariance": None if covariance is None else np.asarray(covariance).tolist(),
        "source": source,
    }
    return coefficients, agreement


def known_law(friction) -> dict | None:
    """The free-fall friction law as (Fc, b): magnitude Fc + b |v| (None without one)."""
    if friction is None:
        return None
    from hmid.friction import affine_friction

    Fc, b = affine_friction(friction)
    return {"law": "(Fc + b |v|) sign(v)", "Fc": Fc, "b": b, "unit": "N"}


def model_document(
    fitted: Fitted, data: FitData, *, units: dict, denoise: dict, fit: dict, friction=None,
    posterior: str | None = None,
) -> dict:  # fmt: skip
    """The model file's content for ``fitted`` (``data``: its training rows)."""
    terms = fixed_terms(fitted.model.structure())
    coefficients, agreement = _coefficients(fitted, data, terms)
    t = data.signals["t"]
    steps = np.diff(t)
    steps = steps[steps > 0]
    table = fitted.coefficient_table()
    return {
        "format": FORMAT,
        "hmid_version": __version__,
        "name": fitted.name,
        "family": fitted.family,
        "kind": fitted.kind,
        "rig": data.rig.model_dump(mode="json", by_alias=True),
        "units": dict(units),
        "denoise": denoise,
        "fit": fit,
        "sample_rate_hz": float(1.0 / np.median(steps)) if len(steps) else None,
        "known": {"free_fall_friction": known_law(friction)},
        "terms": term_dicts(terms),
        "coefficients": coefficients,
        "agreement": agreement,
        "parameters": _records(table),
        "interval": None if fitted.interval is None else fitted.interval.columns(),
        "residual": _residual(fitted),
        "equation": fitted.equation,
        "posterior": posterior,
    }


def _residual(fitted: Fitted) -> dict:
    """The training residual's RMS and integrated autocorrelation time [rows]: the force the
    model leaves unexplained, which a free run's band carries as a disturbance."""
    summary = fitted.fit_summary
    tau = summary.tau_int
    if tau is None and fitted.interval is not None:
        tau = fitted.interval.tau_int
    return {"rmse": float(summary.rmse), "tau_int": None if tau is None else float(tau)}


def _records(table: pd.DataFrame) -> list[dict]:
    frame = table.reset_index() if "parameter" not in table.columns else table
    return [
        {str(k): (v.item() if hasattr(v, "item") else v) for k, v in row.items()}
        for row in frame.to_dict(orient="records")
    ]
