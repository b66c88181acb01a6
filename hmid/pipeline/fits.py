"""The fit stage's artifact: the models that converged, and those that did not with the reason.

One family's failure is not the run's failure. A fit that raises one of hmid's own errors (a
Levenberg-Marquardt start that does not converge) or a numerical one, or that *diverges* (a
non-finite parameter or prediction, or a prediction orders of magnitude above the force it
models: an SLS relaxation time of 1e198 s drifts without bound on logs it did not see), is
marked failed with its one-line reason and left out; the comparison, the exports and the loop
go on with the others, and the report and the console name it.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hmid.errors import HmidError
from hmid.families import FitContext, FitData, Fitted

#: a prediction whose RMS exceeds this many times the RMS of the force it was fitted to has
#: diverged: no model of a rig predicts forces ten times those it was trained on
DIVERGED = 10.0

#: a parameter of larger magnitude (SI units) is beyond any physical range: a relaxation time of
#: 1e198 s, a coefficient that ran off along a flat valley
BEYOND = 1e30

#: what a family's fit may raise on data it cannot fit (a bug raises anything else)
FIT_ERRORS = (HmidError, ArithmeticError, np.linalg.LinAlgError)


@dataclass(frozen=True)
class Failed:
    """A model whose fit failed: its name (or its family's entry), family and why."""

    name: str
    family: str
    reason: str

    def message(self) -> str:
        return f"{self.name} ({self.family}) failed and is left out: {self.reason}"


@dataclass(frozen=True)
class Fits(Sequence[Fitted]):
    """The converged models (a sequence of :class:`~hmid.families.Fitted`, in config order)
    and the failed ones."""

    fitted: tuple[Fitted, ...]
    failed: tuple[Failed, ...] = ()

    def __getitem__(self, index):
        return self.fitted[index]

    def __len__(self) -> int:
        return len(self.fitted)

    def __iter__(self) -> Iterator[Fitted]:
        return iter(self.fitted)


def fit_or_fail(spec, data: FitData, context: FitContext) -> tuple[list[Fitted], list[Failed]]:
    """``spec``'s models fitted on ``data``, each checked for divergence; a fit that raises
    one of :data:`FIT_ERRORS` is one failure named after the family's first model."""
    try:
        models = spec.fit(data, context)
    except FIT_ERRORS as err:
        name = spec.model_names()[0]
        return [], [Failed(name, spec.family, " ".join(str(err).split()))]
    good, failed = [], []
    for model in models:
        reason = diverged(model, data)
        if reason is None:
            good.append(model)
        else:
            failed.append(Failed(model.name, model.family, reason))
    return good, failed


def diverged(model: Fitted, data: FitData) -> str | None:
    """Why ``model`` has diverged (None if it has not): a parameter beyond any physical
    range (a left-out term may read NaN), a non-finite
    prediction on the rows it was fitted on, or a prediction on the training or held-out rows
    whose RMS is :data:`DIVERGED` times the training force's (only predictions are read on the
    held-out rows, never the force there)."""
    table = model.coefficients
    for column in ("value", "median"):  # a point estimate, as the families name it
        if column in table:
            values = pd.to_numeric(table[column], errors="coerce").to_numpy(dtype=float)
            names = table.iloc[:, 0].astype(str)
            bad = [n for n, v in zip(names, values, strict=True) if abs(v) > BEYOND]
            if bad:
                return f"parameters {bad} are beyond any physical range (|value| > {BEYOND:g})"
    y = data.y  # a copy of the training rows' target: taken once, squared in place
    finite = np.isfinite(y)
    if not finite.all():
        y = y[finite]
    del finite
    scale = float(np.sqrt(np.mean(np.square(y, out=y)))) if len(y) else 0.0
    del y  # not held beside the predictions
    for role in ("train", "validation"):
        part = data.as_role(role)
        if not part.rows.any():
            continue
        prediction = model.predict(part)
        used = prediction[np.isfinite(prediction)]  # a copy: squared in place
        if role == "train" and len(used) < len(prediction):
            return f"its prediction is not finite on {len(prediction) - len(used)} training rows"
        del prediction
        rms = float(np.sqrt(np.mean(np.square(used, out=used)))) if len(used) else 0.0
        del used
        if scale > 0 and rms > DIVERGED * scale:
            where = "training" if role == "train" else "held-out"
            return (
                f"it diverged: its prediction on the {where} rows has RMS {rms:.4g}, "
                f"{rms / scale:.3g} times the training force's {scale:.4g}"
            )
    return None
