"""Cases of a blind suite: the effect goes on every log, outcomes are judged as stated."""

from types import SimpleNamespace

from hmid.blind import CLEAN, Case, dataset_for, outcome


def _result(effects, verdict="explained"):
    scores = SimpleNamespace(rmse=0.1)
    return SimpleNamespace(
        effects=[SimpleNamespace(name=n) for n in effects],
        verdict=verdict,
        before=scores,
        after=scores,
    )


def test_the_effect_is_switched_on_in_every_log_and_the_seed_replaced():
    template = {"seed": 0, "logs": [{"name": "a"}, {"name": "b", "effects": [{"kind": "viscous"}]}]}
    case = Case("x", "stribeck", "moderate", 0, 42, {"delta": 0.2}, "stribeck")
    config = dataset_for(template, case)
    assert config["seed"] == 42
    assert config["logs"][0]["effects"] == [{"kind": "stribeck", "delta": 0.2}]
    assert config["logs"][1]["effects"][-1] == {"kind": "stribeck", "delta": 0.2}
    assert template["logs"][0] == {"name": "a"}  # the template is not changed


def test_outcomes_are_judged_by_what_was_claimed():
    lib = Case("l", "viscous", "m", 0, 1, {"b": 1.0}, "viscous")
    assert outcome(lib, _result(["viscous", "stribeck"]))["correct"]
    assert not outcome(lib, _result(["stribeck", "viscous"]))["correct"]
    clean = Case("c", CLEAN, "-", 0, 2, {}, None)
    assert outcome(clean, _result([], "no attributable structure"))["correct"]
    assert not outcome(clean, _result(["viscous"]))["correct"]
    outside = Case("o", "rail_ripple", "m", 0, 3, {"amplitude": 0.1}, None)
    assert outcome(outside, _result([], "unexplained structure"))["correct"]
    assert not outcome(outside, _result([], "no attributable structure"))["correct"]
    assert not outcome(outside, _result(["hysteresis"], "unexplained structure"))["correct"]
