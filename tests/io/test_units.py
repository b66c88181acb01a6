"""Unit conversion to SI (hmid.io.units)."""

import os
import subprocess
import sys

import numpy as np
import pytest

from hmid.errors import UnitError
from hmid.io import si_unit, to_si, unit_registry
from hmid.io.units import UNIT_CACHE_VARIABLE

# 1 psi = 1 lbf / in^2 = 4.4482216152605 N / 0.0254^2 m^2 (both exact by definition)
PSI = 4.4482216152605 / 0.0254**2


@pytest.mark.parametrize(
    ("unit", "channel", "raw", "expected", "si"),
    [
        ("ms", "t", [0.0, 153.0, 1000.0], [0.0, 0.153, 1.0], "s"),
        ("s", "t", [1.5], [1.5], "s"),
        ("kPa", "P", [101.325], [101325.0], "Pa"),
        ("MPa", "P", [0.5], [5e5], "Pa"),
        ("bar", "P", [5.0, 0.0, -0.2], [5e5, 0.0, -2e4], "Pa"),  # gauge: no atmosphere added
        ("psi", "P", [1.0, 100.0], [PSI, 100 * PSI], "Pa"),
        ("mm", "x", [12.5, -3.0], [0.0125, -0.003], "m"),
        ("m", "x", [0.25], [0.25], "m"),
        ("mm/s", "v", [10.0], [0.01], "m/s"),
        ("m/s^2", "a", [2.0], [2.0], "m/s^2"),
        ("g0", "a", [1.0, 0.5], [9.80665, 4.903325], "m/s^2"),
        ("N", "F", [50.2], [50.2], "N"),
        ("kN", "F", [1.2], [1200.0], "N"),
        ("lbf", "F", [1.0], [4.4482216152605], "N"),
        # non-canonical channels: coherent SI unit of their dimension
        ("V", "P_raw", [3.3], [3.3], "V"),
        ("mV", "P_raw", [3300.0], [3.3], "V"),
        ("count", "adc", [4095.0], [4095.0], "count"),
        ("counts", "adc", [7.0], [7.0], "count"),
        ("mm", "stroke", [5.0], [0.005], "m"),
        ("bar", "p_supply", [2.0], [2e5], "Pa"),
        ("ms", "lag", [20.0], [0.02], "s"),
    ],
)
def test_to_si_converts_exactly(unit, channel, raw, expected, si):
    values, unit_si = to_si(np.array(raw), unit, channel, "a.csv")
    assert unit_si == si
    assert values.dtype == np.float64
    np.testing.assert_allclose(values, expected, rtol=1e-12, atol=0)


def test_to_si_does_not_modify_its_input():
    raw = np.array([1.0, 2.0])
    to_si(raw, "mm", "x", "a.csv")
    np.testing.assert_array_equal(raw, [1.0, 2.0])


def test_wrong_dimension_names_file_column_channel_and_examples():
    with pytest.raises(UnitError) as info:
        to_si(np.array([1.0]), "mm", "P", "data/a.csv", column="pos")
    assert str(info.value) == (
        "data/a.csv: column 'pos' (channel P): unit 'mm' is a [length], channel P needs a "
        "[pressure] unit such as Pa, kPa, bar, psi"
    )


@pytest.mark.parametrize(
    ("unit", "channel", "dimension", "needed"),
    [
        ("s", "x", "[time]", "[length]"),
        ("N", "P", "[force]", "[pressure]"),
        ("bar", "F", "[pressure]", "[force]"),
        ("m/s", "a", "[velocity]", "[acceleration]"),
        ("count", "x", "dimensionless", "[length]"),
        ("V", "t", "[voltage]", "[time]"),
    ],
)
def test_wrong_dimension_for_each_canonical_channel(unit, channel, dimension, needed):
    with pytest.raises(UnitError) as info:
        to_si(np.array([1.0]), unit, channel, "f.csv", column=3)
    article = "" if dimension == "dimensionless" else "a "
    assert str(info.value).startswith(
        f"f.csv: column 3 (channel {channel}): unit '{unit}' is {article}{dimension}, "
        f"channel {channel} needs a {needed} unit such as "
    )


@pytest.mark.parametrize("unit", ["mmm", "barr", "", "  ", "2*m", "kPa)", "$"])
def test_unknown_unit_names_unit_and_column_and_suggests(unit):
    with pytest.raises(UnitError) as info:
        to_si(np.array([1.0]), unit, "P", "data/a.csv", column="p")
    message = str(info.value)
    assert message.startswith(f"data/a.csv: column 'p' (channel P): unknown unit {unit!r}")
    assert "Pa, kPa, bar, psi" in message
    assert "\n" not in message


def test_unknown_unit_on_other_channel_suggests_general_examples():
    with pytest.raises(UnitError, match=r"channel volts\): unknown unit 'vv'; .*V, m/s, count"):
        to_si(np.array([1.0]), "vv", "volts", "f.csv", column=2)


def test_message_without_column_names_the_channel():
    with pytest.raises(UnitError, match=r"^f\.csv: channel x: unit 'bar' is a \[pressure\]"):
        to_si(np.array([1.0]), "bar", "x", "f.csv")


def test_si_unit_is_checked_without_values():
    assert si_unit("kPa", "P") == "Pa"
    assert si_unit("degC", "temperature") == "K"
    with pytest.raises(UnitError, match="unknown unit 'psii'"):
        si_unit("psii", "P")


def test_registry_is_shared_and_created_lazily():
    assert unit_registry() is unit_registry()
    code = "import sys, hmid, hmid.io; print('pint' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_the_registry_kept_in_a_cache_folder_converts_as_a_parsed_one(tmp_path):
    """``HMID_UNIT_CACHE``: the first process parses pint's definitions and keeps them, the next
    loads them; a damaged cache file is parsed afresh, never a failure."""
    code = (
        "from hmid.io import to_si; import numpy as np; "
        "print(to_si(np.array([1.0, 2.5]), 'psi', 'P', 'f'), "
        "to_si(np.array([3.0]), 'ft', 'x', 'f'))"
    )
    env = {**os.environ, UNIT_CACHE_VARIABLE: str(tmp_path)}

    def converted(env):
        run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
        return run.stdout

    plain = converted({k: v for k, v in env.items() if k != UNIT_CACHE_VARIABLE})
    assert converted(env) == plain  # parsed, and kept
    kept = sorted(tmp_path.glob("*.pickle"))
    assert kept
    assert converted(env) == plain  # loaded
    for path in kept:
        path.write_bytes(path.read_bytes()[:40])  # as if its writer had been killed
    assert converted(env) == plain  # parsed, and the damaged files removed
    assert converted(env) == plain  # kept again
    assert all(path.stat().st_size > 40 for path in kept)


def test_a_unit_cache_folder_that_cannot_be_made_only_costs_time(tmp_path):
    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    code = "from hmid.io import si_unit; print(si_unit('psi', 'P'))"
    env = {**os.environ, UNIT_CACHE_VARIABLE: str(blocked / "cache")}
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "Pa"
