"""The loop on inputs that went wrong upstream: a base whose prediction diverged or is missing
gets a verdict and a report, never a traceback."""

from dataclasses import replace

import numpy as np
import pytest
from _loop_data import PISTON

from hmid.families import FitContext, FitData
from hmid.families.balance import BalanceSpec
from hmid.loop import LoopBase, LoopSpec, Setting, run_loop
from hmid.loop.report import loop_section


@pytest.mark.parametrize(
    "broken",
    [
        lambda p, s: p * 1e200,  # an SLS relaxation time of 1e198 s: astronomic forces
        lambda p, s: np.full(len(p), np.nan),  # no prediction at all
        lambda p, s: np.where(s.validation, np.inf, p),  # diverged on the held-out rows only
    ],
    ids=["astronomic", "missing", "held-out-infinite"],
)
def test_a_diverged_base_gets_a_report_and_no_traceback(synthetic, broken, tmp_path):
    signals, _ = synthetic()
    data = FitData(signals, PISTON)
    (fitted,) = BalanceSpec().fit(data, FitContext(0, tmp_path))
    base = LoopBase.of(fitted, data)
    base = replace(base, prediction=broken(base.prediction, signals))
    spec = LoopSpec(base="balance", candidates=("viscous", "coulomb.x"), draws=100)
    result = run_loop(signals, base, spec, Setting.of(PISTON))
    assert result.message
    # the loop's own refit is the base's structure, whatever the family predicted
    assert np.isfinite(result.base_parameters["value"]).all()
    section, metrics = loop_section(result, tmp_path, lambda frame, name: None)
    assert metrics["verdict"] == result.verdict.value and section.text
