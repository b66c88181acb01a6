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

**One family per run.** Every declared term tested in a run (the Coulomb level, each known
value's correction, the motion's mass) is one hypothesis of one family, decided as the loop
decides its candidates (:func:`decide`): each test's p-value, Holm's step-down adjustment over
the run's tests, a finding where the adjusted p is below the loop's ``alpha``. Tested one by
one at the intervals' level, every added test added its 5 % of false findings on clean data
(the blind suite's clean runs: a friction level found wrong in 1 of 10). The intervals the
findings print stay at the loop's ``confidence``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from scipy import stats

from hmid.balance import Column, Columns, Signals, Term
from hmid.balance.checks import logged_channels
from hmid.balance.terms import unit_of
from hmid.stats import holm


@dataclass(frozen=True)
class Finding:
    """A declared term found inconsistent with the dynamic data: the tested ``parameter`` (a
    correction such as dFc or dM, or ``motion.mass``) and the one line that says so;
    ``refitted``: its correction is in the loop's base (the motion's mass is in no fit);
    ``p``: its test's p-value (Holm-adjusted over the run's declared-term tests, once
    :func:`decide` has judged it)."""

    parameter: str
    message: str
    refitted: bool = True
    p: float = float("nan")


#: the parameter the refit of the declared Coulomb level is filed under
LEVEL = "dFc"


def _p(estimate: float, null: float, se: float) -> float:
    """The two-sided p-value of ``estimate`` against ``null`` with standard error ``se``
    (normal: the intervals' t has hundreds of degrees of freedom); NaN where undefined."""
    if not (np.isfinite(estimate) and np.isfinite(se)) or se <= 0:
        return float("nan")
    return float(2 * stats.norm.sf(abs(estimate - null) / se))


def decide(tests: tuple[Finding, ...] | list[Finding], alpha: float) -> tuple[Finding, ...]:
    """The findings among a run's declared-term ``tests``: Holm's step-down over them all (the
    family-wise rate of a false finding stays at ``alpha`` however many terms a rig declares),
    a finding where the adjusted p is below ``alpha``; each message says its adjusted p. A
    NaN p (an undefined test) is no finding."""
    if not tests:
        return ()
    raw = np.array([t.p if np.isfinite(t.p) else 1.0 for t in tests])
    adjusted = holm(raw)
    family = (f"of {len(tests)} declared-term tests" if len(tests) > 1
              else "its run's only declared-term test")  # fmt: skip
    said = "[p = {:.2g}, Holm-adjusted, " + family + f"; α = {alpha:g}]"
    return tuple(
        replace(t, p=float(p), message=f"{t.message} {said.format(p)}")
        for t, p in zip(tests, adjusted, strict=True)
        if p < alpha
    )


def level_test(table: pd.DataFrame, known: str, unit: str, scores, known_se: float = 0.0,
               confidence: float = 0.95) -> Finding | None:  # fmt: skip
    """The declared Coulomb level is a hypothesis: the base's refit of it (dFc) against zero,
    with the uncertainty of both (its standard error and the known level's ``known_se`` in
    quadrature); said with what could cause it (an honest set: these data cannot tell the
    causes apart) and what the refit alone did to the held-out error (never credited to a
    candidate). None where the base has no dFc."""
    rows = table[table["parameter"] == LEVEL]
    if rows.empty:
        return None
    row = rows.iloc[0]
    p = _p(row["value"], 0.0, float(np.hypot(row["std. error"], known_se)))
    before, refitted = scores
    side = "above" if row["value"] > 0 else "below"
    return Finding(LEVEL, (
        f"the dynamic friction level is {abs(row['value']):.3g} {unit} {side} {known} (dFc = "
        f"{row['value']:.3g} [{row['lower']:.3g}, {row['upper']:.3g}] {unit}; refitted alone, "
        f"the held-out error goes {before.rmse:.4g} → {refitted.rmse:.4g} {unit}): a declared "
        "mass or the free-fall drive is wrong, or friction depends on the load, or on the "
        "direction of motion; these data cannot separate them (a free fall with another "
        "hanging mass would)"), p=p)  # fmt: skip


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


def value_tests(known: tuple[KnownValue, ...], table: pd.DataFrame, position: str | None,
                scores, unit: str) -> tuple[Finding, ...]:  # fmt: skip
    """The tests of the corrections in ``table`` (the base's parameters, refitted with them),
    each with its p-value against zero and the message it is said with if found (see
    :func:`decide`); ``scores``: the held-out scores before and after the refit, in ``unit``
    (the explained quantity's)."""
    rows = table.set_index("parameter")
    before, refitted = scores
    out = []
    for k in known:
        if k.correction not in rows.index:
            continue
        row = rows.loc[k.correction]
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
        out.append(Finding(k.correction, said, p=_p(row["value"], 0.0, row["std. error"])))
    return tuple(out)


#: the parameter a finding on the motion equation's mass is filed under
MOTION_MASS = "motion.mass"


def motion_finding(rig, signals: Signals, confidence: float,
                   alpha: float | None = None) -> Finding | None:  # fmt: skip
    """The motion's mass tested alone (:func:`motion_test`), a finding where its p is below
    ``alpha`` (by default ``1 - confidence``: outside both intervals)."""
    test = motion_test(rig, signals, confidence)
    alpha = 1 - confidence if alpha is None else alpha
    return test if test is not None and test.p < alpha else None


def motion_test(rig, signals: Signals, confidence: float) -> Finding | None:
    """The ``motion`` equation (``sensor = mass a + offset``) as a hypothesis, tested on the
    training rows (standard errors for a correlated residual). Both sides are measured with
    noise, so the data bound the mass between two regressions: the sensor on the acceleration
    (its noise biases that slope low) and the acceleration on the sensor (the sensor's noise
    biases the mass it implies high). Its p-value is the test of the declared mass against the
    bound it lies beyond (1 between them): a mass outside both intervals has p below ``1 -
    confidence``. None where the explained quantity is no single logged channel (then it is
    made of the motion, and the corrections of its parts test it) or the mass's sign is wrong
    (a sign finding says so)."""
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
    p = min(_p(low["value"], declared, low["std. error"]) if declared < low["value"] else 1.0,
            _p(high["value"], 1 / declared, high["std. error"])
            if 1 / declared < high["value"] else 1.0)  # fmt: skip
    return Finding(MOTION_MASS, (
        f"the motion's mass is {low['value']:.4g} … {1 / high['value']:.4g} kg on the dynamic "
        f"data ({sensor} on the acceleration, and the reverse; with their intervals "
        f"{bound[0]:.4g} … {bound[1]:.4g} kg), declared {declared:g} kg in rig.motion: the "
        f"declared mass is wrong, or the scale of {sensor} or of {rig.position} (a unit or a "
        f"calibration), or a force on the load that follows its acceleration is missing from "
        f"the motion; these data cannot separate them (a run with a known added mass would). "
        f"Only free runs use the motion: no fit changes"), refitted=False, p=p)  # fmt: skip
