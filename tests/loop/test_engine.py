"""The loop on synthetic cylinder data: the right effect and its parameter from the whole
library, rivals said out loud, decisions blind to the reported rows, and honest endings."""

import re

import numpy as np
import pytest
from _loop_data import loop_on

from hmid.loop import LoopSpec, Verdict
from hmid.loop.decision import ACROSS, LABELS

SPEC = LoopSpec(base="balance")  # the whole library the cylinder is offered


def _interval(effect, name):
    row = effect.parameters.set_index("parameter").loc[name]
    return row["value"], row["lower"], row["upper"]


def viscous(frame):
    return -12.0 * frame["v"], {"b": 12.0}


def direction_viscous(frame):
    return -10.0 * frame["v"] * (frame["v"] > 0), {"b_pos": 10.0}


def stribeck(frame):
    v = frame["v"]
    return -1.5 * np.sign(v) * np.exp(-((v / 0.01) ** 2)), {"delta": 1.5, "v_s": 0.01}


def pressure_friction(frame):
    return -4e-6 * frame["P"] * np.sign(frame["v"]), {"h_P": 4e-6}


def position_friction(frame):
    return -60.0 * frame["x"] * np.sign(frame["v"]), {"h_x": 60.0}


def zero_drift(frame):
    return 0.4 * frame["t"] / frame["t"].max(), {"D": 0.4}


@pytest.mark.parametrize(
    ("effect", "name", "parameter"),
    [
        (viscous, "viscous", "b"),
        (direction_viscous, "viscous.direction", "b_pos"),
        (stribeck, "stribeck", "delta"),
        (pressure_friction, "coulomb.P", "h_P"),
        (position_friction, "coulomb.x", "h_x"),
        (zero_drift, "zero_drift", "D"),
    ],
)
def test_an_undeclared_effect_is_named_and_its_parameter_recovered(
    synthetic, effect, name, parameter
):
    data, truth = synthetic(effect)
    result = loop_on(data, SPEC)
    assert result.first_named == (name,), result.tests
    value, lower, upper = _interval(result.effects[0], parameter)
    se = (upper - lower) / 3.92  # 95 % interval; 4 standard errors keeps this test from flaking
    assert abs(value - truth[parameter]) < 4 * se, (value, lower, upper)
    assert se < 0.05 * truth[parameter]
    assert result.after.rmse < 0.8 * result.before.rmse
    assert result.verdict is Verdict.EXPLAINED


def test_a_pressure_lag_is_found_and_its_delay_bracketed(synthetic):
    delay = 0.02

    def lag(frame):
        # the pressure that acts leads the measured one: F depends on P(t + d)
        shifted = frame.groupby("segment", group_keys=False)[["t", "P"]].apply(
            lambda g: np.interp(g["t"] + delay, g["t"], g["P"])
        )
        return 5.0e-4 * (np.concatenate(list(shifted)) - frame["P"]), {"d": delay}

    data, _ = synthetic(lag)
    result = loop_on(data, SPEC)
    # a delay and a first-order lag of P shift its phase alike: either, or both as rivals
    assert "delay.P" in result.first_named and set(result.first_named) <= {"delay.P", "lag.P"}
    if result.first_effect == "delay.P":
        _, lower, upper = _interval(result.effects[0], "d")
        assert lower <= delay <= upper


def test_rivals_the_data_cannot_separate_are_both_named(synthetic):
    """Position and pressure moving together: friction growing with x is also friction growing
    with P, and the loop must say so rather than pick one with confidence."""

    def tied(frame):
        # the pressure follows the position (as on a muscle rig), to 1e-4 of its swing
        p = 3e5 + 5e6 * frame["x"] + 30.0 * np.sin(2 * np.pi * 7.0 * frame["t"])
        return -60.0 * frame["x"] * np.sign(frame["v"]) + 5e-4 * (p - frame["P"]), {}

    data, _ = synthetic(tied)
    p = 3e5 + 5e6 * data["x"] + 30.0 * np.sin(2 * np.pi * 7.0 * data["t"])
    data = data.with_columns(P=p, **{"raw:P": p} if "raw:P" in data else {})
    result = loop_on(data, SPEC)
    assert {"coulomb.x", "coulomb.P"} <= set(result.first_named), result.tests
    effect = result.effects[0]
    assert "indistinguishable on these data" in effect.verdict()
    assert "vary x with P held fixed" in " ".join(a.separating for a in effect.alternatives) or (
        "vary P with x held fixed" in " ".join(a.separating for a in effect.alternatives)
    )
    assert "indistinguishable on these data" in result.message


def test_decisions_never_see_the_reported_rows(synthetic):
    """Corrupting the held-out rows changes the reported error, not one decision."""
    data, _ = synthetic(viscous)
    noisy = data.target.copy()
    noise = np.random.default_rng(5).normal(0, 1.0, len(noisy))
    noisy[data.validation] += noise[data.validation]
    corrupted = data.with_columns(target=noisy)
    a, b = loop_on(data, SPEC), loop_on(corrupted, SPEC)
    assert a.tests.equals(b.tests)
    assert a.first_named == b.first_named == ("viscous",)
    assert b.after.rmse > 5 * a.after.rmse  # the report did see them


def test_clean_data_get_no_effect_and_no_claim_of_structure(synthetic):
    for seed in range(3):
        data, _ = synthetic(None, seed=seed)
        result = loop_on(data, SPEC)
        assert result.effects == ()
        assert result.verdict is Verdict.NOTHING_ATTRIBUTABLE
        assert result.after.rmse == result.before.rmse


def test_the_loop_reports_what_each_part_and_candidate_cost(synthetic):
    data, _ = synthetic(viscous)
    result = loop_on(data, SPEC)
    parts = [part for part, _, _ in result.costs]
    screened = int((result.tests["round"] == 1).sum())
    assert parts[0] == "setting up" and parts[-1] == "diagnostics and verdict"
    assert parts[1] == f"round 1: screening {screened} candidates"
    assert parts[2] == "round 1: selection, adding its effect"  # viscous was added
    assert all(seconds >= 0 for _, seconds, _ in result.costs)
    assert [n for _, _, n in result.costs if n] == [screened]  # nothing remained after it
    assert "s each" in result.cost_text()


def test_structure_outside_the_library_is_reported_as_unexplained(synthetic):
    def ripple(frame):  # friction that varies along the bore: no candidate has it
        return -0.6 * np.sign(frame["v"]) * np.sin(2 * np.pi * frame["x"] / 0.004), {}

    data, _ = synthetic(ripple)
    result = loop_on(data, SPEC)
    assert result.effects == ()
    assert result.verdict is Verdict.PATTERN_REMAINS
    assert result.diagnostics_after.strongest[0] == "x"
    assert "no candidate effect explains" in result.message
    assert result.hint is not None
    period = float(re.search(r"period ([\d.]+) mm", result.hint.periodic).group(1))
    assert abs(period - 4.0) < 0.2  # the ripple's wavelength, found without naming it


def test_every_candidate_is_tabulated_with_its_evidence(synthetic):
    data, _ = synthetic(viscous)
    result = loop_on(data, SPEC)
    first = [d for d in result.decisions if d.round == 1]
    assert {d.candidate for d in first} <= set(SPEC.candidate_names(_setting()))
    assert [d.candidate for d in first if d.added] == ["viscous"]
    assert all(d.p_holm >= d.p for d in first)
    selected = [d for d in first if d.selected]
    assert selected and all(d.cv_upper < 0 and d.passes_training for d in selected)
    # the report's table is rendered from the decisions, a labelled column per field
    table = result.tests
    labels = [v for k, v in LABELS.items() if k not in ACROSS]  # no logs held out here
    assert list(table.columns) == labels and len(table) == len(result.decisions)
    assert table["p (Holm)"].tolist() == [d.p_holm for d in result.decisions]
    assert "cross-validation" in result.effects[0].evidence


def _setting():
    from _loop_data import PISTON

    from hmid.loop import Setting

    return Setting.of(PISTON)


def test_a_margin_no_effect_can_meet_adds_nothing(synthetic):
    data, _ = synthetic(viscous)
    result = loop_on(data, SPEC.model_copy(update={"margin": 0.99}))
    assert result.effects == ()
    assert result.verdict is Verdict.PATTERN_REMAINS


def test_the_loop_is_deterministic(synthetic):
    data, _ = synthetic(stribeck)
    a, b = loop_on(data, SPEC), loop_on(data, SPEC)
    assert a.tests.equals(b.tests)
    np.testing.assert_array_equal(a.residual_after, b.residual_after)
