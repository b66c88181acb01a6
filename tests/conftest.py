"""Test-suite settings: hypothesis runs derandomised under CI so a failure replays exactly."""

import os

from hypothesis import settings

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")
