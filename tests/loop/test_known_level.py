"""A declared term taken as known is a hypothesis too: a wrong known Coulomb level is named as a
finding of its own, with the causes these data cannot separate, and no candidate is credited
with it."""

import numpy as np
from _loop_data import FC, PISTON

from hmid.balance import RigSection
from hmid.families import FitContext, FitData
from hmid.families.balance import BalanceSpec
from hmid.loop import LoopBase, LoopSpec, Setting, run_loop

DECLARED = 3.5  # N, where the data have FC = 4 N


def _known(value: float) -> RigSection:
    terms = [t.model_dump(by_alias=True, exclude_none=True) for t in PISTON.balance[:2]]
    coulomb = {"kind": "coulomb", "name": "Fc", "sign": -1, "value": value}
    spec = PISTON.model_dump(by_alias=True, exclude_none=True)
    return RigSection.model_validate(spec | {"balance": [*terms, coulomb]})


def test_a_wrong_known_friction_level_is_a_finding_not_an_effect(synthetic, tmp_path):
    signals, _ = synthetic()
    rig = _known(DECLARED)
    # the balance takes the known term off the explained quantity, as the signals stage does
    signals = signals.with_columns(target=signals.target - DECLARED * np.sign(signals["v"]) * -1)
    data = FitData(signals, rig)
    (fitted,) = BalanceSpec().fit(data, FitContext(0, tmp_path))
    spec = LoopSpec(base="balance", candidates=("viscous", "coulomb.x", "zero_drift"), draws=200)
    result = run_loop(signals, LoopBase.of(fitted, data), spec, Setting.of(rig))
    (finding,) = [n for n in result.notes if n.startswith("the dynamic friction level")]
    assert f"{FC - DECLARED:.3g} N above its declared value" in finding
    assert "these data cannot separate them" in finding
    assert not result.effects  # the refit base holds the correction: no candidate takes it
    # the after is the base with its level refitted, and says so
    assert result.after.rmse < result.before.rmse and "dFc" in result.after_name
    dfc = result.base_parameters.set_index("parameter").loc["dFc"]
    assert dfc["lower"] < FC - DECLARED < dfc["upper"]


def test_a_right_known_level_is_no_finding(synthetic, tmp_path):
    signals, _ = synthetic()
    rig = _known(FC)
    signals = signals.with_columns(target=signals.target + FC * np.sign(signals["v"]))
    data = FitData(signals, rig)
    (fitted,) = BalanceSpec().fit(data, FitContext(0, tmp_path))
    spec = LoopSpec(base="balance", candidates=("viscous",), draws=200)
    result = run_loop(signals, LoopBase.of(fitted, data), spec, Setting.of(rig))
    assert not [n for n in result.notes if n.startswith("the dynamic friction level")]


# -- known values and the motion: a mass declared wrong is named, a right one is not ----------
M_TRUE = 5.0  # kg, a mass the cylinder's rod force also drives (F = A P + F0 - Fc sign v + M a)


def _with_mass(signals, mass: float = M_TRUE, seed: int = 0):
    """``signals`` with an acceleration (the velocity's derivative, per segment) and the rod
    force of a rod mass ``mass`` added to the target, also logged as channel F."""
    a = np.zeros(len(signals))
    for start, stop in signals.bounds():
        a[start:stop] = np.gradient(signals["v"][start:stop], signals["t"][start:stop])
    force = signals.target + mass * a
    return signals.with_columns(a=a, target=force, F=force)


def _mass_rig(declared: float) -> RigSection:
    spec = PISTON.model_dump(by_alias=True, exclude_none=True)
    mass = {"kind": "channel", "name": "M", "channel": "a", "value": declared, "unit": "kg",
            "positive": True}  # fmt: skip
    return RigSection.model_validate(spec | {"balance": [*spec["balance"], mass]})


def _loop_with_known_mass(signals, declared: float, tmp_path):
    rig = _mass_rig(declared)
    # the signals stage takes the known term off the explained quantity
    signals = signals.with_columns(target=signals.target - declared * signals["a"])
    data = FitData(signals, rig)
    (fitted,) = BalanceSpec().fit(data, FitContext(0, tmp_path))
    spec = LoopSpec(base="balance", candidates=("viscous", "zero_drift"), draws=200)
    return run_loop(signals, LoopBase.of(fitted, data), spec, Setting.of(rig), rig=rig)


def test_a_wrong_known_value_is_named_and_refitted_in_the_base(synthetic, tmp_path):
    signals, _ = synthetic()
    result = _loop_with_known_mass(_with_mass(signals), 4.0, tmp_path)
    (finding,) = result.findings
    assert finding.parameter == "dM" and finding.refitted
    assert "declared 4 kg in rig.balance (M)" in finding.message
    assert "these data cannot separate them" in finding.message and finding.message in result.notes
    dm = result.base_parameters.set_index("parameter").loc["dM"]
    assert dm["lower"] < M_TRUE - 4.0 < dm["upper"]
    assert not result.effects and "dM" in result.after_name  # no candidate takes it
    assert result.after.rmse < result.before.rmse


def test_a_right_known_value_is_no_finding(synthetic, tmp_path):
    signals, _ = synthetic()
    result = _loop_with_known_mass(_with_mass(signals), M_TRUE, tmp_path)
    assert not result.findings and "dM" not in result.base_parameters["parameter"].tolist()


def test_a_known_mass_of_the_wrong_sign_is_a_sign_finding(synthetic, tmp_path):
    signals, _ = synthetic()
    result = _loop_with_known_mass(_with_mass(signals, -M_TRUE), 4.0, tmp_path)
    (finding,) = result.findings
    assert finding.message.startswith("M is negative on the dynamic data (its interval -5")
    assert "its value is not estimated" in finding.message and "M = " not in finding.message
    assert "a channel counted the other way (x)" in finding.message


def _motion_rig(mass: float) -> RigSection:
    spec = PISTON.model_dump(by_alias=True, exclude_none=True)
    return RigSection.model_validate(spec | {"motion": {"mass": mass, "offset": 0.3}})


def test_the_motion_mass_is_tested_against_the_force_sensor(synthetic):
    from hmid.loop.declared import MOTION_MASS, motion_finding

    signals, _ = synthetic()
    # a load cell behind a mass alone: F = M a + offset, with the sensor's noise
    signals = _with_mass(signals)
    noise = np.random.default_rng(3).normal(0, 0.05, len(signals))
    signals = signals.with_columns(F=M_TRUE * signals["a"] + 0.3 + noise)
    found = motion_finding(_motion_rig(4.5), signals, 0.95)
    assert found is not None and found.parameter == MOTION_MASS and not found.refitted
    assert "declared 4.5 kg in rig.motion" in found.message
    assert motion_finding(_motion_rig(M_TRUE), signals, 0.95) is None


def test_an_inertial_force_made_of_the_motion_alone_is_not_tested(synthetic):
    """On a rig without a force sensor ((M + m1) a + m1 g explained), a wrong mass scales the
    whole balance, which the model takes up: no correction is offered; beside a sensor (a force
    less a known inertia) the known part is tested, entering with the explained side's sign."""
    from dataclasses import replace
    from pathlib import Path

    import yaml

    from hmid.loop.declared import known_values

    signals, _ = synthetic()
    signals = _with_mass(signals)
    signals = replace(signals, units={**signals.units, "F": "N"})  # the sensor's, as logged
    config = Path(__file__).resolve().parents[2] / "configs" / "knee.yaml"
    knee = yaml.safe_load(config.read_text(encoding="utf-8"))["rig"]
    assert known_values(RigSection.model_validate(knee), signals) == ()
    spec = PISTON.model_dump(by_alias=True, exclude_none=True)
    parts = [{"channel": "F"}, {"channel": "a", "value": -0.2, "unit": "kg", "name": "m_rod"}]
    rig = RigSection.model_validate(spec | {"explained": {"name": "F", "parts": parts}})
    (known,) = known_values(rig, signals)
    assert (known.name, known.value, known.sign, known.correction) == ("m_rod", -0.2, -1, "dm_rod")


def test_declared_terms_are_one_family_decided_by_holm():
    from hmid.loop.declared import Finding, decide

    tests = [Finding("dFc", "level", p=0.03), Finding("dM", "mass", p=1e-6),
             Finding("motion.mass", "motion", p=0.2, refitted=False)]  # fmt: skip
    # alone at 0.05 the level would be a finding; with three tests its Holm p is 0.06
    assert [f.parameter for f in decide(tests, 0.05)] == ["dM"]
    assert [f.parameter for f in decide(tests[:2], 0.05)] == ["dFc", "dM"]  # 0.03 x 1 after dM
    (mass,) = decide(tests, 0.01)
    assert mass.p == 3e-6 and "Holm-adjusted, of 3 declared-term tests" in mass.message
    assert decide([Finding("dM", "undefined", p=float("nan"))], 0.05) == ()
