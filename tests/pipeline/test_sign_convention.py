"""A rig whose elongation sign is the reverse of the declared convention: said on the console and
in the report, naming the channel; declared with ``sign: -1``, the numbers are the normal ones."""

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml

from hmid.errors import HmidWarning
from pipelines.identify import run

ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "data/demo"


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    """The demo logs with column maps that read x negated (the sensor counts the other way),
    and a fast experiment: the SLS by least squares (signs free) and a polynomial."""
    root = tmp_path_factory.mktemp("sign")
    for kind in ("dynamic", "free_fall"):
        columns = yaml.safe_load((DEMO / f"columns-{kind}.yaml").read_text())
        x = columns["channels"]["x"]
        x["scale"], x["range"] = -1.0, [-x["range"][1], -x["range"][0]]
        (root / f"reversed-{kind}.yaml").write_text(yaml.safe_dump(columns))
    demo = yaml.safe_load((ROOT / "configs/demo.yaml").read_text())
    from hmid.balance import RigSection
    from hmid.families.balance import BalanceSpec

    rig = RigSection.model_validate(demo["rig"])
    experiment = {
        "name": "sign", "seed": 1, "rig": demo["rig"], "denoise": demo["denoise"],
        "friction": demo["friction"], "fit": demo["fit"], "split": demo["split"],
        "models": [BalanceSpec.example(rig).model_dump(mode="json", by_alias=True)
                   | {"name": "sls-ls"},
                   {"family": "polynomial", "variants": ["cubic_xvP"]}],
    }  # fmt: skip
    return root, experiment, demo["logs"]


def _run(root, experiment, logs, *, reversed_map: bool, sign: int, name: str):
    data = copy.deepcopy(experiment)
    data["logs"] = [
        {"path": str(ROOT / "configs" / e["path"]),
         "columns": str(root / f"reversed-{e['role']}.yaml") if reversed_map
         else str(ROOT / "configs" / e["columns"]), "role": e["role"]}
        for e in logs
    ]  # fmt: skip
    data["rig"]["channels"]["x"] = data["rig"]["channels"]["x"] | {"sign": sign}
    path = root / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return run(path, results=root / "results")


def test_a_reversed_elongation_is_flagged_and_declaring_it_restores_the_numbers(setup):
    root, experiment, logs = setup
    _, normal = _run(root, experiment, logs, reversed_map=False, sign=1, name="normal")
    assert normal["sign_findings"] == []
    with pytest.warns(HmidWarning) as said:
        run_dir, wrong = _run(root, experiment, logs, reversed_map=True, sign=1, name="wrong")
    lines = [str(w.message) for w in said]
    assert any(line.startswith("sls-ls: k1 = -") for line in lines)
    assert all("rig.channels.x.sign: -1" in line and "\n" not in line for line in lines)
    flagged = {f["parameter"] for f in wrong["sign_findings"]}
    # the springs read x; the declared motion's mass (checked whatever the family) is flagged too
    springs = [f for f in wrong["sign_findings"] if f["parameter"] in ("k1", "k2")]
    assert {"k1", "k2"} <= flagged and all(f["channels"] == ["x"] for f in springs)
    report = (run_dir / "report.md").read_text(encoding="utf-8")
    assert "physical-sign check" in report and "rig.channels.x.sign" in report
    _, declared = _run(root, experiment, logs, reversed_map=True, sign=-1, name="declared")
    assert declared["sign_findings"] == []
    assert declared["held_out"] == normal["held_out"]
    for model in ("sls-ls",):
        a, b = normal["parameters"][model], declared["parameters"][model]
        assert a.keys() == b.keys()
        for name in a:
            assert b[name]["value"] == pytest.approx(a[name]["value"], rel=1e-12, abs=1e-15)
    assert np.isfinite(declared["held_out"][0]["rmse (held-out)"])
