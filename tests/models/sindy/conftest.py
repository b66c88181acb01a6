"""Session fixtures of the SINDy tests: the simulated truth (see _sindy_truth.py) and fits."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from _sindy_truth import RATE, RIG, training_rows, true_force

from hmid.friction import Coulomb, FallRig, FrictionEstimate
from hmid.simulate.profiles import Chirp


@pytest.fixture(scope="session")
def trajectory():
    from hmid.simulate.rig import integrate
    from hmid.simulate.rigs.hydro_muscle import HydroMuscle

    t = np.arange(1, int(30 * RATE) + 1) / RATE
    return integrate(HydroMuscle(RIG), {"P_cmd": Chirp(f0=0.2, f1=3.0).command(t, None)}, RATE)


@pytest.fixture(scope="session")
def truth(trajectory) -> pd.DataFrame:
    """Every sample: true x, v, P, the stuck flag, and the true force map at the sample.

    The simulator logs F_m from its last substep, where x lags the logged x by one substep
    (v dt/20): that adds a real (k1 + 3 k3 x²) v dt/20 term (~0.005 N RMS) that the library can
    also represent. The truth here is the force map itself, evaluated at the logged states.
    """
    tr = trajectory
    return pd.DataFrame(
        {"log": "chirp", "t": tr.t, "x": tr.x, "v": tr.v, "P": tr.P,
         "F_true": true_force(tr.x, tr.P), "stuck": tr.stuck}
    )  # fmt: skip


@pytest.fixture(scope="session")
def true_friction() -> FrictionEstimate:
    fall = FallRig(RIG.M + RIG.m1, RIG.m1 * RIG.g)
    return FrictionEstimate.known(Coulomb(), {"Fc": RIG.friction.coulomb}, fall)


@pytest.fixture(scope="session")
def truth_fits(truth):
    """keep=() (no term spared the threshold), seeds 0, 1, 2 for noise and ensemble."""
    from hmid.models.sindy import SINDyForceModel, SINDySettings

    return {
        seed: SINDyForceModel(SINDySettings(keep=()), seed=seed).fit(*training_rows(truth, seed))
        for seed in (0, 1, 2)
    }
