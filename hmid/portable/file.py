"""The portable model file: one JSON document per fitted model.

A model of hmid is a sum of balance terms (``rig.balance``'s kinds, each at a fixed value of its
time constant) times coefficients, evaluated on the signals as hmid prepares them: the logged
channels through the run's zero-phase moving average, v and a derivatives of the smoothed
position, a term that is not linear in the signals (``sign(v)``, ``x^3`` of a logged channel)
evaluated on the unsmoothed signal and smoothed after. The file says all of it, so that another
program can evaluate the model without hmid (``tests/portable/reference.py`` does, with numpy
alone)::

    format            "hmid-model/1"
    name, family      the fitted model and its family
    rig               the rig section as declared (convention, channels, balance, motion)
    units             SI unit of every channel and of the explained quantity and the target
    denoise, fit      the smoother, the derivative, the low-speed cut the model was fitted with
    sample_rate_hz    of the training logs (the smoother's window in samples follows from it)
    known             the known terms' law: free-fall friction (Fc + b |v|) sign(v), if any
    terms             the model's terms, in order (kind, name, sign, channel, tau / time fixed)
    coefficients      names, values and covariance (null where the family gives none) of the
                      terms: target = sum_k coef_k column_k (the signs are in the columns)
    agreement         how far the file's evaluation is from the fitted model's own predictions
                      on the training rows (relative to their RMS)
    parameters        the family's parameter table: value, unit, interval, method, calibration
    equation          as the report prints it
    posterior         the file of the posterior draws (ArviZ netCDF), where the family has them

Files are written atomically (a temporary file renamed), never overwritten in a run folder.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from hmid.errors import ConfigError
from hmid.files import write_json

FORMAT = "hmid-model/1"


def _finite(value: Any) -> Any:
    """JSON has no NaN or infinity: they are written as null."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value


def write_model_file(document: dict, path: Path) -> Path:
    """Write ``document`` (a model file's content) to ``path`` atomically."""
    write_json(Path(path), _finite(document))
    return Path(path)


def read_model_file(path: str | Path) -> dict:
    """A model file's content, checked to be one (a one-line ConfigError names the file)."""
    path = Path(path)
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ConfigError(f"{path}: not a readable model file ({err})") from None
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        found = document.get("format") if isinstance(document, dict) else type(document).__name__
        raise ConfigError(f"{path}: format {found!r} is not {FORMAT!r}; is it an hmid model file?")
    missing = [k for k in ("rig", "units", "denoise", "terms", "coefficients") if k not in document]
    if missing:
        raise ConfigError(f"{path}: model file lacks {missing}")
    return document
