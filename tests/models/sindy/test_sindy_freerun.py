"""Free run of the discovered equation of motion: tracks simulator truth, and fails cleanly."""

from __future__ import annotations

import time
import warnings

import numpy as np
import pandas as pd
import pytest
from _sindy_truth import SPLIT_T, sequences

from hmid.errors import ConfigError
from hmid.models.sindy import (
    EquationOfMotion,
    ForceMap,
    SINDySettings,
    free_run,
    held_out_blocks,
    simulate,
)


@pytest.fixture(scope="module")
def fitted(truth_fits):
    return truth_fits[0]


def test_free_run_tracks_the_measured_x_on_held_out_truth(fitted, truth, ch4_rig, true_friction):
    """9 s held-out, from the true state at its start, driven by the true P. Tolerance: x RMSE
    below 0.05 mm (measured 0.014 mm; the rig's x spans ~10 mm, its stick band 2 Fc/k ~0.2 mm)."""
    eom = EquationOfMotion.from_rig(fitted.force_map(), ch4_rig, true_friction, 1e-3)
    result = free_run(eom, sequences(truth), substeps=2, max_seconds=60)
    (block,) = result.blocks
    assert block.status == "ok" and block.failed_at is None
    assert block.t[0] == pytest.approx(SPLIT_T, abs=0.05) and block.t[-1] == pytest.approx(30.0)
    assert result.rmse < 5e-5
    assert np.ptp(block.x_measured) > 5e-3  # the block does move
    table = result.table()
    assert list(table["status"]) == ["ok"] and table["x rmse [mm]"].iloc[0] < 0.05
    assert "x RMSE" in result.text()


def _unstable_eom(rig, true_friction) -> EquationOfMotion:
    """F_m = m1 g + 1e7 N/m (x - 7 mm): a huge *positive* stiffness, x runs away exponentially."""
    library = SINDySettings(
        variables=("x",), degree=1, max_degree={}, friction_terms=False, keep=()
    ).library()
    library.fit({"x": np.array([0.0, 0.01])})
    weight = rig.motion.offset
    force = ForceMap(library.features_, np.array([weight - 1e7 * 0.007, 1e7]), v0=1e-3)
    return EquationOfMotion.from_rig(force, rig, true_friction, 1e-3)


def test_a_diverging_model_is_reported_with_its_time_not_raised(truth, ch4_rig, true_friction):
    eom = _unstable_eom(ch4_rig, true_friction)
    start = time.perf_counter()
    result = free_run(eom, sequences(truth), substeps=2, max_seconds=30)
    assert time.perf_counter() - start < 5.0
    (block,) = result.blocks
    assert block.status == "diverged"
    assert block.t[0] < block.failed_at < block.t[0] + 1.0  # e-folding time ~ 0.3 ms
    assert any(word in block.reason for word in ("outside", "above", "non-finite"))
    assert np.isnan(block.x_simulated[-1]) and np.isfinite(block.x_simulated[0])
    assert np.isnan(result.rmse) and result.diverged == (block,)
    assert "diverged**: chirp block" in result.text() and "at t = " in result.text()


def test_non_finite_values_and_the_wall_time_bound_are_handled(ch4_rig, true_friction):
    eom = _unstable_eom(ch4_rig, true_friction)
    t = np.arange(1, 2001) / 1000.0
    run = simulate(eom, t, np.full(2000, 1e5), 0.0071, 0.0, substeps=1)  # no bounds: overflows
    assert run.status == "diverged" and "non-finite" in run.reason

    def overflowing(x, v, P):
        return 10.0 ** (1e3 * x)  # raises OverflowError once x > 0.308 m

    raising = EquationOfMotion(overflowing, 0.75, 4.9, 0.35, 0.0, 1e-3)
    run = simulate(raising, t, np.zeros(2000), 0.31, 0.0)
    assert run.status == "diverged" and run.reason.startswith("OverflowError")
    stable = EquationOfMotion(ForceMap((), np.array([]), 1e-3), 0.75, 4.9, 0.35, 0.0, 1e-3)
    t = np.arange(1, 200_001) / 1000.0  # 200 s at 1 kHz: ~10 s of work
    start = time.perf_counter()
    run = simulate(eom=stable, t=t, P=np.zeros_like(t), x0=0.0, v_start=0.0,
                   deadline=time.perf_counter() + 0.05)  # fmt: skip
    assert time.perf_counter() - start < 1.0
    assert run.status == "stopped" and run.failed_at < 200.0


def test_held_out_blocks_span_stuck_rows_inside_them():
    t = np.arange(10) / 10.0
    frame = pd.DataFrame(
        {"t": t, "x": t, "v": t, "P": t, "F_m": t,
         "train": [1, 1, 1, 0, 0, 0, 0, 0, 1, 1], "validation": [0, 0, 0, 1, 0, 0, 1, 1, 0, 0]}
    ).astype({"train": bool, "validation": bool})  # fmt: skip
    ((name, block),) = held_out_blocks({"a": frame})
    assert name == "a" and list(block["t"]) == pytest.approx([0.3, 0.4, 0.5, 0.6, 0.7])


def test_friction_law_must_be_coulomb_plus_viscous(ch4_rig):
    class Stribeck:
        def friction(self, v):
            return np.sign(v) * (0.3 + 0.2 * np.exp(-np.abs(v) / 0.01))

    empty = ForceMap((), np.array([]), 1e-3)
    with pytest.raises(ConfigError, match="Coulomb"):
        EquationOfMotion.from_rig(empty, ch4_rig, Stribeck(), 1e-3)
    with pytest.raises(ConfigError, match="friction"):
        EquationOfMotion.from_rig(empty, ch4_rig, None, 1e-3)


def test_a_rig_without_declared_motion_has_no_equation_of_motion(ch4_rig, true_friction):
    empty = ForceMap((), np.array([]), 1e-3)
    with pytest.raises(ConfigError, match=r"rig\.motion"):
        EquationOfMotion.from_rig(empty, ch4_rig.model_copy(update={"motion": None}),
                                  true_friction, 1e-3)  # fmt: skip


def test_a_diverging_run_is_reported_without_numpy_overflow_warnings():
    """A run that blows up is the free run's to report ("diverged"); numpy's 'overflow
    encountered in multiply' on the way there is not news for the console."""

    class Exploding:
        def acceleration(self, x, v, P):
            return np.float64(1e200) * np.float64(x) * np.float64(1e200)

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any warning fails the test
        run = simulate(Exploding(), np.linspace(0, 1, 50), np.zeros(50), 1.0, 0.0, x_bounds=(-9, 9))
    assert run.status == "diverged" and run.failed_at is not None
