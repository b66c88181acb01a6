"""Bad data never yields a confident model (issue 31): every bad input of the audit, made from the
demo logs, ends in exit 2 with its cause named, or in exit 0 with the finding on the console and
in the report's summary; none is silent. And the shipped configs' plausible data raise none."""

import json
from pathlib import Path

import pytest
from _bad_inputs import case

from hmid.cli import main
from hmid.experiment import load_experiment
from pipelines.identify import analyse, data_findings, sign_findings

ROOT = Path(__file__).resolve().parents[2]

#: case -> (exit status, what the console and, for exit 0, the report's summary must say)
CASES = {
    "time_s_as_ms": (0, "is the time column in s rather than ms"),
    "bar_as_kpa": (0, "channel P: spans 281 … 2.52e+03 Pa, 0.19 % of its sensor's range"),
    "mm_as_m": (0, "is x in mm rather than m?"),
    "position_too_small": (0, "dyn-steps: log: contributes no rows to the fit"),
    "position_stuck": (0, "dyn-steps: channel x: constant (0.005 m)"),
    "pressure_constant": (0, "dyn-steps: channel P: constant (1.5e+05 Pa)"),
    "force_clipped": (0, "channel F: 186 samples (3.1 %) sit exactly at 6 N"),
    "position_clipped": (0, "channel x: 3526 samples (58.8 %) sit exactly at 0.008 m"),
    "x_F_swapped": (0, "x and F look swapped"),
    "position_reversed": (0, "x counted the other way: F falls as the acceleration"),
    "free_fall_mass": (0, "free_fall.mass 7.5 kg too large"),
    "pressure_reversed": (0, "poly:linear: P = -2.491e-05 N/Pa (interval"),
    "max_effects_0": (0, "nothing screened (loop.max_effects is 0"),
    "force_1e300": (2, "channel F: 1 isolated sample(s) far outside"),
    "khz_as_hz": (2, "is the time column in ms rather than s (the log would be sampled at 1000"),
    "three_rows": (2, "the log holds only 3 sample(s)"),
    "dynamic_as_free_fall": (2, "given role free_fall, but it is no free fall"),
    "v_deadband_10": (2, "fit.v_deadband 10 m/s is above every speed"),
}


def _run(config: Path, results: Path, capsys, *flags) -> tuple[int, str, str]:
    code = main(["run", str(config), "--results", str(results), *flags])
    out = capsys.readouterr()
    return code, out.out, " ".join(out.err.split())


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_input_is_never_silent(name, tmp_path, capsys):
    code, said = CASES[name]
    status, out, err = _run(case(name, tmp_path / name), tmp_path / "results", capsys)
    assert status == code, err
    if code == 2:
        assert said in err and err.count("hmid run: error:") == 1
        assert "Traceback" not in err
        return
    assert said in err + out
    (report,) = (tmp_path / "results" / "bad").glob("*/report.md")
    summary = " ".join(report.read_text().split("\n## ")[0].split())
    assert said in summary


@pytest.mark.slow
@pytest.mark.parametrize("name", ["pressure_constant", "position_reversed"])
def test_strict_makes_a_finding_an_error(name, tmp_path, capsys):
    status, _, err = _run(
        case(name, tmp_path / name), tmp_path / "results", capsys, "--strict", "--quiet"
    )
    assert status == 2
    assert err.startswith("hmid run: error: --strict: ") and CASES[name][1] in err
    (manifest,) = (tmp_path / "results" / "bad").glob("*/manifest.json")
    assert '"failed"' in manifest.read_text()


def test_clean_demo_logs_give_no_finding(tmp_path):
    config = load_experiment(case("clean", tmp_path / "clean"))
    artifacts = analyse(config, ("inventory", "rows", "checks"), tmp_path / "cache")
    assert data_findings(artifacts) == () and artifacts["checks"] == ()


def test_a_declared_positive_coefficient_fitted_positive_is_no_finding(tmp_path):
    config = load_experiment(case("pressure_declared_positive", tmp_path / "case"))
    artifacts = analyse(config, ("fit", "checks"), tmp_path / "cache")
    assert sign_findings(artifacts) == ()
    (model,) = artifacts["fit"]
    assert model.coefficients.set_index("term").loc["P", "value"] > 0


@pytest.mark.slow
@pytest.mark.parametrize("name", ["demo", "knee", "linear-motor"])
def test_shipped_configs_give_no_finding(name, tmp_path):
    config = load_experiment(ROOT / "configs" / f"{name}.yaml")
    artifacts = analyse(config, ("inventory", "rows", "checks"), tmp_path / "cache")
    assert [f.message() for f in data_findings(artifacts)] == []
    assert sign_findings(artifacts | {"fit": []}) == ()


@pytest.mark.slow
def test_two_runs_give_byte_identical_metrics(tmp_path, capsys):
    """Wall times (the loop's parts, the SLS sampler's) go to timings.json, not metrics.json nor
    the report: two runs from empty caches give the same bytes."""
    config = case("clean", tmp_path / "case")
    text = config.read_text().replace(
        "- family: polynomial",
        "- {family: sls, spring: linear, stride: 4}\n- family: polynomial",
    )
    config.write_text(text + "loop: {base: sls, max_effects: 1}\n")
    runs = []
    for results in ("a", "b"):
        status, _, err = _run(config, tmp_path / results, capsys)
        assert status == 0, err
        (metrics,) = (tmp_path / results / "bad").glob("*/metrics.json")
        runs.append(metrics.parent)
    a, b = runs
    assert (a / "metrics.json").read_bytes() == (b / "metrics.json").read_bytes()
    assert _numbers(a / "report.md") == _numbers(b / "report.md")
    timings = json.loads((a / "timings.json").read_text())
    assert timings["loop_s"] and timings["samplers_s"]["sls"] > 0
    assert "wall_s" not in (a / "metrics.json").read_text()


def _numbers(report: Path) -> str:
    """The report less its provenance (run id, times, paths): what it says of the data."""
    return report.read_text().split("## Provenance")[0].replace(report.parent.name, "<run>")
