"""The loop on synthetic cylinder data: the right effect, its parameter, and honest endings."""

import re

import numpy as np
import pytest
from _loop_data import loop_on

from hmid.loop import LoopSpec

SPEC = LoopSpec(
    base="balance",
    candidates=("viscous", "stribeck", "pressure_friction", "pressure_lag", "force_zero_drift"),
)


def _interval(effect, name):
    row = effect.parameters.set_index("parameter").loc[name]
    return row["value"], row["lower"], row["upper"]


def viscous(frame):
    return -12.0 * frame["v"], {"b": 12.0}


def stribeck(frame):
    v = frame["v"]
    return -1.5 * np.sign(v) * np.exp(-((v / 0.01) ** 2)), {"delta": 1.5, "v_s": 0.01}


def pressure_friction(frame):
    return -4e-6 * frame["P"] * np.sign(frame["v"]), {"mu": 4e-6}


def force_drift(frame):
    return 0.4 * frame["t"] / frame["t"].max(), {"D": 0.4}


@pytest.mark.parametrize(
    ("effect", "name", "parameter"),
    [
        (viscous, "viscous", "b"),
        (stribeck, "stribeck", "delta"),
        (pressure_friction, "pressure_friction", "mu"),
        (force_drift, "force_zero_drift", "D"),
    ],
)
def test_an_undeclared_effect_is_named_and_its_parameter_recovered(
    synthetic, effect, name, parameter
):
    data, truth = synthetic(effect)
    result = loop_on(data, SPEC)
    assert result.first_effect == name, result.tests
    value, lower, upper = _interval(result.effects[0], parameter)
    se = (upper - lower) / 3.92  # 95 % interval; 4 standard errors keeps this test from flaking
    assert abs(value - truth[parameter]) < 4 * se, (value, lower, upper)
    assert se < 0.05 * truth[parameter]
    assert result.after.rmse < 0.8 * result.before.rmse
    assert result.verdict == "explained"


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
    assert result.first_effect == "pressure_lag"
    _, lower, upper = _interval(result.effects[0], "d")
    assert lower <= delay <= upper


def test_clean_data_get_no_effect_and_no_claim_of_structure(synthetic):
    for seed in range(3):
        data, _ = synthetic(None, seed=seed)
        result = loop_on(data, SPEC)
        assert result.effects == ()
        assert result.verdict == "no attributable structure"
        assert result.after.rmse == result.before.rmse


def test_structure_outside_the_library_is_reported_as_unexplained(synthetic):
    def ripple(frame):  # friction that varies along the bore: no candidate has it
        return -0.6 * np.sign(frame["v"]) * np.sin(2 * np.pi * frame["x"] / 0.004), {}

    data, _ = synthetic(ripple)
    result = loop_on(data, SPEC)
    assert result.effects == ()
    assert result.verdict == "unexplained structure"
    assert result.diagnostics_after.strongest[0] == "x"
    assert "no candidate effect explains" in result.message
    assert result.hint is not None and len(result.hint.terms) > 0
    period = float(re.search(r"period ([\d.]+) mm", result.hint.periodic).group(1))
    assert abs(period - 4.0) < 0.2  # the ripple's wavelength, found without naming it


def test_every_candidate_is_tabulated_with_its_evidence(synthetic):
    data, _ = synthetic(viscous)
    result = loop_on(data, SPEC)
    first = result.tests[result.tests["round"] == 1]
    assert set(first["candidate"]) == set(SPEC.candidates)
    assert first.loc[first["added"], "candidate"].tolist() == ["viscous"]
    assert (first["p (Holm)"] >= first["p"]).all()
    assert "held-out RMSE" in result.effects[0].evidence


def test_a_margin_no_effect_can_meet_adds_nothing(synthetic):
    data, _ = synthetic(viscous)
    result = loop_on(data, SPEC.model_copy(update={"margin": 0.99}))
    assert result.effects == ()
    assert result.verdict == "unexplained structure"


def test_the_loop_is_deterministic(synthetic):
    data, _ = synthetic(stribeck)
    a, b = loop_on(data, SPEC), loop_on(data, SPEC)
    assert a.tests.equals(b.tests)
    np.testing.assert_array_equal(a.residual_after, b.residual_after)
