"""The denoising stage: new channels in SI, true motion recovered, short logs rejected clearly."""

import numpy as np
import pandas as pd
import pytest

from hmid.denoise import denoise_log
from hmid.errors import LogError
from hmid.io.log import Log
from hmid.signal import MovingAverage, SavitzkyGolay, Window
from hmid.simulate.profiles import Sine
from hmid.simulate.rigs.hydro_muscle_dataset import DynamicLog, HydroMuscleDataset

SMOOTHER = MovingAverage(Window(seconds=0.011))
DIFF = SavitzkyGolay(Window(seconds=0.051), polyorder=3)


def test_velocity_of_a_simulated_log_matches_the_truth():
    spec = DynamicLog(name="s", duration=6.0, profile=Sine())
    sim = HydroMuscleDataset(seed=4, logs=(spec,)).simulate(spec)
    out = denoise_log(sim.log, SMOOTHER, DIFF)
    assert {"P_s", "x_s", "F_s", "v", "a_est"} <= set(out.channels)
    assert out.units["v"] == "m/s" and out.units["P_s"] == "Pa"
    inner = slice(100, -100)  # one window from the ends (documented edge accuracy)
    err = out["v"][inner] - sim.trajectory.v[inner]
    # SG(51, 3) on 0.015 mm noise + 0.02 mm steps: noise ~ sigma 12^0.5 / (N^1.5 dt) ~ 0.15 mm/s,
    # plus the 12 Hz ringing and stick-slip kinks it smooths away (measured 0.37 mm/s, 1.8 % of
    # the ~20 mm/s amplitude); 3 % leaves room for other seeds, not for a broken estimator.
    assert np.sqrt(np.mean(err**2)) < 0.03 * np.max(np.abs(sim.trajectory.v))


def test_log_shorter_than_the_windows_names_the_file():
    t = np.arange(20) * 1e-3
    log = Log(pd.DataFrame({"t": t, "x": np.zeros(20)}), source="data/short.csv")
    with pytest.raises(LogError, match=r"^data/short\.csv: differentiating failed: .*51") as err:
        denoise_log(log, SMOOTHER, DIFF)
    assert "\n" not in str(err.value)


# -- advice that matches the cause (issue 13, item 8f and 8g) -----------------------------------
def kilohertz_log(n: int = 200, jitter: float = 0.0) -> Log:
    rng = np.random.default_rng(3)
    t = np.cumsum(1e-3 * (1 + jitter * rng.uniform(-1, 1, n)))
    return Log(pd.DataFrame({"t": t, "x": np.sin(t)}), source="data/k.csv")


@pytest.mark.parametrize(
    ("smoother", "diff", "expected"),
    [
        (  # a 3 ms cubic Savitzky-Golay window at 1 kHz is 3 samples: too SHORT
            SMOOTHER,
            SavitzkyGolay(Window(seconds=0.003), polyorder=3),
            "data/k.csv: differentiating failed: polyorder 3 needs a window of more than 3 "
            "samples, got 3; lengthen the window or lower polyorder "
            "(denoise.derivative, kind 'savitzky_golay')",
        ),
        (  # a 0.4 ms moving average at 1 kHz is less than one sample: too SHORT
            MovingAverage(Window(seconds=0.0004)),
            DIFF,
            "data/k.csv: smoothing failed: a window of 0.0004 s is shorter than half a time "
            "step (0.001 s); lengthen the window to at least one time step "
            "(denoise.smoother, kind 'moving_average')",
        ),
    ],
)
def test_a_window_too_short_is_told_to_be_longer(smoother, diff, expected):
    with pytest.raises(LogError) as err:
        denoise_log(kilohertz_log(), smoother, diff)
    assert str(err.value) == expected


def test_a_window_too_long_is_told_to_be_shorter():
    with pytest.raises(LogError) as err:
        denoise_log(kilohertz_log(20), SMOOTHER, DIFF)
    assert str(err.value) == (
        "data/k.csv: differentiating failed: a Savitzky-Golay window of 51 samples needs 51 "
        "samples but the signal has only 20; shorten the window or use a longer log "
        "(denoise.derivative, kind 'savitzky_golay')"
    )


def test_messages_name_the_config_kind_not_the_class():
    with pytest.raises(LogError) as err:
        denoise_log(kilohertz_log(jitter=0.2), SMOOTHER, DIFF)
    message = str(err.value)
    assert "SmoothedFiniteDifference" not in message and "SavitzkyGolay" not in message
    assert message.endswith(
        "resample the log or use derivative kind 'smoothed_difference' "
        "(denoise.derivative, kind 'savitzky_golay')"
    )
