"""The loop on the measured pneumatic-cylinder logs (skips where the shared data are absent)."""

import os
from pathlib import Path

import pytest
import yaml

from hmid.cli import main
from pipelines.pneumatic import DataAbsent, run

REPO = Path(__file__).resolve().parents[2]
STUDY = REPO / "configs" / "studies" / "pneumatic.yaml"


def _study(tmp_path: Path, **changes) -> Path:
    data = yaml.safe_load(STUDY.read_text(encoding="utf-8")) | changes
    data["data"] = str((STUDY.parent / data["data"]).resolve())
    data["columns"] = str((STUDY.parent / data["columns"]).resolve())
    path = tmp_path / "study.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


@pytest.mark.shared_data
def test_seal_friction_grows_with_pressure_on_held_out_pressure(tmp_path):
    path = _study(tmp_path, seals=["NAPN"])
    try:
        run_dir, metrics = run(path, results=tmp_path / "results")
    except DataAbsent as err:
        pytest.skip(str(err))
    napn = metrics["seals"]["NAPN"]
    assert napn["effects"][0]["name"] == "pressure_friction"
    mu = {p["parameter"]: p for p in napn["effects"][0]["parameters"]}["mu"]
    assert 0 < mu["lower"] < mu["value"] < mu["upper"]
    assert napn["held_out_after"]["rmse"] < 0.7 * napn["held_out_before"]["rmse"]
    assert napn["held_out_before"]["kind"] == "one-step"
    text = (run_dir / "report.md").read_text(encoding="utf-8")
    assert "Seal NAPN" in text and "pressure-dependent friction" in text


def test_the_study_skips_cleanly_without_the_shared_data(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(os.environ, "HMID_SHARED_DATA", str(tmp_path / "nowhere"))
    assert main(["study", str(STUDY), "--results", str(tmp_path / "results")]) == 0
    assert "skipped" in capsys.readouterr().out
    assert not (tmp_path / "results").exists()
