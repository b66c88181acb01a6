"""hmid's exceptions and warnings.

Every error hmid raises on bad input is one line that names the file, the column or key (and the
row where relevant) and says how to fix it. Callers catch :class:`HmidError` to tell hmid's own
clear errors from bugs.
"""

from __future__ import annotations


class HmidError(Exception):
    """Base class of every error hmid raises deliberately."""


class LogError(HmidError, ValueError):
    """A log file or table is malformed (missing column, NaN, bad time base, ...)."""


class UnitError(LogError):
    """A unit is unknown or has the wrong dimension for its channel."""


class DataError(HmidError, ValueError):
    """The data are implausible for the rig (``hmid run --strict``: a finding is an error)."""


class ConfigError(HmidError, ValueError):
    """A configuration file or object is invalid (unknown key, wrong type, impossible value)."""


class SignalError(HmidError, ValueError):
    """A signal cannot be processed as asked (window longer than the log, non-finite input)."""


class FitError(HmidError, RuntimeError):
    """No model of an experiment could be fitted (each failure said with its reason)."""


class SimulationError(HmidError, RuntimeError):
    """A simulation left the model's domain of validity (e.g. the rig's string went slack)."""


class HmidWarning(UserWarning):
    """Something the user should see but that does not stop the work (e.g. ADC saturation)."""


def where(source: str | None, column: str | None = None, row: int | None = None) -> str:
    """Prefix ``"file: column 'c' row r: "`` for one-line messages; None parts are left out."""
    parts = [source or "<table>"]
    if column is not None:
        parts.append(f"column {column!r}")
    if row is not None:
        parts.append(f"row {row}")
    return " ".join(parts[:1]) + (": " + " ".join(parts[1:]) if len(parts) > 1 else "") + ": "


def one_line(err: BaseException, limit: int = 200, *, name_foreign: bool = False) -> str:
    """An exception's text on one line, at most ``limit`` characters; ``name_foreign``: a
    library's own error (not an :class:`HmidError`) is prefixed with its type, so that it is
    never read as one of hmid's messages."""
    text = str(err)
    if name_foreign and not isinstance(err, HmidError):
        text = f"{type(err).__name__}: {text}"
    text = " ".join(text.split()) or type(err).__name__
    return text if len(text) <= limit else text[: limit - 3] + "..."
