"""The travel time by direction: from the reference's first move to 90 % of the output's own
travel, so a controller that stops short of the target still has one."""

import numpy as np

from hmid.control import reference
from hmid.control.metrics import tracking_score, travel_time


def test_the_travel_time_counts_to_90_percent_of_the_outputs_own_travel():
    t = np.arange(0, 3001) * 1e-3
    ref = reference("step_up", t, 0.0, 1.0, step_at=1.0, transition=0.2)
    tau = 0.1
    # a first-order approach from the step's start that stops at 60 % of the step
    y = np.where(t > 1.0, 0.6 * (1 - np.exp(-(t - 1.0) / tau)), 0.0)
    assert abs(travel_time(ref, t, y) - tau * np.log(10)) <= 1e-3  # one sample
    assert tracking_score(ref, t, y, 0.01, None).travel_s == travel_time(ref, t, y)
    sine = reference("sine", t, 0.0, 1.0)
    assert np.isnan(travel_time(sine, t, y))
