"""The README's minimal example is the shipped one, and it works: the config and column map shown
in README.md are docs/examples/mass-spring-damper/'s byte for byte, its log is what the committed
generator makes, and the run recovers the simulated m, c and k within their intervals."""

import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest

from pipelines.identify import run

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "docs/examples/mass-spring-damper"


def _generator():
    spec = importlib.util.spec_from_file_location("make_data", EXAMPLE / "make_data.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize(
    "name, opening",
    [("config.yaml", "name: mass-spring-damper"), ("columns.yaml", "# Which column of msd.csv")],
)
def test_the_readme_shows_the_shipped_files_whole(name, opening):
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```yaml\n(.*?)```", readme, flags=re.DOTALL)
    shown = [b for b in blocks if b.startswith(opening)]
    assert len(shown) == 1, f"README.md shows {name} once, as a ```yaml block"
    assert shown[0] == (EXAMPLE / name).read_text(encoding="utf-8")


def test_the_shipped_log_is_what_the_generator_makes():
    columns = _generator().simulate()
    logged = np.loadtxt(EXAMPLE / "msd.csv", delimiter=",", skiprows=1)
    for k, (name, values) in enumerate(columns.items()):
        np.testing.assert_allclose(logged[:, k], values, atol=6e-4, err_msg=name)  # 4 decimals


def test_the_example_recovers_the_simulated_parameters(tmp_path):
    truth = _generator().TRUTH
    folder, metrics = run(EXAMPLE / "config.yaml", results=tmp_path)
    assert (folder / "report.html").is_file() and metrics["sign_findings"] == []
    fitted = metrics["parameters"]["balance"]
    assert set(fitted) == {"m", "c", "k"}
    for name, p in fitted.items():
        assert p["lower"] <= truth[name] <= p["upper"], (name, p)
        assert p["value"] == pytest.approx(truth[name], rel=0.005), name
