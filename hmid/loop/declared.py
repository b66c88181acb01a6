"""Declared terms are hypotheses too: the rig's known values tested against the dynamic data.

A rig takes some coefficients as known: a ``value:`` of a balance term (a weighed mass times the
acceleration), a known part of the explained quantity (``explained.parts``: the load's mass on a
rig without a force sensor), the free falls' Coulomb level (refitted in the loop's base as dFc,
see :func:`hmid.loop.candidates.level`) and the ``motion`` equation that relates a force sensor
to the acceleration (``explained = mass a + offset``, which free runs use). Each is a hypothesis:

* a known value's **correction** ``d<name>`` is fitted jointly with the loop's base (its column
  is the term's own regressor); where its interval excludes zero, the correction stays in the
  base (the whole loop then starts from the corrected balance, so no candidate can be credited
  with it) and is a finding of its own, said with what could cause it;
* the **motion equation** is a regression of the force sensor on the acceleration; a mass whose
  interval excludes the declared one is a finding (it changes no fit: only free runs use it).

A correction whose column the base already spans (a constant beside the model's own offset), or
nearly spans (its columns explain all but :data:`NEAR_SPAN` of its norm), cannot be told from
the base's terms and is not tested. A part of an explained quantity made of the motion alone (an
inertial force, ``(M + m1) a + m1 g`` on a rig without a force sensor) is not tested either: a
wrong mass there scales the whole balance, which the model's coefficients take up (the load's
acceleration *is* the model's force over the mass); only a run with another known mass tells.
The causes are an honest set: a value, the scale of the channels its regressor reads, or a
force the balance lacks that follows that regressor; these data cannot tell them apart, a run
with a known change of the value would. A value that physics makes positive (``positive:
true``) and that the data put wholly below zero is said as a sign finding, not as a number.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from hmid.balance import Column, Columns, Signals, Term
from hmid.balance.checks import logged_channels
from hmid.balance.terms import unit_of


@dataclass(frozen=True)
class Finding:
    """A declared term found inconsistent with the dynamic data: the tested ``parameter`` (a
    correction such as dFc or dM, or ``motion.mass``) and the one line that says so;
    ``refitted``: its correction is in the loop's base (the motion's mass is in no fit)."""

    parameter: str
    message: str
    refitted: bool = True


@dataclass(frozen=True)
class KnownValue:
    """A coefficient the rig declares known: ``name`` [``unit``] at ``value`` (SI), ``where`` it
    is declared, and its regressor as the balance holds it: the channels' ``powers``, with
    ``sign`` +1 for a term of the balance, -1 for a part of the explained quantity (a larger
    true value there lowers the quantity the model explains)."""

    name: str
    where: str
    value: float
    unit: str
    powers: tuple[tuple[str, int], ...]
    sign: int
    positive: bool
    term: Term | None = None  # the declared balance term (its own columns), if any

    @property
    def correction(self) -> str:
        return f"d{self.name}" if self.name.isidentifier() else f"d({self.name})"

    @property
    def regressor(self) -> str:
        return "·".join(c if p == 1 else f"{c}^{p}" for c, p in self.powers) or "1"


def known_values(rig, signals: Signals) -> tuple[KnownValue, ...]:
    """The rig's known values that a correction can test (not the Coulomb levels: the base
    refits those as dFc): balance terms with a ``value`` and the explained quantity's parts,
    in SI by the logs' units."""
    from hmid.balance.kinds import CoulombTerm, SmoothCoulombTerm

    units = {c: signals.unit(c) for c in rig.model_channels} | {"target": signals.unit("target")}
    out = []
    for term in rig.known:
        if isinstance(term, CoulombTerm | SmoothCoulombTerm) or term.value is None:
            continue
        powers = tuple(term.powers().items())
        out.append(KnownValue(term.name, f"rig.balance ({term.name})", rig.term_value(term, units),
                              unit_of(signals, dict(powers), term.unit), powers, 1, term.positive,
                              term))  # fmt: skip
    # a known part is tested against a logged sensor's part (a force less a known inertia);
    # where the explained quantity is made of the motion alone (an inertial force), a part's
    # correction is a scale of the whole balance, which the model's coefficients take up
    sensors = [i for i, part in enumerate(rig.explained.parts) if _sensor(part, rig)]
    if sensors and len(sensors) < len(rig.explained.parts):
        values = rig.part_values(units | {c: signals.unit(c) for c in rig.explained.channels})
        for i, part in enumerate(rig.explained.parts):
            if i in sensors:
                continue
            powers = tuple(part.powers().items())
            name = part.name or f"{rig.explained.name} part {i}"
            unit = unit_of(signals, dict(powers), part.unit)
            out.append(KnownValue(name, f"rig.explained.parts.{i}", values[i], unit, powers, -1,
                                  False))  # fmt: skip
    return tuple(out)


def _sensor(part, rig) -> bool:
    """Whether an explained part is a logged channel as measured (its scale is the sensor's)."""
    from hmid.balance.rig import DERIVED

    powers = part.powers()
    return (part.value == 1 and part.unit is None and len(powers) == 1
            and set(powers.values()) == {1} and not set(powers) & set(DERIVED))  # fmt: skip


class Corrections(Term):
    """The corrections ``d<name>`` of known values, one column each: the value's regressor with
    the sign it has in the balance (see :class:`KnownValue`)."""

    name = "declared values"

    def __init__(self, known: tuple[KnownValue, ...]) -> None:
        self.known = known

    @property
    def reads(self):
        return tuple(dict.fromkeys(c for k in self.known for c, _ in k.powers))

    def columns(self, signals: Signals, value) -> Columns:
        columns = []
        for k in self.known:
            if k.term is not None:  # the declared term's own column, as the balance took it off
                values = k.term.columns(signals, None).values[:, 0] * k.sign
            else:
                values = np.ones(len(signals))
                for channel, power in k.powers:
                    values = values * signals[channel] ** power
                values = k.sign * values
            reads = tuple(c for c, _ in k.powers)
            columns.append(Column(k.correction, values, k.unit, False, reads))
        return Columns.stack(len(signals), columns)


#: a correction whose column the base's columns explain but this share of (its norm's) is not
#: tested: what remains of it is mostly noise, through which a fit would read a biased value
NEAR_SPAN = 0.05


def testable(known: tuple[KnownValue, ...], base, signals: Signals) -> tuple[KnownValue, ...]:
    """The known values whose correction the base's columns do not span (on its fit rows): a
    constant part beside a model with an offset of its own is not testable on these data."""
    rows = np.flatnonzero(base.rows)
    rows = rows[:: max(1, len(rows) // 4000)]
    design = base.columns.values[rows]
    out = []
    for k in known:
        column = Corrections((k,)).columns(signals, None).values[rows, 0]
        if not np.any(column):
            continue
        coef, *_ = np.linalg.lstsq(design, column, rcond=None)
        if np.linalg.norm(column - design @ coef) > NEAR_SPAN * np.linalg.norm(column):
            out.append(k)
    return tuple(out)


def value_findings(known: tuple[KnownValue, ...], table: pd.DataFrame, position: str | None,
                   scores, unit: str) -> tuple[Finding, ...]:  # fmt: skip
    """Findings for the corrections in ``table`` (the base's parameters, refitted with them)
    whose interval excludes zero; ``scores``: the held-out scores before and after the refit,
    in ``unit`` (the explained quantity's)."""
    rows = table.set_index("parameter")
    before, refitted = scores
    out = []
    for k in known:
        if k.correction not in rows.index:
            continue
        row = rows.loc[k.correction]
        if not (row["lower"] > 0 or row["upper"] < 0):  # NaN: undefined, no finding
            continue
        value, low, high = (k.value + row[c] for c in ("value", "lower", "upper"))
        channels = ", ".join(logged_channels(tuple(c for c, _ in k.powers), position))
        said = (f"{k.name} = {value:.4g} [{low:.4g}, {high:.4g}] {k.unit} on the dynamic data, "
                f"declared {k.value:.4g} {k.unit} in {k.where} ({k.correction} = "
                f"{row['value']:.3g} [{row['lower']:.3g}, {row['upper']:.3g}] {k.unit}; "
                f"refitted, the held-out error goes {before.rmse:.4g} → "
                f"{refitted.rmse:.4g} {unit})")  # fmt: skip
        if k.positive and high < 0:  # a sign, not a number
            said = (f"{k.name} is negative on the dynamic data (its interval {low:.4g} … "
                    f"{high:.4g} {k.unit}; declared {k.value:.4g} {k.unit} in {k.where}), but "
                    f"physics makes it positive: a channel counted the other way ({channels}), "
                    "or the term's declared sign; its value is not estimated")  # fmt: skip
        else:
            said += (f": the declared value is wrong, or the scale of {channels} (its unit or "
                     f"calibration), or the balance lacks a force that follows "
                     f"{k.regressor} as this term does; these data cannot separate them (a run "
                     f"with a known change of {k.name} would)")  # fmt: skip
        out.append(Finding(k.correction, said))
    return tuple(out)


#: the parameter a finding on the motion equation's mass is filed under
MOTION_MASS = "motion.mass"


def motion_finding(rig, signals: Signals, confidence: float) -> Finding | None:
    """The ``motion`` equation (``sensor = mass a + offset``) as a hypothesis, tested on the
    training rows (intervals for a correlated residual). Both sides are measured with noise, so
    the data bound the mass between two regressions: the sensor on the acceleration (its noise
    biases that slope low) and the acceleration on the sensor (the sensor's noise biases the
    mass it implies high). A declared mass outside both intervals is a finding. None where the
    explained quantity is no single logged channel (then it is made of the motion, and the
    corrections of its parts test it) or the mass's sign is wrong (a sign finding says so)."""
    from hmid.balance.inference import inference
    from hmid.balance.rig import DERIVED

    channels = rig.explained.channels
    if rig.motion is None or rig.position is None or len(channels) != 1:
        return None
    sensor = channels[0]
    if sensor in DERIVED or rig.explained.parts[0].channel != sensor:
        return None
    rows = signals.train & signals.usable
    if rows.sum() < 10:
        return None
    a, force, ones = signals["a"], signals[sensor], np.ones(len(signals))
    kg, unit = unit_of(signals, {"a": 1}, "kg"), signals.unit("target")

    def slope(y, x) -> pd.Series:
        columns = Columns(("slope", "offset"), (kg, unit), np.column_stack([x, ones]))
        return inference(columns, y, rows, signals, confidence).set_index("parameter").loc["slope"]

    low, high = slope(force, a), slope(a, force)  # the mass, and its inverse
    declared = rig.motion.mass
    if low["upper"] < 0 or high["lower"] <= 0:
        return None  # a negative mass is the sign check's (hmid.balance.checks)
    bound = (low["lower"], 1 / high["lower"])  # the mass from below, from above
    if bound[0] <= declared <= bound[1]:
        return None
    return Finding(MOTION_MASS, (
        f"the motion's mass is {low['value']:.4g} … {1 / high['value']:.4g} kg on the dynamic "
        f"data ({sensor} on the acceleration, and the reverse; with their intervals "
        f"{bound[0]:.4g} … {bound[1]:.4g} kg), declared {declared:g} kg in rig.motion: the "
        f"declared mass is wrong, or the scale of {sensor} or of {rig.position} (a unit or a "
        f"calibration), or a force on the load that follows its acceleration is missing from "
        f"the motion; these data cannot separate them (a run with a known added mass would). "
        f"Only free runs use the motion: no fit changes"), refitted=False)  # fmt: skip
