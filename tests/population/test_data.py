"""Each muscle's data: retargeted pressures, seeded scatter, byte-reproducible data sets."""

from __future__ import annotations

import filecmp
from pathlib import Path

import pytest

from hmid.errors import ConfigError
from hmid.population import load_population, muscle_dataset, retarget
from hmid.population._data import elongation, pressure_for
from hmid.simulate.profiles import Cycles, Sine
from hmid.simulate.specs import MuscleSpec

CONFIG = Path(__file__).parents[2] / "configs" / "population" / "muscles.yaml"

LOAD = 0.5 * 9.80665


def test_elongation_and_pressure_invert_each_other():
    params = MuscleSpec().params()
    for x in (0.001, 0.008, 0.015):
        assert elongation(params, pressure_for(params, x, LOAD), LOAD) == pytest.approx(x)


def test_retarget_gives_the_same_elongations():
    ref = MuscleSpec(prestress=1e4)
    wide = MuscleSpec(length=0.2, inner_diameter=0.028, outer_diameter=0.034, prestress=1e4)
    cycles = retarget(Cycles(low=3e4, high=2.5e5), ref, wide, LOAD)
    assert elongation(wide.params(), cycles.high, LOAD) == pytest.approx(
        elongation(ref.params(), 2.5e5, LOAD)
    )
    assert cycles.high < 2.5e5  # a wide bore needs less pressure
    sine = retarget(Sine(offset=1.4e5, amplitude=1e5), ref, wide, LOAD)
    assert 0 < sine.amplitude < sine.offset


def test_shipped_config_loads_with_the_ankle_muscles():
    config = load_population(CONFIG)
    names = [m.name for m in config.muscles]
    assert len(names) == 8
    assert {"gastrocnemius", "soleus", "tibialis-anterior"} <= set(names)
    full = {m.name: m.spec().params().A_eff * 5e5 for m in config.muscles}  # at 500 kPa
    assert full["gastrocnemius"] == pytest.approx(307, rel=0.05)
    assert full["soleus"] == pytest.approx(356, rel=0.05)


def test_a_bad_key_is_a_config_error(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(CONFIG.read_text().replace("leave_one_out:", "leave_one_outt:"))
    with pytest.raises(ConfigError, match="leave_one_outt"):
        load_population(bad)


def test_shipped_data_is_reproducible_from_the_seed(tmp_path):
    from hmid.simulate.write import write_dataset

    config = load_population(CONFIG)
    index = 0
    write_dataset(muscle_dataset(config, index), tmp_path / "m")
    shipped = config.data_dir(config.muscles[index])
    for path in shipped.iterdir():
        if path.suffix == ".json":  # truth records name the generator's version: compare data
            continue
        assert filecmp.cmp(path, tmp_path / "m" / path.name, shallow=False), path.name
