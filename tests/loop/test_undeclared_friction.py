"""The library is offered whole: a mass-spring-damper whose rig declares no friction, with a 1 N
Coulomb friction in its data. The loop names Coulomb friction (against the motion), and the
damping, no longer absorbing it, comes back within its interval of the truth."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import yaml

from hmid.experiment import experiment_from
from hmid.loop import Setting, library
from pipelines.identify import analyse

EXAMPLE = Path(__file__).resolve().parents[2] / "docs" / "examples" / "mass-spring-damper"
TRUTH = {"m": 2.0, "c": 5.0, "k": 150.0, "Fc": 1.0}  # kg, N·s/m, N/m, N


@pytest.fixture(scope="module")
def msd_loop(tmp_path_factory):
    spec = importlib.util.spec_from_file_location("msd_make_data", EXAMPLE / "make_data.py")
    make = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make)
    make.TRUTH = TRUTH  # the example's generator with a friction its rig does not declare
    root = tmp_path_factory.mktemp("msd")
    columns = make.simulate()
    table = np.column_stack(list(columns.values()))
    np.savetxt(root / "msd.csv", table, fmt=("%.3f", "%.3f", "%.4f"), delimiter=",",
               header=",".join(columns), comments="")  # fmt: skip
    (root / "columns.yaml").write_text((EXAMPLE / "columns.yaml").read_text())
    config = yaml.safe_load((EXAMPLE / "config.yaml").read_text())
    config["loop"] = {"base": "balance"}
    # the rig declares no friction, so the low-speed rule is off by default: the loop turns it
    # on for its final refit once it adds friction (with stopped rows the level reads 0.989 N
    # [0.95, 0.989]: static friction is indeterminate there)
    experiment = experiment_from(config, "msd.yaml", root)
    return experiment, analyse(experiment, ("loop",), root / "cache")["loop"]


def test_friction_is_offered_against_the_motion_on_a_rig_that_declares_none(msd_loop):
    experiment, _ = msd_loop
    setting = Setting.of(experiment.rig)
    assert not setting.declared and setting.friction_sign == 1  # u = m a + c v + k x (+ f)
    offered = library(setting)
    assert {"coulomb", "viscous.direction", "stribeck"} <= set(offered)
    assert "dFc" in offered["coulomb"].positive  # all the friction there is: against the motion


def test_undeclared_coulomb_friction_is_named_and_the_damping_recovered(msd_loop):
    _, result = msd_loop
    assert "coulomb" in result.first_named
    final = result.final_parameters.set_index("parameter")
    level = final.loc["dFc"]
    assert level["part"] == "coulomb" and level["lower"] < TRUTH["Fc"] < level["upper"]
    c = final.loc["c"]
    assert c["part"] == "balance" and c["lower"] < TRUTH["c"] < c["upper"]
    assert any(line.startswith("coulomb: dFc = ") for line in result.final_lines())
    assert any("without the rows of stopped motion" in note for note in result.notes)
    # the effect's own table is the final refit's
    own = result.effects[0].parameters.set_index("parameter").loc["dFc"]
    assert own["value"] == level["value"] and own["upper"] == level["upper"]
