"""The blind suite at reduced size, with the full suite's pass marks asserted."""

from pathlib import Path

import pandas as pd
import pytest

from hmid.blind import load_suite, plan_cases
from hmid.errors import ConfigError
from pipelines.blind import run

REPO = Path(__file__).resolve().parents[2]
CI_SUITE = REPO / "configs" / "blind" / "ci.yaml"


def test_the_reduced_blind_suite_meets_every_pass_mark(tmp_path):
    run_dir, table, targets = run(CI_SUITE, results=tmp_path)
    suite = load_suite(CI_SUITE)
    # every effect, the clean controls (an effect added, a declared term found wrong), confidently
    # wrong names and spurious second effects over all effects, intervals without estimates
    assert len(targets) == len(suite.effects) + len(suite.declared) + 5
    missed = targets.loc[~targets["met"], ["target", "measured"]]
    assert missed.empty, f"pass marks missed:\n{missed}\n{table}"
    assert (run_dir / "blind.md").is_file() and (run_dir / "manifest.json").is_file()
    assert len(list((run_dir / "cases").glob("*.json"))) == len(plan_cases(suite))
    # the errors the loop removed are real: every in-library effect lowers the held-out RMSE
    declared = [d.name for d in suite.declared]  # clean data: no effect to remove
    found = table[(table["effect"] != "clean") & (table["expected"] != "—")]
    found = found[~found["effect"].isin(declared)]
    assert (found["RMSE after [N]"] < found["RMSE before [N]"]).all()
    # every interval the loop printed contains its estimate; additions that did worse on the
    # held-out rows are counted
    outcomes = pd.read_csv(run_dir / "outcomes.csv", keep_default_na=False)
    excluded = outcomes["intervals without their estimate"]
    assert (excluded == "").all(), excluded[excluded != ""].tolist()
    assert "added, then held-out worse" in table
    counts = pd.read_csv(run_dir / "counts.csv").set_index("what")
    assert counts.loc["an interval without its estimate", "runs"] == 0


def test_full_suite_config_is_valid_and_plans_every_case():
    suite = load_suite(REPO / "configs" / "blind" / "full.yaml")
    cases = plan_cases(suite)
    strengths = sum(len(e.strengths) for e in (*suite.effects, *suite.declared))
    assert len(cases) == suite.clean_seeds + suite.seeds * strengths
    assert len({c.seed for c in cases}) == len(cases)


def test_an_expectation_outside_the_library_is_a_config_error(tmp_path):
    path = tmp_path / "suite.yaml"
    path.write_text(
        CI_SUITE.read_text().replace("expect: stribeck", "expect: rail_ripple"), encoding="utf-8"
    )
    for name in ("dataset.yaml", "experiment.yaml"):
        (tmp_path / name).write_text((CI_SUITE.parent / name).read_text(), encoding="utf-8")
    with pytest.raises(ConfigError, match=r"effects\.1\.expect: \['rail_ripple'\] are no cand"):
        run(path, results=tmp_path / "results")  # before any case runs
    assert not (tmp_path / "results").exists() or not any((tmp_path / "results").iterdir())


def test_an_unknown_effect_parameter_is_a_config_error(tmp_path):
    path = tmp_path / "suite.yaml"
    path.write_text(CI_SUITE.read_text().replace("{b: 1.0}", "{beta: 1.0}"), encoding="utf-8")
    with pytest.raises(ConfigError, match="unknown key 'beta'"):
        load_suite(path)
