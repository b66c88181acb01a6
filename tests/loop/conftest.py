"""Fixtures of the loop tests (the data themselves: _loop_data.py)."""

import pytest
from _loop_data import make_data


@pytest.fixture
def synthetic():
    return make_data
