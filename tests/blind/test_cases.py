"""Cases of a blind suite: the effect goes on every log, outcomes are judged as stated."""

from types import SimpleNamespace

import pandas as pd

from hmid.blind import CLEAN, Case, dataset_for, outcome
from hmid.loop.declared import Finding
from hmid.loop.result import AddedEffect, Alternative, Verdict


def _effect(names):
    """An added effect, with rivals when ``names`` is a tuple (the first is added)."""
    names = (names,) if isinstance(names, str) else names
    rivals = tuple(Alternative(n, n, "", pd.DataFrame(), 0.0, "") for n in names[1:])
    return AddedEffect(names[0], names[0], "", pd.DataFrame(), "", rivals)


def _result(effects, verdict=Verdict.EXPLAINED):
    scores = SimpleNamespace(rmse=0.1)
    effects = [_effect(e) for e in effects]
    return SimpleNamespace(
        effects=effects,
        first_named=effects[0].named if effects else (),
        verdict=verdict,
        before=scores,
        after=scores,
        notes=(),
        base_name="sls",
        base_parameters=pd.DataFrame(),
        findings=(),
    )


def test_the_effect_is_switched_on_in_every_log_and_the_seed_replaced():
    template = {"seed": 0, "logs": [{"name": "a"}, {"name": "b", "effects": [{"kind": "viscous"}]}]}
    case = Case("x", "stribeck", "moderate", 0, 42, {"delta": 0.2}, ("stribeck",))
    config = dataset_for(template, case)
    assert config["seed"] == 42
    assert config["logs"][0]["effects"] == [{"kind": "stribeck", "delta": 0.2}]
    assert config["logs"][1]["effects"][-1] == {"kind": "stribeck", "delta": 0.2}
    assert template["logs"][0] == {"name": "a"}  # the template is not changed


def test_outcomes_are_judged_by_what_was_claimed():
    lib = Case("l", "viscous", "m", 0, 1, {"b": 1.0}, ("viscous",))
    assert outcome(lib, _result(["viscous", "stribeck"]))["correct"]
    wrong = outcome(lib, _result(["stribeck", "viscous"]))
    assert not wrong["correct"] and wrong["confidently wrong"]
    # an "indistinguishable" set that holds the right name is right, and not confident
    rivals = outcome(lib, _result([("stribeck", "viscous")]))
    assert rivals["correct"] and rivals["indistinguishable"] and not rivals["confidently wrong"]
    hedged = outcome(lib, _result([("stribeck", "coulomb.x")]))
    assert not hedged["correct"] and not hedged["confidently wrong"]
    clean = Case("c", CLEAN, "-", 0, 2, {}, None)
    assert outcome(clean, _result([], Verdict.NOTHING_ATTRIBUTABLE))["correct"]
    assert outcome(clean, _result(["viscous"]))["confidently wrong"]
    outside = Case("o", "rail_ripple", "m", 0, 3, {"amplitude": 0.1}, None)
    assert outcome(outside, _result([], Verdict.PATTERN_REMAINS))["correct"]
    assert not outcome(outside, _result([], Verdict.NOTHING_ATTRIBUTABLE))["correct"]
    claimed = outcome(outside, _result(["coulomb.x"], Verdict.PATTERN_REMAINS))
    assert not claimed["correct"] and claimed["confidently wrong"]
    # additions that did worse on the held-out rows are counted; intervals are checked
    worse = _result(["viscous"])
    worse.notes = ("added viscous, but the held-out error rose 0.1 → 0.2 N: ...",)
    worse.base_parameters = pd.DataFrame(
        {"parameter": ["k", "tau"], "value": [1.0, 0.5], "lower": [0.9, 0.6], "upper": [1.1, 0.7]}
    )
    row = outcome(lib, worse)
    assert row["added, then worse"] and row["intervals without their estimate"] == "sls: tau"
    assert not outcome(lib, _result(["viscous"]))["added, then worse"]
    # a second addition of other physics is spurious; a declared term found on clean data is
    # false, one on an effect's data is not judged
    assert outcome(lib, _result(["viscous", "stribeck"]))["spurious second effect"]
    assert not outcome(lib, _result(["viscous"]))["spurious second effect"]
    found = _result([], Verdict.NOTHING_ATTRIBUTABLE)
    found.findings = (Finding("dFc", "the dynamic friction level is …"),)
    assert outcome(clean, found)["declared, falsely found"]
    assert outcome(clean, found)["declared found wrong"] == "dFc"
    assert not outcome(clean, _result([]))["declared, falsely found"]
    assert outcome(lib, found)["declared, falsely found"] is None
