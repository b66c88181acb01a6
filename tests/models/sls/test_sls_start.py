"""SLS starting point: tau-grid linear fits + Levenberg-Marquardt recover simulator truth."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from hmid.models.sls._data import sls_data
from hmid.models.sls.model import SLSModel
from hmid.models.sls.start import StartError, initial_fit
from hmid.simulate.params import RigParams
from hmid.simulate.profiles import Chirp
from hmid.simulate.rig import integrate
from hmid.simulate.rigs.hydro_muscle import HydroMuscle


@pytest.fixture(scope="module")
def rig_log():
    """6 s chirp on the simulated rig (50 substeps: sample-and-hold error ~5e-3 N), true x and
    P, true F_m plus N(0, 0.01 N) noise."""
    rig, rate = RigParams(), 1000.0
    t = np.arange(1, 6001) / rate
    tr = integrate(HydroMuscle(rig), {"P_cmd": Chirp().command(t, None)}, rate, substeps=50)
    noise = np.random.default_rng(11).normal(0.0, 0.01, t.size)
    frame = pd.DataFrame({"t": tr.t, "x": tr.x, "P": tr.P, "F": tr.F_m + noise, "use": True})
    return rig.muscle, frame


def test_initial_fit_recovers_simulator_truth(rig_log):
    muscle, frame = rig_log
    result = initial_fit(sls_data([frame]), SLSModel(spring="cubic", arms=1, noise="iid"))
    assert result.status == "successful" and result.n_steps > 0
    for name in ("A_eff", "k1", "k3", "k2", "tau"):
        assert result.physical[name] == pytest.approx(getattr(muscle, name), rel=0.02), name
    assert abs(result.physical["F0"]) < 0.05
    assert result.residual_std == pytest.approx(0.01, rel=0.1)
    assert result.physical["sigma"] == pytest.approx(result.residual_std)
    grid, sse = result.tau_profile
    assert grid.shape == (40, 1) and sse.shape == (40,)
    assert grid[np.argmin(sse), 0] == pytest.approx(muscle.tau, rel=0.3)
    assert result.notes == ()


def test_forced_failure_raises_start_error(rig_log):
    _, frame = rig_log
    with pytest.raises(StartError, match=r"maximum number of steps.*Best grid point: tau"):
        initial_fit(sls_data([frame]), SLSModel(), max_steps=1)


def test_two_arms_and_ar1_noise_on_model_data(rig_log):
    """Two arms (truth from the model itself) with AR(1) residuals phi = 0.5."""
    _, frame = rig_log
    model = SLSModel(spring="cubic", arms=2, noise="ar1")
    truth = {"A_eff": 2e-4, "F0": 0.3, "k1": 3000.0, "k3": 2e6, "k2_1": 1500.0, "tau_1": 0.02,
             "k2_2": 800.0, "tau_2": 0.5}  # fmt: skip
    rng = np.random.default_rng(12)
    e = rng.normal(0.0, 0.01, len(frame))
    r = np.zeros_like(e)
    for k in range(len(e)):
        r[k] = 0.5 * r[k - 1] + e[k] if k else e[k] / np.sqrt(1 - 0.25)
    data = sls_data([frame.assign(F=model.predict(truth, sls_data([frame])) + r)])
    result = initial_fit(data, model)
    for name, value in truth.items():
        tol = 0.05 if name != "F0" else 0.1
        assert result.physical[name] == pytest.approx(value, rel=tol, abs=1e-3), name
    assert result.physical["phi"] == pytest.approx(0.5, abs=0.05)
    assert result.physical["sigma"] == pytest.approx(0.01, rel=0.1)
    assert np.isfinite(float(model.log_prob(result.theta, data)))


def test_negative_linear_estimate_is_clipped_and_noted(rig_log):
    """A softening spring (k3 = -5e5 N/m³) fitted with the cubic model, whose k3 > 0: the
    linear solve gives k3 < 0, the start clips it, says so, and LM still converges."""
    _, frame = rig_log
    linear = {"A_eff": 2e-4, "F0": 0.0, "k1": 3000.0, "k2": 1500.0, "tau": 0.2}
    x = frame["x"].to_numpy()
    F = SLSModel(spring="linear").predict(linear, sls_data([frame])) + 5e5 * x**3
    noise = np.random.default_rng(13).normal(0.0, 0.01, len(frame))
    result = initial_fit(sls_data([frame.assign(F=F + noise)]), SLSModel(spring="cubic"))
    assert result.status == "successful"
    assert any(note.startswith("k3 = -") and "not positive" in note for note in result.notes)
    assert 0 < result.physical["k3"] < 1e5
