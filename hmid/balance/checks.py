"""Physical-sign checks: a parameter that physics makes positive, fitted with its whole interval
below zero, is not a finding about the rig but about the set-up; say what is likely wrong."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import pandas as pd

from hmid.balance.rig import DERIVED


@dataclass(frozen=True)
class SignFinding:
    """``parameter`` of ``model`` lies below zero (its whole interval) although it is positive."""

    model: str
    parameter: str
    value: float
    lower: float
    upper: float
    unit: str
    channels: tuple[str, ...]  # the logged channels its column reads

    def message(self) -> str:
        causes = []
        if self.channels:
            keys = ", ".join(f"rig.channels.{c}.sign" for c in self.channels)
            causes.append(
                f"a channel counted the other way ({', '.join(self.channels)}: set {keys}: -1)"
            )
        causes += [
            "a term declared with the wrong sign in rig.balance",
            "a missing term that this one stands in for",
            "a wrong unit or calibration",
        ]
        return (
            f"{self.model}: {self.parameter} = {self.value:.4g} {self.unit} "
            f"(interval {self.lower:.4g} … {self.upper:.4g}) is negative, but physics makes it "
            f"positive; likely causes: {'; '.join(causes)}"
        )

    def to_dict(self) -> dict:
        return {
            "model": self.model,
            "parameter": self.parameter,
            "value": self.value,
            "lower": self.lower,
            "upper": self.upper,
            "unit": self.unit,
            "channels": list(self.channels),
            "message": self.message(),
        }


def logged_channels(reads: tuple[str, ...], position: str | None) -> tuple[str, ...]:
    """The logged channels behind ``reads``: v and a stand for the position they come from."""
    out = [position if c in DERIVED and position is not None else c for c in reads]
    return tuple(dict.fromkeys(out))


def sign_findings(
    model: str,
    table: pd.DataFrame,
    reads: Mapping[str, tuple[str, ...]],
    position: str | None,
) -> tuple[SignFinding, ...]:
    """Findings for the rows of ``table`` (parameter, value, lower, upper, unit, positive) whose
    parameter is positive by physics and whose interval lies below zero; ``reads`` maps a
    parameter to the channels its column reads."""
    found = []
    for row in table.itertuples(index=False):
        if bool(getattr(row, "positive", False)) and row.upper < 0:
            found.append(
                SignFinding(
                    model,
                    str(row.parameter),
                    float(row.value),
                    float(row.lower),
                    float(row.upper),
                    str(row.unit),
                    logged_channels(tuple(reads.get(row.parameter, ())), position),
                )
            )
    return tuple(found)
