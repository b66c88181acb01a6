"""Plausibility from physics: each check finds what it is for, names the likely unit, and stays
silent on plausible data (the shipped demo logs among them)."""

from pathlib import Path

import numpy as np
import pytest

from hmid.io import load_column_map, read_log
from hmid.io import plausibility as p

DEMO = Path(__file__).resolve().parents[2] / "data" / "demo"
LIMITS = p.Limits()


def _wave(n=5000, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 1000.0
    return 0.005 + 0.004 * np.sin(2 * np.pi * 0.5 * t) + rng.normal(0, 2e-5, n)


def test_a_constant_channel_is_stuck():
    found = p.stuck("log", "P", np.full(100, 1.5e5), "Pa")
    assert found.kind == "stuck" and "constant (1.5e+05 Pa)" in found.text
    assert p.stuck("log", "P", _wave(), "Pa") is None


def test_an_absurd_sample_is_fatal_and_a_glitch_a_finding():
    values = _wave()
    values[2500] = 1e300
    found = p.outliers("log", "F", values, "N")
    assert found.fatal and "row 2501" in found.text and "1e+300" in found.text
    values[2500] = 0.3  # 0.3 m against a 0.008 m span: a glitch, not an overflow
    found = p.outliers("log", "F", values, "N")
    assert found.kind == "outlier" and not found.fatal
    assert p.outliers("log", "F", _wave(), "N") is None


def test_clipping_inside_the_range_is_found_and_a_rest_is_not():
    values = np.minimum(_wave(), 0.007)
    found = p.clipped("log", "x", values, "m")
    assert found.kind == "clipped" and "0.007 m" in found.text
    assert p.clipped("log", "x", _wave(), "m") is None
    # a signal resting at its top with noise spreads over neighbouring levels: no spike
    rest = np.round(np.r_[_wave(), 0.009 + np.random.default_rng(1).normal(0, 2e-5, 2000)], 5)
    assert p.clipped("log", "x", rest, "m") is None


@pytest.mark.parametrize(
    ("speed", "accel", "rate", "time_unit", "position_unit", "named"),
    [
        (31.5, 148_050.0, 10_000.0, "ms", "mm", "is the time column in s rather than ms"),
        (72.9, 3_000.0, 1_000.0, "ms", "m", "is x in mm rather than m"),
    ],
)
def test_implausible_motion_names_the_unit_at_fault(
    speed, accel, rate, time_unit, position_unit, named
):
    found = p.motion("log", "x", speed, accel, rate, LIMITS, time_unit, position_unit)
    assert found is not None and named in found.text.split(": ", 1)[1].split(" Or ")[0]
    assert f"speeds of {speed:.3g} m/s" in found.text


def test_plausible_motion_and_declared_limits():
    assert p.motion("log", "x", 1.2, 20.0, 1000.0, LIMITS, "ms", "mm") is None
    tight = p.Limits(max_speed=0.5)
    assert p.motion("log", "x", 1.2, 20.0, 1000.0, tight, "ms", "mm").kind == "speed"


def test_a_channel_using_a_sliver_of_its_range_is_likely_in_another_unit():
    kpa = 1e3 * np.linspace(0.28, 2.5, 500)  # bar read as kPa, in Pa
    found = p.small_span("log", "P", kpa, "Pa", "kPa", (0.0, 1.2e6), "its sensor's range")
    assert found.kind == "unit" and "is it in bar rather than kPa?" in found.text
    assert p.small_span("log", "P", 100 * kpa, "Pa", "kPa", (0.0, 1.2e6), "range") is None


def test_values_outside_the_rigs_range_name_the_unit():
    x_read_as_m = np.linspace(0.3, 13.3, 100)  # mm values mapped as m
    found = p.out_of_range("log", "x", x_read_as_m, "m", "m", (0.0, 0.05))
    assert found.kind == "range" and "is it in mm rather than m?" in found.text


def test_swapped_columns_fit_each_others_ranges():
    x_mm, f_n = 6.0 + 6.0 * np.sin(np.linspace(0, 20, 1000)), 4.9 + np.zeros(1000)
    ranges, units = {"x": (0.0, 20.46), "F": (0.0, 10.23)}, {"x": "mm", "F": "N"}
    # in SI as loaded: the force's numbers read as mm, the position's as N
    (found,) = p.swapped("log", {"x": f_n / 1000, "F": x_mm}, ranges, units)
    assert found.kind == "swapped" and "x and F look swapped" in found.text
    assert p.swapped("log", {"x": x_mm / 1000, "F": f_n}, ranges, units) == ()


def test_a_log_without_rows_says_why():
    found = p.no_rows("dyn", 6000, 0, 8e-5, 0.002, "x")
    assert "fit.v_deadband 0.002 m/s" in found.text and "peak 8e-05 m/s" in found.text
    assert "too short" in p.no_rows("dyn", 0, 0, None, 0.002, "x").text
    assert p.no_rows("dyn", 6000, 10, 0.1, 0.002, "x") is None


def test_findings_are_typed_and_fatal_first():
    a = p.DataFinding("a", "x", "stuck", "constant")
    b = p.DataFinding("b", "F", "outlier", "absurd", fatal=True)
    assert p.ordered([a, b, a]) == (b, a)
    assert a.to_dict()["message"] == "data: a: channel x: constant"


@pytest.mark.parametrize("name", ["dyn-cycles", "dyn-steps", "dyn-random", "free-fall-1"])
def test_the_shipped_demo_logs_are_plausible(name):
    role = "free_fall" if name.startswith("free") else "dynamic"
    columns = load_column_map(DEMO / f"columns-{role}.yaml")
    log = read_log(DEMO / f"{name}.csv", columns)
    channels = {c: log[c] for c in log.channels}
    own = {c: s.unit for c, s in columns.channels.items()}
    sensor = {
        c: tuple(b * p.unit_factor(s.unit) for b in s.range)
        for c, s in columns.channels.items()
        if s.range is not None
    }
    assert p.check_channels(name, channels, log.units, own, sensor, LIMITS) == ()


def test_the_rig_declares_its_limits():
    import yaml
    from pydantic import ValidationError

    from hmid.balance.rig import RigSection

    rig = yaml.safe_load((DEMO.parents[1] / "configs" / "demo.yaml").read_text())["rig"]
    rig["channels"]["x"] |= {"range": [0.0, 0.02], "max_speed": 0.5, "max_acceleration": 50}
    limits = RigSection.model_validate(rig).limits()
    assert (limits.max_speed, limits.max_acceleration) == (0.5, 50)
    assert limits.range("x") == (0.0, 0.02) and limits.range("P") is None
    assert RigSection.model_validate(rig | {"channels": {"x": {}, "P": {}}}).limits() == LIMITS
    rig["channels"]["P"] = {"max_speed": 1.0}
    with pytest.raises(ValidationError, match="max_speed and max_acceleration are the position"):
        RigSection.model_validate(rig)
