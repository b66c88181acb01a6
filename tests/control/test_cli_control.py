"""``hmid control`` end to end on the shipped config (a short version of it), on the models a
finished identification run exported; its one-line errors."""

import json
from pathlib import Path

import pandas as pd
import yaml

from hmid.cli import main

SHIPPED = Path(__file__).resolve().parents[2] / "configs/control/muscle.yaml"


def _config(tmp_path: Path, **changes) -> Path:
    config = yaml.safe_load(SHIPPED.read_text()) | changes
    path = tmp_path / "control.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def test_the_shipped_config_runs_and_writes_its_report(identified, tmp_path, capsys):
    short = {
        "duration": 2.0,
        "step_at": 0.5,
        "references": ["step_up", "sine"],
        "robustness": {"draws": 3, "effects": [{"kind": "muscle_damping", "c": 3.0}]},
    }
    config = _config(tmp_path, model={"run": str(identified), "name": "sls"}, **short)
    results = tmp_path / "results"
    assert main(["control", str(config), "--results", str(results), "--quiet"]) == 0
    (run_dir,) = (tmp_path / "results" / "control-muscle").iterdir()
    for name in ("report.md", "report.html", "metrics.json", "manifest.json", "config.yaml"):
        assert (run_dir / name).is_file(), name
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert manifest["status"] == "complete"
    hashed = manifest["inputs_sha256"]
    assert any(p.endswith("sls.json") for p in hashed)
    assert any(p.endswith("sls.posterior.nc") for p in hashed)  # the draws it used
    targets = pd.read_csv(run_dir / "tables" / "targets.csv")
    assert len(targets) == 2 * 2 * 2  # tasks x references x valves
    proportional = targets[targets["valves"] == "proportional"]
    assert (proportional["reduction"] >= 0.5).all()
    metrics = json.loads((run_dir / "metrics.json").read_text())
    assert metrics["targets"]["reduction_met_proportional"] is True
    # FF+PID and FF+DOB beside FF+PD, each shaken on both valve kinds (FF+DOB where an
    # observer keeps the margins: tuning.csv has a row for each loop it runs on)
    robust = pd.read_csv(run_dir / "tables" / "robustness.csv")
    assert set(robust["controller"]) == {"FF+PD", "FF+PID", "FF+DOB"}
    assert set(robust["valves"]) == {"proportional", "on/off (switching)"}
    tuning = pd.read_csv(run_dir / "tables" / "tuning.csv")
    observed = tuning[tuning["controller"] == "FF+DOB"]
    assert {"force", "position"} <= set(observed[observed["valves"] == "proportional"]["task"])
    loops = 2 * 2 * 2 + len(observed)  # tasks x valves x (FF+PD, FF+PID), the observers'
    assert len(robust) == loops * 2 * 2  # x references x cases
    assert set(metrics["targets"]["robustness_met_by"]) >= {
        f"{c}, {v}" for c in ("FF+PD", "FF+PID") for v in ("proportional", "on/off (switching)")
    }
    pid = tuning[tuning["controller"] == "FF+PID"]
    assert len(pid) == 2 * 2 and (pid["ki (Pa/unit/s)"] != 0).all() and pid["stable"].all()
    # the steps by direction: a travel time each way, per valves and controller
    assert not (run_dir / "tables" / "directions.csv").read_text().strip()  # no step_down here
    assert {p.name for p in (run_dir / "figures").iterdir()} >= {"position_proportional.png"}
    assert "report:" in capsys.readouterr().out


def test_a_missing_model_run_says_to_run_the_demo_first(tmp_path, capsys):
    config = _config(tmp_path, model={"run": str(tmp_path / "nothing"), "name": "sls"})
    assert main(["control", str(config), "--results", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err.strip()
    assert "make demo" in err and len(err.splitlines()) == 1


def test_the_controllers_must_include_the_comparison(tmp_path, capsys):
    config = _config(tmp_path, controllers=["PD", "FF+PID"])
    assert main(["control", str(config), "--results", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err.strip()
    assert "controllers" in err and len(err.splitlines()) == 1


def test_an_unknown_key_is_named(tmp_path, capsys):
    config = _config(tmp_path, controler={"gain_margin_db": 6})
    assert main(["control", str(config), "--results", str(tmp_path / "r")]) == 2
    assert "controler" in capsys.readouterr().err


def test_a_model_without_pressure_is_one_line(identified, tmp_path, capsys):
    config = _config(tmp_path, model={"run": str(identified), "name": "poly:cubic_xv"},
                     duration=1.5, step_at=0.5, references=["step_up"],
                     robustness={"draws": 0})  # fmt: skip
    assert main(["control", str(config), "--results", str(tmp_path / "r"), "--quiet"]) == 2
    assert "no term in P" in capsys.readouterr().err


ANKLE = SHIPPED.parent / "ankle.yaml"


def test_the_shipped_ankle_config_runs_and_writes_its_report(fibre_models, tmp_path):
    config = yaml.safe_load(ANKLE.read_text())
    config["ankle"] |= {
        "plant": str(ANKLE.parent / "ankle-plant.yaml"),
        "models": {k: {"run": str(v), "name": "sls"} for k, v in fibre_models.items()},
        "scatter_draws": 2,
    }
    config |= {"duration": 2.0, "step_at": 0.5, "references": ["step_up", "step_down"],
               "robustness": {"draws": 2, "effects": [{"kind": "stribeck", "delta": 0.2,
                                                       "v_s": 0.05}]}}  # fmt: skip
    path = tmp_path / "ankle.yaml"
    path.write_text(yaml.safe_dump(config))
    assert main(["control", str(path), "--results", str(tmp_path / "r"), "--quiet"]) == 0
    (run_dir,) = (tmp_path / "r" / "control-ankle").iterdir()
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert manifest["status"] == "complete"
    assert sum(p.endswith("sls.json") for p in manifest["inputs_sha256"]) == 2  # both types
    targets = pd.read_csv(run_dir / "tables" / "targets.csv")
    assert len(targets) == 2 * 2  # references x valves
    assert (targets[targets["valves"] == "proportional"]["reduction"] >= 0.5).all()
    robust = pd.read_csv(run_dir / "tables" / "robustness.csv")
    assert set(robust["plant"]) == {"posterior (2 draws)", "build scatter (2 draws)", "stribeck"}
    tracking = pd.read_csv(run_dir / "tables" / "tracking.csv")
    assert (tracking[tracking["valves"] != "proportional"]["switchings"] > 0).all()
    assert set(tracking["controller"]) == {"PD", "FF+PD", "FF+PID", "FF+DOB"}
    directions = pd.read_csv(run_dir / "tables" / "directions.csv")
    assert len(directions) == 2 * 4  # valves x controllers
    assert (directions["up: travel (s)"] > 0).all() and (directions["down: travel (s)"] > 0).all()
    pd_rows = directions[directions["controller"] == "PD"]
    assert set(pd_rows["valves"]) == {"proportional", "on/off (switching)"}
    markdown = (run_dir / "tables" / "directions.md").read_text()  # the README's table
    assert markdown.startswith("angle:") and "travel, plantarflexion" in markdown
    assert markdown.count("\n| ") == 2 * 4 + 1  # header and a row per valves and controller
    assert (run_dir / "tables" / "robustness.md").is_file()
    assert {p.name for p in (run_dir / "figures").iterdir()} >= {"angle_proportional.png"}


def test_an_ankle_config_without_fibre_models_says_how_to_make_them(tmp_path, capsys):
    config = yaml.safe_load(ANKLE.read_text())
    config["ankle"] |= {"plant": str(ANKLE.parent / "ankle-plant.yaml"),
                        "models": {k: {"run": str(tmp_path / k)} for k in
                                   ("gastrocnemius", "soleus")}}  # fmt: skip
    path = tmp_path / "ankle.yaml"
    path.write_text(yaml.safe_dump(config))
    assert main(["control", str(path), "--results", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err.strip()
    assert "make fibre-models" in err and len(err.splitlines()) == 1


def test_ff_dob_runs_beside_the_comparison_where_an_observer_keeps_the_margins(
    identified, tmp_path
):
    config = _config(tmp_path, model={"run": str(identified), "name": "sls"},
                     controllers=["PD", "FF+PD", "FF+DOB"], duration=1.5, step_at=0.5,
                     references=["step_up"],
                     robustness={"draws": 0, "effects": [{"kind": "stribeck", "delta": 0.2,
                                                          "v_s": 0.005}]})  # fmt: skip
    assert main(["control", str(config), "--results", str(tmp_path / "r"), "--quiet"]) == 0
    (run_dir,) = (tmp_path / "r" / "control-muscle").iterdir()
    tuning = pd.read_csv(run_dir / "tables" / "tuning.csv")
    dob = tuning[tuning["controller"] == "FF+DOB"]
    # the proportional valve's loops have one each; the on/off force loop, whose PD has no gain
    # margin left behind the switching delay, none
    assert {("force", "proportional"), ("position", "proportional")} <= set(
        zip(dob["task"], dob["valves"], strict=True)
    )
    assert dob["stable"].all() and (dob["observer bandwidth (Hz)"] > 0).all()
    assert (dob["phase margin (deg)"] >= 45).all()
    tracking = pd.read_csv(run_dir / "tables" / "tracking.csv")
    ran = set(zip(tracking["task"], tracking["valves"], tracking["controller"], strict=True))
    assert {(t, v, "FF+DOB") for t, v in zip(dob["task"], dob["valves"], strict=True)} <= ran
    robust = pd.read_csv(run_dir / "tables" / "robustness.csv")
    assert "FF+DOB" in set(robust["controller"])
    assert "disturbance observer" in (run_dir / "report.md").read_text()
