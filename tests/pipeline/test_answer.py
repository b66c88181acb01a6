"""The run's answer: the margin's block-bootstrap interval, the parameters read from any
family's coefficient table, R² shown as a number, and the rows left out said with their reason."""

import numpy as np
import pandas as pd
import pytest

from hmid.experiment import experiment_from
from hmid.pipeline.answer import (
    coefficient_rows,
    console_lines,
    margin,
    parameter_lines,
    r2_text,
    rows_text,
)
from hmid.pipeline.stages import Rows


def _predictions(seed=0, n=4000, noise_b=0.5):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 100.0  # 40 s at 100 Hz: 40 blocks of 1 s
    y = np.sin(t)
    # correlated errors: a random walk's steps smoothed, as residuals of a real fit are
    drift = np.convolve(rng.normal(size=n), np.ones(50) / 50, mode="same")
    return pd.DataFrame({
        "log": np.where(t < 20, "a", "b"), "t": np.where(t < 20, t, t - 20), "target": y,
        "good": y + 0.1 * drift, "bad": y + noise_b * drift + 0.05,
    })  # fmt: skip


def test_the_margin_interval_brackets_the_difference_and_is_seeded():
    frame = _predictions()
    found = margin(frame, "good", "bad", seed=3)
    assert found["runner_up"] == "bad" and found["blocks"] == 40 and found["block_s"] == 1.0
    assert 0 < found["lower"] < found["difference"] < found["upper"]
    assert found["ratio"] > 1
    assert margin(frame, "good", "bad", seed=3) == found  # the experiment's seed: same numbers
    assert margin(frame, "good", "bad", seed=4)["lower"] != found["lower"]


def test_a_margin_of_two_alike_models_includes_zero():
    frame = _predictions()
    other = _predictions(seed=9)  # the same errors' law, drawn independently
    frame["twin"] = frame["target"] + (other["good"] - other["target"])
    found = margin(frame, "good", "twin", seed=1)
    assert found["lower"] < 0 < found["upper"]


def test_a_margin_needs_two_blocks():
    frame = _predictions(n=50)
    assert margin(frame[frame["log"] == "a"].head(50), "good", "bad", seed=1) is None


@pytest.mark.parametrize(
    "table",
    [
        pd.DataFrame({"parameter": ["M"], "value": [95.0014], "std. error": [0.001],
                      "ci_low (95%)": [94.9996], "ci_high (95%)": [95.0032], "unit": ["kg"]}),
        pd.DataFrame({"parameter": ["M"], "median": [95.0014], "lower": [94.9996],
                      "upper": [95.0032], "mean": [95.0], "unit": ["kg"]}),
    ],
)  # fmt: skip
def test_parameters_from_either_layout_with_digits_the_interval_needs(table):
    (row,) = coefficient_rows(table)
    assert row == {"name": "M", "value": 95.0014, "lower": 94.9996, "upper": 95.0032,
                   "unit": "kg"}  # fmt: skip
    (line,) = parameter_lines({"parameters": [row], "level": 0.95})
    assert line == "M = 95.0014 kg (95 % interval 94.9996 … 95.0032)"


def test_r2_is_a_number_told_apart_from_one():
    assert r2_text(0.99582) == "0.996"
    assert r2_text(0.9999988) == "0.9999988"
    assert r2_text(-0.25) == "-0.250"


RIG = {
    "name": "mass on a spring",
    "convention": "x up",
    "channels": {"x": {}},
    "position": "x",
    "explained": "u",
    "balance": [
        {"kind": "channel", "name": "m", "channel": "a", "unit": "kg"},
        {"kind": "channel", "name": "k", "channel": "x", "unit": "N/m"},
    ],
}


def _config(tmp_path, fit=None, friction=False):
    (tmp_path / "log.csv").write_text("t,x,u\n")
    (tmp_path / "cols.yaml").write_text(
        "delimiter: ','\nheader: true\nchannels:\n  t: {column: t, unit: s}\n"
        "  x: {column: x, unit: m}\n  u: {column: u, unit: N}\n"
    )
    rig = dict(RIG, balance=[*RIG["balance"], *([{"kind": "coulomb", "name": "Fc"}]
                                               if friction else [])])  # fmt: skip
    data = {"name": "msd", "seed": 1, "rig": rig,
            "logs": [{"path": "log.csv", "columns": "cols.yaml", "role": "dynamic"}],
            "models": [{"family": "balance"}]}  # fmt: skip
    if fit is not None:
        data["fit"] = fit
    return experiment_from(data, "test", tmp_path)


def test_the_low_speed_rule_follows_the_rigs_friction_unless_asked(tmp_path):
    assert _config(tmp_path).fit.exclude_stuck is False
    assert _config(tmp_path, friction=True).fit.exclude_stuck is True
    assert _config(tmp_path, {"exclude_stuck": True}).fit.exclude_stuck is True
    assert _config(tmp_path, {"exclude_stuck": False}, friction=True).fit.exclude_stuck is False


def test_the_rows_left_out_are_said_with_their_reason(tmp_path):
    from hmid.pipeline.answer import excluded_rows

    config = _config(tmp_path)
    found = {"rows": excluded_rows(config, Rows(700, 300, 40, edges=40))}
    text = rows_text(found)
    assert "40 left out (40 within the filters' reach of a piece's ends)" in text
    assert "not applied: the rig declares no friction term" in text
    config = _config(tmp_path, friction=True)
    found = {"rows": excluded_rows(config, Rows(700, 300, 540, edges=40))}
    assert "500 where the motion stops or is slower than 2 mm/s" in rows_text(found)


def test_console_lines_name_the_parameters_and_the_margin():
    frame = _predictions()
    found = {
        "model": "good", "equation": "u = m·a + k·x", "level": 0.95,
        "parameters": [{"name": "k", "value": 10.0, "lower": 9.5, "upper": 10.5, "unit": "N/m"}],
        "one_step": {"rmse": 0.1, "r2": 0.99, "nrmse_fit_pct": 90.0},
        "margin": margin(frame, "good", "bad", seed=1), "free_run": None,
        "rows": {"train": 1, "held_out": 1, "excluded": 0, "filter_edges": 0,
                 "stopped_or_slow": 0, "exclude_stuck": True, "v_deadband": 0.002,
                 "rig_declares_friction": True},
    }  # fmt: skip
    lines = console_lines(found, "N", "u")
    assert lines[0] == "best model: good, held-out RMSE 0.1000 N of u (one-step), R² 0.990"
    assert lines[2] == "  k = 10.0 N/m (95 % interval 9.5 … 10.5)"
    assert lines[3].startswith("runner-up bad: held-out RMSE ") and "block bootstrap" in lines[3]
