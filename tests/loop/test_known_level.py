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
