"""The command line: help, simulate, relaxation, summary; bad input is one line and exit code 2."""

import errno
import json
import os
import re
import shutil
from pathlib import Path

import pytest
import yaml

from hmid.cli import main

ROOT = Path(__file__).resolve().parents[1]
#: The demo's rig section, as a flow-style YAML line
RIG = "rig: " + json.dumps(yaml.safe_load((ROOT / "configs/demo.yaml").read_text())["rig"])


def test_help_lists_the_commands(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--help"])
    assert exit_.value.code == 0
    out = capsys.readouterr().out
    for command in ("simulate", "summary", "run", "sweep", "blind"):
        assert command in out


@pytest.mark.parametrize("command", ["simulate", "summary", "run", "sweep", "blind"])
def test_each_command_explains_itself(command, capsys):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    assert len(capsys.readouterr().out.splitlines()) > 5


def test_simulate_writes_the_ch2_relaxation_figure_and_numbers(tmp_path):
    config = ROOT / "configs/simulate/ch2-relaxation.yaml"
    assert main(["simulate", str(config), "--out", str(tmp_path / "r"), "--quiet"]) == 0
    numbers = json.loads((tmp_path / "r/relaxation.truth.json").read_text())
    assert 64 < numbers["cases"]["instant"]["t_equilibrium_ms"] < 70
    assert (tmp_path / "r/relaxation.png").stat().st_size > 10_000
    curves = (tmp_path / "r/relaxation.csv").read_text().splitlines()
    assert curves[0] == "valve,t_s,x_m,v_m_per_s,a_m_per_s2,P_Pa" and len(curves) > 1000


def test_simulate_then_summary_end_to_end(tmp_path, capsys):
    config = tmp_path / "set.yaml"
    config.write_text(
        "seed: 5\nlogs:\n"
        "  - {name: sine, kind: dynamic, duration: 2, profile: {kind: sine}}\n"
        "  - {name: drop, kind: free_fall, duration: 0.3}\n"
    )
    assert main(["simulate", str(config), "--out", str(tmp_path / "data"), "--quiet"]) == 0
    experiment = tmp_path / "exp.yaml"
    experiment.write_text(
        f"name: tiny\nseed: 5\n{RIG}\nlogs:\n"
        "  - {path: data/sine.csv, columns: data/columns-dynamic.yaml, role: dynamic}\n"
        "  - {path: data/drop.csv, columns: data/columns-free_fall.yaml, role: free_fall}\n"
        "models: [{family: polynomial, variants: [quadratic_xv]}]\n"
    )
    results = tmp_path / "results"
    for _ in range(2):  # a second run gets its own folder: nothing is overwritten
        assert main(["summary", str(experiment), "--results", str(results)]) == 0
    runs = sorted(p for p in (results / "tiny").iterdir() if not p.name.startswith("."))
    assert len(runs) == 2
    first = runs[0]
    for name in ("summary.md", "summary.json", "manifest.json", "config.yaml", "overview.png"):
        assert (first / name).is_file(), name
    manifest = json.loads((first / "manifest.json").read_text())
    assert set(manifest["stage_wall_s"]) == {"load", "denoise", "report"}
    assert len(manifest["inputs_sha256"]) == 5  # the config, two logs and their two column maps
    summaries = json.loads((first / "summary.json").read_text())
    assert (
        json.loads((runs[1] / "summary.json").read_text()) == summaries
    )  # same data, same numbers
    assert [s["name"] for s in summaries] == ["sine", "drop"]


def test_bad_config_is_one_line_and_exit_2(tmp_path, capsys):
    config = tmp_path / "bad.yaml"
    config.write_text(
        "seed: 1\nlogs:\n"
        "  - {name: a, kind: dynamic, duration: 1, profile: {kind: sine, ofset: 1}}\n"
    )
    assert main(["simulate", str(config), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0
    expected = "key 'logs.0.profile.ofset': unknown key; allowed keys are offset, amplitude, kind"
    assert expected in err


def test_missing_log_file_names_the_key(tmp_path, capsys):
    experiment = tmp_path / "exp.yaml"
    shutil.copy(ROOT / "data/demo/columns-dynamic.yaml", tmp_path / "c.yaml")
    experiment.write_text(
        "name: x\nseed: 1\nrig: {channels: {x: {}}, position: x, explained: F, "
        "balance: [{kind: channel, name: M, channel: a}]}\nlogs:\n"
        "  - {path: nope.csv, columns: c.yaml, role: dynamic}\n"
        "models: [{family: balance}]\n"
    )
    assert main(["summary", str(experiment), "--results", str(tmp_path / "r")]) == 2
    assert "key 'logs.0.path': file" in capsys.readouterr().err
    (tmp_path / "nope.csv").mkdir()
    assert main(["summary", str(experiment), "--results", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert "key 'logs.0.path': " in err and "nope.csv is a folder, not a file" in err


def test_blind_prints_the_pass_marks_and_exits_by_them(tmp_path, capsys):
    blind = ROOT / "configs" / "blind"
    suite = tmp_path / "tiny.yaml"
    suite.write_text(
        f"name: tiny\nseed: 3\ndataset: {blind / 'dataset.yaml'}\n"
        f"experiment: {blind / 'experiment.yaml'}\nseeds: 1\nclean_seeds: 1\n"
        "executor: {kind: process, workers: 1}\n"
        "effects:\n  - {kind: pressure_lag, expect: delay.P, "
        "strengths: {moderate: {delay: 0.03}}}\n",
        encoding="utf-8",
    )
    code = main(["blind", str(suite), "--results", str(tmp_path / "results"), "--quiet"])
    out = capsys.readouterr().out
    assert "pressure_lag (moderate): delay.P named first" in out
    assert "clean: an effect added" in out
    assert code == 0, out  # both pass marks met: exit status 0
    assert list((tmp_path / "results" / "tiny").glob("*/blind.md"))


def test_run_prints_the_answer_and_the_loop_with_model_names(tmp_path, capsys):
    assert main(["run", str(ROOT / "configs/linear-motor.yaml"), "--results", str(tmp_path)]) == 0
    out = capsys.readouterr()
    lines = out.out.splitlines()
    assert (
        lines[0].startswith("best model: balance, held-out RMSE ") and "of u (one-step)" in lines[0]
    )
    assert lines[1].strip().startswith("u = ")  # the equation, then each parameter
    assert lines[2].strip().startswith("M = ") and "kg (95 % interval " in lines[2]
    assert any(line.startswith("free run of x: fit ") for line in lines)
    assert any(" left out (" in line for line in lines)
    loop = next(line for line in lines if line.startswith("loop on balance: "))
    assert "balance" in loop.split("RMSE")[1]
    assert lines[-1].startswith("report: ") and lines[-1].endswith("report.html")
    # not a terminal: one line per stage on stderr, no bars
    assert "hmid run: fit " in out.err and "hmid run: report " in out.err and "\r" not in out.err


def _demo_copy(tmp_path):
    """The demo config pointing at the repository's demo data, from a temporary folder."""
    text = (ROOT / "configs/demo.yaml").read_text().replace("../data/", f"{ROOT}/data/")
    config = tmp_path / "demo.yaml"
    config.write_text(text)
    return config


#: A stage's line in a log (stderr not a terminal): what ``hmid run`` says as it works.
STAGE_LINE = re.compile(r"hmid run: \w+ \d+\.\d s( \(cached\))? \[\d+ s\]")


def _said(err: str) -> list[str]:
    """stderr's lines less the stages' progress lines."""
    return [line for line in err.strip().splitlines() if not STAGE_LINE.fullmatch(line)]


def _one_line(err: str) -> str:
    lines = _said(err)
    assert len(lines) == 1, err
    return lines[0]


def test_results_that_is_a_file_is_one_line_and_exit_2(tmp_path, capsys):
    blocker = tmp_path / "results"
    blocker.write_text("not a folder")
    assert main(["summary", str(_demo_copy(tmp_path)), "--results", str(blocker)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert str(blocker) in line and "--results must name a folder" in line


def test_a_path_that_is_not_utf8_is_refused_before_the_work(tmp_path, capsys, monkeypatch):
    import pipelines.identify

    monkeypatch.setattr(pipelines.identify, "run", lambda *a, **k: pytest.fail("work started"))
    results = Path(os.fsdecode(bytes(tmp_path) + b"/r\xe9sultats"))  # Latin-1, not UTF-8
    assert main(["run", str(_demo_copy(tmp_path)), "--results", str(results)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "not valid UTF-8" in line and "r\\xe9sultats" in line


def test_a_results_root_that_is_not_writable_is_one_line(tmp_path, capsys, monkeypatch):
    import hmid.runs

    def refuse(results, *a):  # root runs the tests, so chmod cannot deny it: refuse instead
        raise PermissionError(errno.EACCES, "Permission denied", str(results))

    monkeypatch.setattr(hmid.runs, "new_run_dir", refuse)
    root = tmp_path / "locked"
    assert main(["summary", str(_demo_copy(tmp_path)), "--results", str(root)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith(f"hmid summary: error: {root}: permission denied; make it writable")


@pytest.mark.parametrize(
    ("error", "fix"),
    [
        (PermissionError(errno.EACCES, "Permission denied"), "make it writable"),
        (OSError(errno.ENOSPC, "No space left on device"), "free disk space"),
    ],
    ids=["cache not writable", "disk full"],
)
def test_a_cache_that_cannot_be_written_is_one_line_and_the_run_is_marked_failed(
    tmp_path, capsys, monkeypatch, error, fix
):
    import hmid.pipeline.cache

    def fail(*args, **kwargs):
        raise error

    monkeypatch.setattr(hmid.pipeline.cache.pickle, "dump", fail)
    results = tmp_path / "results"
    assert main(["run", str(_demo_copy(tmp_path)), "--results", str(results)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "/.cache/friction-" in line and fix in line  # the first stage that is stored
    (manifest,) = results.glob("demo/*/manifest.json")
    record = json.loads(manifest.read_text())
    assert record["status"] == "failed" and record["error"]


def test_ctrl_c_is_one_line_and_the_run_is_marked_failed(tmp_path, capsys, monkeypatch):
    import hmid.pipeline.runner

    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(hmid.pipeline.runner, "write_entry", interrupt)
    results = tmp_path / "results"
    assert main(["run", str(_demo_copy(tmp_path)), "--results", str(results)]) == 130
    assert "interrupted (Ctrl-C)" in _one_line(capsys.readouterr().err)
    (manifest,) = results.glob("demo/*/manifest.json")
    record = json.loads(manifest.read_text())
    assert record["status"] == "failed" and record["error"] == "interrupted (Ctrl-C)"
    assert main(["runs", str(results), "--failed"]) == 0
    assert "failed" in capsys.readouterr().out


def test_a_library_warning_is_not_passed_off_as_a_finding_of_hmid(capsys):
    from hmid.cli import _show_warning
    from hmid.errors import HmidWarning

    numpy_file = "/x/.venv/lib/python3.12/site-packages/numpy/_core/multiarray.py"
    _show_warning("overflow encountered\nin multiply", RuntimeWarning, numpy_file, 3)
    _show_warning("k1 < 0: check rig.channels.x.sign", HmidWarning, "/x/hmid/balance/checks.py", 9)
    err = capsys.readouterr().err.splitlines()
    assert err == [
        "hmid: note from numpy (RuntimeWarning): overflow encountered in multiply",
        "hmid: warning: k1 < 0: check rig.channels.x.sign",
    ]
