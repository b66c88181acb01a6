"""The free-run integrator against known answers: a mass dragged against Coulomb friction, a
mass-spring-damper, and a model whose balance is not an equation of motion; a run that
diverges says when and which state left, and does not raise."""

import warnings

import numpy as np
import pandas as pd
import pytest

from hmid.balance import Signals
from hmid.portable import Model
from hmid.portable.file import FORMAT
from hmid.portable.freerun import NotSimulable, block_spans, blocks, simulate_signals


def _model(terms, coefficients, *, explained="u", motion=None, channels=("x", "u")):
    rig = {
        "name": "test rig",
        "channels": {c: {} for c in channels},
        "position": "x",
        "explained": explained,
        "balance": [dict(t, value=None) | {"name": t["name"]} for t in terms],
    }
    if motion is not None:
        rig["motion"] = motion
    document = {
        "format": FORMAT, "name": "m", "family": "balance", "rig": rig,
        "units": {"x": "m", "u": "N", "v": "m/s", "a": "m/s^2", "target": "N", "F": "N"},
        "denoise": {}, "fit": {"v_deadband": 1e-4}, "known": {"free_fall_friction": None},
        "terms": terms, "coefficients": {"names": [t["name"] for t in terms],
                                         "values": coefficients, "covariance": None},
    }  # fmt: skip
    return Model(document)


MASS = {"kind": "channel", "name": "M", "channel": "a"}
COULOMB = {"kind": "coulomb", "name": "Fc"}
SPRING = {"kind": "channel", "name": "k", "channel": "x"}
DAMPER = {"kind": "channel", "name": "c", "channel": "v"}


def test_a_mass_dragged_against_coulomb_friction_accelerates_uniformly():
    # u = M a + Fc sign(v): from rest under a constant 5 N, x = (u - Fc) / (2 M) t^2. The
    # regularised sign (tanh(v / v0), v0 = 0.1 mm/s) costs at most ~v0 * M / (u - Fc) s of lag.
    M, Fc, u = 0.75, 1.2, 5.0
    model = _model([MASS, COULOMB], [M, Fc])
    t = np.linspace(0.0, 1.0, 1001)
    run = model.simulate(t, {"u": np.full_like(t, u)}, x0=0.0)
    exact = 0.5 * (u - Fc) / M * t**2
    assert run.ok
    assert np.max(np.abs(run.x - exact)) < 1e-5 * np.max(exact)


def test_below_the_friction_level_the_mass_creeps_at_the_regularisation_speed():
    # a push below the friction level: with sign(v) ~ tanh(v / v0) the mass creeps at
    # v0 atanh(u / Fc) (0.12 mm/s here) instead of sticking: the price of the regularisation
    Fc, u, v0 = 1.2, 1.0, 1e-4
    model = _model([MASS, COULOMB], [0.75, Fc])
    t = np.linspace(0.0, 2.0, 201)
    run = model.simulate(t, {"u": np.full_like(t, u)}, x0=0.0)
    assert abs(run.v[-1] - v0 * np.arctanh(u / Fc)) < 1e-3 * v0


def test_a_mass_spring_damper_rings_down_as_the_closed_form_says():
    m, c, k, x0 = 2.0, 3.0, 150.0, 0.02
    model = _model([MASS, DAMPER, SPRING], [m, c, k])
    t = np.linspace(0.0, 3.0, 3001)
    run = model.simulate(t, {"u": np.zeros_like(t)}, x0=x0)
    zeta, wn = c / (2 * np.sqrt(k * m)), np.sqrt(k / m)
    wd = wn * np.sqrt(1 - zeta**2)
    exact = x0 * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))
    assert np.max(np.abs(run.x - exact)) < 1e-5 * x0


def test_a_sensor_read_through_the_motion_gives_the_force_it_would_read():
    # F = (M + m1) a + m1 g declared as motion; F = k (x_r - x) on the model side
    motion = {"mass": 0.75, "offset": 4.903325}
    spring = {"kind": "channel", "name": "k", "channel": "x", "sign": -1}
    offset = {"kind": "constant", "name": "F0"}
    model = _model([spring, offset], [200.0, 6.0], explained="F", motion=motion,
                   channels=("x", "F"))  # fmt: skip
    t = np.linspace(0.0, 5.0, 5001)
    run = model.simulate(t, {}, x0=0.0)
    rest = (6.0 - 4.903325) / 200.0
    exact = rest * (1 - np.cos(np.sqrt(200.0 / 0.75) * t))  # about x = (F0 - m1 g) / k
    assert np.max(np.abs(run.x - exact)) < 1e-5 * rest
    assert np.allclose(run.explained, 6.0 - 200.0 * run.x, atol=1e-6)


def test_an_equation_not_linear_in_the_acceleration_says_why():
    model = _model([{"kind": "channel", "name": "q", "channel": "a^2"}], [1.0])
    with pytest.raises(NotSimulable, match="not linear in a"):
        model.simulate(np.linspace(0, 1, 11), {"u": np.zeros(11)}, x0=0.0)


def test_runs_over_draws_in_one_call_equal_one_run_each():
    # to the error-controlled run's accuracy: a disturbance sampled as white noise has a kink at
    # every sample, which the draws' steps of one sample resolve and the error-controlled run
    # steps across (measured: 3e-4 of the motion off an rtol-1e-11 run, the draws 5e-9)
    model = _model([MASS, DAMPER, SPRING], [2.0, 3.0, 150.0])
    sim = model.simulator
    t = np.linspace(0.0, 1.0, 501)
    u = {"u": np.sin(7 * t)}
    draws, noise = [], np.random.default_rng(0).normal(0, 0.1, (3, len(t)))
    for scale in (0.9, 1.0, 1.1):
        cr, cl, taus, lags = sim.coefficients()
        draws.append((cr * scale, cl, taus, lags))
    batch = sim.positions(t, u, 0.01, 0.0, [], draws, noise)
    for row, draw, e in zip(batch, draws, noise, strict=True):
        one = sim.integrate(t, u, 0.01, coefficients=draw, disturbance=e).x
        assert np.max(np.abs(row - one)) < 3e-3 * np.max(np.abs(one))


def test_draws_at_steps_of_several_samples_are_finite_to_the_last_sample_on_a_step():
    # 501 samples: the last lies on a step of 5 (and of 4); it was NaN (the unused slot after
    # the last step, times 0), which counted every draw as diverging
    model = _model([MASS, DAMPER, SPRING], [2.0, 3.0, 150.0])
    sim = model.simulator
    t = np.linspace(0.0, 1.0, 501)
    u = {"u": np.sin(7 * t)}
    exact = sim.integrate(t, u, 0.01).x
    for stride in (4, 5):
        fixed = sim.positions(t, u, 0.01, 0.0, [], [sim.coefficients()], np.zeros((1, len(t))),
                              stride=stride)[0]  # fmt: skip
        assert np.all(np.isfinite(fixed))
        assert np.max(np.abs(fixed - exact)) < 1e-3 * np.ptp(exact)


def test_a_rig_that_imposes_its_position_has_no_free_run():
    # the pneumatic seals' balance: force = A P + F0 + Fc sign(v), no inertial term
    terms = [{"kind": "channel", "name": "A", "channel": "u"}, {"kind": "constant", "name": "F0"},
             COULOMB]  # fmt: skip
    model = _model(terms, [1e-3, 0.5, 3.0], explained="F", channels=("x", "u", "F"))
    with pytest.raises(NotSimulable, match="imposes its position"):
        model.simulate(np.linspace(0, 1, 11), {"u": np.zeros(11)}, x0=0.0)


def _held_out(starts: dict[str, float]) -> Signals:
    """One 2 s held-out log per name, at rest under u = 0, its measured x a 1 mm sine about the
    given start (which the free run starts from)."""
    t = np.linspace(0.0, 2.0, 2001)
    frames = [
        pd.DataFrame({"log": name, "t": t, "x": x0 + 1e-3 * np.sin(2 * np.pi * t), "u": 0.0,
                      "v": 0.0, "explained": 0.0, "target": 0.0, "validation": True})
        for name, x0 in starts.items()
    ]  # fmt: skip
    units = {"x": "m", "u": "N", "v": "m/s", "explained": "N", "target": "N"}
    return Signals.from_frame(pd.concat(frames), units, position="x")


def test_a_diverging_block_is_reported_with_its_time_and_state_and_the_others_run_on():
    # u = M a + k x with k < 0: x = 0 is an unstable equilibrium, from which the block at rest
    # never leaves; from x0 = 1 mm, x grows as cosh(sqrt(-k / M) t) (e-folding 8.7 ms) and
    # leaves the box of the measured motion (3.5 spans about its mean) after ~20 ms
    M, k = 0.75, -1e4
    model = _model([MASS, SPRING], [M, k])
    signals = _held_out({"rest": 0.0, "away": 1e-3})
    run = simulate_signals(model, signals, blocks(signals))
    rest, away = run.runs
    assert (rest.log, away.log) == ("rest", "away")
    assert rest.diverged_at is None and np.all(rest.x_simulated == 0.0)
    exit_time = np.arccosh(1 + 3.5 * 2e-3 / 1e-3) / np.sqrt(-k / M)
    assert away.diverged_at == pytest.approx(exit_time, abs=2e-3)
    assert away.reason == "x left the measured range"
    scores = run.scores()
    assert scores["free-run blocks"] == 2 and scores["diverged"] == 1
    assert scores["rmse x"] == pytest.approx(1e-3 / np.sqrt(2), rel=1e-3)  # the block at rest


def test_a_run_that_overflows_is_a_divergence_without_numpy_warnings():
    """A run that blows up is the free run's to report; numpy's 'overflow encountered' on the
    way there is not news for the console."""
    model = _model([MASS, SPRING], [1e-6, -1e12])  # e-folding 1 ns: inf within the first step
    signals = _held_out({"away": 1e-3})
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        run = simulate_signals(model, signals, blocks(signals))
    (away,) = run.runs
    assert away.diverged_at is not None and away.diverged_at < 0.01
    assert away.reason == "x left the measured range"  # non-finite: outside any range
    assert np.isnan(run.scores()["fit % (x)"])


def test_a_long_logs_blocks_are_sampled_within_the_budget_and_said():
    from hmid.portable.freerun import within_budget
    from hmid.portable.freerun.run import FREE_RUN_BUDGET_S

    spans = [np.arange(i * 20_000, i * 20_000 + 10_000) for i in range(40)]  # 40 blocks of 10 s
    kept, note = within_budget(spans, 1e-3)
    assert FREE_RUN_BUDGET_S == 60.0
    assert [r[0] for r in kept] == [r[0] for r in spans[::7]]  # 6 blocks, 60 s: the least stride
    assert note.startswith("free run on 6 of 40 held-out blocks (every 7th")
    assert within_budget(spans[:3], 1e-3) == (spans[:3], "")
    one = [np.arange(200_000)]  # a single block of 200 s: its first minute
    kept, note = within_budget(one, 1e-3)
    assert (
        len(kept) == 1 and len(kept[0]) == 60_000 and note.startswith("free run on the first 60 s")
    )


def test_the_regularisation_is_as_small_as_a_sample_step_integrates_stably():
    # a 95 kg stage with 20 N of Coulomb friction logged at 1 kHz, fitted with a 2 mm/s cut-off:
    # near v = 0 the friction damps at Fc / (M v0); one sample stays stable while
    # dt Fc / (M v0) <= 2, so v0 = dt Fc / (2 M) = 0.105 mm/s, and a push of half the level
    # creeps at v0 atanh(1/2) (0.06 mm/s) rather than 1.1 mm/s at the cut-off
    from hmid.portable.freerun import simulator
    from hmid.portable.freerun.equation import free_run_v0

    M, Fc, dt = 95.0, 20.0, 1e-3
    model = _model([MASS, COULOMB], [M, Fc])
    document = model.document | {"fit": {"v_deadband": 2e-3}, "sample_rate_hz": 1 / dt}
    model = Model(document)
    v0 = dt * Fc / (2 * M)
    assert free_run_v0(model) == pytest.approx(v0)
    t = np.arange(2001) * dt
    u = np.full_like(t, Fc / 2)
    run = model.simulate(t, {"u": u}, x0=0.0)
    assert run.v[-1] == pytest.approx(v0 * np.arctanh(0.5), rel=1e-3)
    # the band's fixed steps of one sample follow the error-controlled run there
    sim = simulator(model)
    fixed = sim.positions(t, {"u": u}, 0.0, 0.0, None, [sim.coefficients()], np.zeros((1, len(t))))
    assert np.max(np.abs(fixed[0] - run.x)) < 1e-3 * np.ptp(run.x)


def test_the_free_runs_on_their_rows_alone_equal_those_on_the_whole_signals():
    """What the pipeline runs (:func:`held_rows`: the blocks' and the band's calibration rows as
    signals of their own, a memory arm's states found on the whole log) gives the same runs,
    bands and calibration as the whole signals, to the bit."""
    from hmid.portable.freerun import held_rows

    memory = {"kind": "memory", "name": "k2", "channel": "x", "tau": 0.05}
    model = _model([MASS, SPRING, DAMPER, memory], [0.75, 200.0, 5.0, 50.0])
    model.document["coefficients"]["covariance"] = np.diag([1e-4, 1.0, 1e-2, 1.0]).tolist()
    t = np.linspace(0.0, 8.0, 8001)
    frames = []
    for name, phase in (("a", 0.0), ("b", 1.0)):
        x = 2e-3 * np.sin(2 * np.pi * 0.7 * t + phase)
        held_out = (t > 3.0) & (t < 4.5) | (t > 6.5)
        frames.append(pd.DataFrame({
            "log": name, "t": t, "x": x, "u": 200.0 * x, "v": np.gradient(x, t),
            "explained": 200.0 * x, "target": 200.0 * x, "train": ~held_out,
            "validation": held_out,
        }))  # fmt: skip
    units = {"x": "m", "u": "N", "v": "m/s", "explained": "N", "target": "N"}
    signals = Signals.from_frame(pd.concat(frames), units, position="x")
    spans, training = blocks(signals), blocks(signals, "train")
    options = {"draws": 5, "seed": 2}
    whole = simulate_signals(model, signals, spans, calibration=training, **options)
    held = held_rows(signals, spans, training, [model])
    # the pipeline's spans are ranges (a long log's blocks are not held as row numbers)
    ranges = held_rows(signals, block_spans(signals), block_spans(signals, "train"), [model])
    assert [list(r) for r in block_spans(signals)] == [list(rows) for rows in spans]
    for field in ("spans", "pieces"):
        for one, other in zip(getattr(held, field), getattr(ranges, field), strict=True):
            np.testing.assert_array_equal(one, other)
    pd.testing.assert_frame_equal(held.signals.frame, ranges.signals.frame)
    assert len(held.signals) < len(signals) and held.memory["m"]
    alone = simulate_signals(model, held.signals, held.spans, held=held, **options)
    assert whole.calibration is not None and whole.runs[0].band is not None
    assert whole.band == alone.band and whole.calibration == alone.calibration
    assert len(whole.runs) == len(alone.runs) == len(spans)
    for one, other in zip(whole.runs, alone.runs, strict=True):
        assert one.log == other.log and one.diverged_at == other.diverged_at
        for field in ("t", "x_measured", "x_simulated", "explained_measured", "band"):
            np.testing.assert_array_equal(getattr(one, field), getattr(other, field))


def test_a_stored_program_is_read_back_without_tracing_and_a_damaged_one_is_traced_again(
    tmp_path,
):
    import jax

    from hmid.portable.freerun.stored import stored

    traced = []

    def program():  # a new function each time, as in a new process (JAX keeps its own traces)
        def f(x, k):
            traced.append(1)
            return jax.lax.fori_loop(0, 3, lambda i, y: y * k + 1.0, x)

        return f

    x, k = np.linspace(0.0, 1.0, 5), np.float64(1.5)
    with jax.enable_x64(True):
        first = np.asarray(stored(program(), "f", "shape", tmp_path)(x, k))
        again = np.asarray(stored(program(), "f", "shape", tmp_path)(x, k))
        assert len(traced) == 1 and np.array_equal(first, again)
        (path,) = tmp_path.glob("freerun-programs/f-*.exported")
        path.write_bytes(path.read_bytes()[:-5])
        damaged = np.asarray(stored(program(), "f", "shape", tmp_path)(x, k))
        assert len(traced) == 2 and np.array_equal(first, damaged)
        assert np.array_equal(first, np.asarray(jax.jit(program())(x, k)))


def test_writing_a_stored_program_removes_the_programs_of_other_builds(tmp_path):
    """An upgrade (other sources or library versions) leaves no dead programs: the files of
    other builds unused for a day, this format's and the one before it, go when a program is
    written; another build's program in use, and this build's other programs, stay."""
    import os
    import time

    import jax

    from hmid.portable.freerun.stored import UNUSED_S, stored

    folder = tmp_path / "freerun-programs"
    folder.mkdir()
    stale = [folder / "f-000000000000-0123456789abcdef.exported", folder / f"g-{'0' * 24}.exported"]
    live = folder / "f-111111111111-0123456789abcdef.exported"
    for path in (*stale, live):
        path.write_bytes(b"a program of another build")
    old = time.time() - UNUSED_S - 60
    for path in stale:
        os.utime(path, (old, old))
    x = np.linspace(0.0, 1.0, 5)
    with jax.enable_x64(True):
        stored(lambda y: y * 2.0, "f", "shape", tmp_path)(x)
        stored(lambda y: y + 1.0, "g", "shape", tmp_path)(x)
    assert live.exists() and not any(path.exists() for path in stale)
    assert len(list(folder.glob("*.exported"))) == 3


def test_the_band_coverage_comes_with_an_interval_over_its_blocks():
    """Blocks covered 3 of 4 and 4 of 4: 7 of 8 pooled, the interval the ratio's cluster
    standard error (1/8 here) times t(1)'s 95 % point, clipped to [0, 1]. One block gives no
    interval; a run without a band has no coverage at all."""
    from scipy import stats

    from hmid.portable.freerun import FreeRun, coverage_interval
    from hmid.portable.freerun.scores import BlockRun

    t, x = np.arange(4.0), np.array([0.0, 1.0, 2.0, 3.0])

    def block(low: float) -> BlockRun:
        band = (np.full(4, low), np.full(4, 3.0))
        return BlockRun("log", t, x, x + 0.1, x, None, None, band=band)

    scores = FreeRun("m", (block(0.5), block(0.0))).scores()
    assert scores["band coverage"] == 7 / 8
    low, high = scores["band coverage interval"]
    assert low == pytest.approx(7 / 8 - stats.t.ppf(0.95, 1) / 8) and high == 1.0
    assert np.isnan(coverage_interval([np.array([True, True, False])])).all()
    bare = FreeRun("m", (BlockRun("log", t, x, x, x, None, None),)).scores()
    assert np.isnan(bare["band coverage"]) and np.isnan(bare["band coverage interval"]).all()


def test_a_perfect_models_band_is_centred_on_its_error_controlled_run():
    """A stage with stiff friction near v = 0 (95 kg, 20 N Coulomb, 1 kHz: the band's steps of
    several samples miss the error-controlled run), no coefficient uncertainty and no residual,
    the measured position its own free run: the band lies on it (4 µm, the restarts' rounding,
    which a drift of 1e-6 m/√s takes up). Made of the fixed steps' runs themselves it lay 3 mm
    off, and a drift a thousand times larger was calibrated to cover that."""
    model, signals = _perfect_stage()
    spans, training = blocks(signals), blocks(signals, "train")
    found = simulate_signals(model, signals, spans, calibration=training, draws=5, seed=1)
    gap = max(np.max(np.abs(np.asarray(r.band) - r.x_measured)) for r in found.runs)
    assert gap < 2e-5 and found.calibration is not None and found.calibration.scale < 1e-5


def test_a_band_that_no_scale_calibrates_is_not_drawn(monkeypatch):
    """Its coverage would check nothing: the runs have no band, the coverage is NaN, and the
    band's description says why."""
    from hmid.portable.freerun import Calibration
    from hmid.portable.freerun import run as freerun_run

    model, signals = _perfect_stage()
    monkeypatch.setattr(freerun_run, "choose",
                        lambda *_: Calibration(16384.0, 0.03, 100, reachable=False))  # fmt: skip
    found = simulate_signals(model, signals, blocks(signals), draws=5, seed=1,
                             calibration=blocks(signals, "train"))  # fmt: skip
    assert found.runs and all(r.band is None for r in found.runs)
    assert np.isnan(found.scores()["band coverage"]) and found.level == 0.9
    assert "band not calibrated: no disturbance scale reaches the level" in found.band


def _perfect_stage():
    """A 95 kg stage with 20 N Coulomb friction at 1 kHz, two logs whose measured position is
    the model's own free run (the last 2 s of 6 held out), and the model."""
    model = _model([MASS, DAMPER, COULOMB], [95.0, 200.0, 20.0])
    model.document["sample_rate_hz"] = 1000.0
    t = np.arange(6000) / 1000.0
    rng = np.random.default_rng(3)
    frames = []
    for name in ("a", "b"):
        u = np.interp(t, t[::250], rng.normal(0.0, 60.0, len(t[::250])))
        run = model.simulate(t, {"u": u}, x0=0.0)
        held_out = t >= 4.0
        frames.append(pd.DataFrame({
            "log": name, "t": t, "x": run.x, "v": run.v, "u": u, "explained": u, "target": u,
            "train": ~held_out, "validation": held_out,
        }))  # fmt: skip
    units = {"x": "m", "u": "N", "v": "m/s", "explained": "N", "target": "N"}
    return model, Signals.from_frame(pd.concat(frames), units, position="x")
