"""Physical-sign checks: a parameter that physics makes positive, fitted with its whole interval
below zero, is not a finding about the rig but about the set-up; say what is likely wrong."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hmid.balance.rig import DERIVED
from hmid.errors import HmidError


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
    causes: tuple[str, ...] = ()  # the likely causes where they are known (else the usual ones)

    def message(self) -> str:
        if self.causes:
            return self._said(list(self.causes))
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
        return self._said(causes)

    def _said(self, causes: list[str]) -> str:
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


def friction_findings(estimate, rig) -> tuple[SignFinding, ...]:
    """The free falls' friction parameters (positive by physics) whose interval lies below zero,
    with the declaration likely at fault: a fall faster than ``drive / mass`` allows says the
    mass is too large or the drive too small (the mass that fits is named), or the position's
    unit or sign is wrong."""
    if estimate is None or rig.free_fall is None:
        return ()
    found = []
    fall, position = rig.free_fall, rig.position
    for name, value in estimate.params.items():
        low, high = estimate.ci[name]
        if high >= 0:
            continue
        causes = []
        if name == "Fc":  # mass u'' = drive - Fc: the falls' deceleration, and the mass it allows
            accel = (fall.drive - value) / fall.mass
            if accel > 0:
                causes.append(
                    f"free_fall.mass {fall.mass:g} kg too large: the falls accelerate at "
                    f"{accel:.3g} m/s², which drive {fall.drive:g} N gives a mass of at most "
                    f"{fall.drive / accel:.3g} kg"
                )
            causes.append(f"free_fall.drive {fall.drive:g} N too small")
        causes += [
            f"a wrong unit of {position} (its scale is the falls' acceleration)",
            f"{position} counted the other way (rig.channels.{position}.sign)",
        ]
        found.append(
            SignFinding(
                "friction from free falls",
                name,
                float(value),
                float(low),
                float(high),
                estimate.units.get(name, ""),
                (position,),
                tuple(causes),
            )
        )
    return tuple(found)


def motion_findings(rig, signals) -> tuple[SignFinding, ...]:
    """The rig's ``motion`` (``explained = mass * a + offset``) checked for its sign on the rows
    the balance fits: a force sensor that reads the inertial force must grow with the
    acceleration; it falls when the position (or the force) is counted the other way, whatever
    family is fitted."""
    explained = rig.explained.channels
    if rig.motion is None or rig.position is None or len(explained) != 1:
        return ()
    if explained[0] in DERIVED or rig.explained.parts[0].channel != explained[0]:
        return ()  # the explained quantity is made of the motion itself: nothing to check
    rows, y_all, a_all = signals.usable, signals[explained[0]], signals["a"]
    sums = np.zeros(6)  # n, Σa, Σy, Σa², Σay, Σy²: block by block, no copy of a long log
    for lo in range(0, len(rows), 1 << 20):
        block = slice(lo, lo + (1 << 20))
        a, y = a_all[block][rows[block]], y_all[block][rows[block]]
        sums += (len(a), a.sum(), y.sum(), a @ a, a @ y, y @ y)
    n, sa, sy, saa, say, syy = sums
    if n < 10:
        return ()
    ssa, sxy, ssy = saa - sa * sa / n, say - sa * sy / n, syy - sy * sy / n
    if ssa <= 0:
        return ()
    slope = sxy / ssa
    se = float(np.sqrt(max(ssy - slope * sxy, 0.0) / max(n - 2, 1) / ssa))
    if slope + 4 * se >= 0:  # well beyond any noise: a sign, not a scatter
        return ()
    target = explained[0]
    return (
        SignFinding(
            "rig motion", "mass", slope, slope - 4 * se, slope + 4 * se, "kg",
            (rig.position, target),
            (f"{rig.position} counted the other way: {target} falls as the acceleration "
             f"d²{rig.position}/dt² grows, but rig.motion declares {target} = "
             f"{rig.motion.mass:g} kg · a + offset (set rig.channels.{rig.position}.sign: -1)",
             f"{target} counted the other way (its column map's scale)"),
        ),
    )  # fmt: skip


def declared_positive(
    model: str, table: pd.DataFrame, positive, position: str | None
) -> tuple[SignFinding, ...]:
    """Sign findings of a family's coefficient table (``term``, ``value``, ``unit`` and the
    ``ci_low``/``ci_high`` columns) for the terms its config declares ``positive``."""
    if not positive:
        return ()
    from hmid.balance.monomial import Monomial

    low, high = (c for c in table.columns if c.startswith("ci_"))
    rows = pd.DataFrame(
        {"parameter": table["term"], "value": table["value"], "lower": table[low],
         "upper": table[high], "unit": table["unit"], "positive": table["term"].isin(positive)}
    )  # fmt: skip
    reads = {}
    for term in positive:
        try:
            reads[term] = Monomial.parse(term).variables
        except (ValueError, HmidError):  # a term that is no monomial (tanh(v/v0)): v's
            reads[term] = tuple(c for c in ("x", "v", "P") if c in term)
    return sign_findings(model, rows, reads, position)
