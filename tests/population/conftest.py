"""Shared pieces of the population tests."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

HERE = Path(__file__).parent


@pytest.fixture(scope="session")
def template() -> dict:
    """An SLS model file of the population's per-muscle experiment (the ch4 muscle's)."""
    return json.loads((HERE / "sls-template.json").read_text(encoding="utf-8"))
