"""Test-suite settings: hypothesis runs derandomised under CI so a failure replays exactly."""

import os
from pathlib import Path

import pytest
import yaml
from hypothesis import settings

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")


ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def ch4_rig():
    """The thesis Ch. 4 rig as the demo declares it (configs/demo.yaml): load cell, friction
    from free falls, motion F = (M + m1) a + m1 g."""
    from hmid.balance import RigSection

    return RigSection.model_validate(
        yaml.safe_load((ROOT / "configs/demo.yaml").read_text())["rig"]
    )
