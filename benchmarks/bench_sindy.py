"""SINDy family benchmarks: fit time on 30k rows with a 50-model ensemble and (with ``--study``)
term recovery and interval coverage against simulator truth across seeds. The free run, the
same integrator for every family, is timed by ``bench_freerun.py``.

Run: ``.venv/bin/python benchmarks/bench_sindy.py [--study [N_SEEDS]]``. Prints Markdown tables.
The baseline of the fit is pysindy's own ``EnsembleOptimizer`` (row bagging, 50 models) around
STLSQ on the same 30k-row design at the same threshold, without the threshold search.
"""

from __future__ import annotations

import sys
import warnings

import numpy as np
import pandas as pd
from _rigs import DEMO_RIG
from _timing import median_time

from hmid.balance import RigSection
from hmid.friction import Coulomb, FallRig, FrictionEstimate
from hmid.models.sindy import SINDyForceModel, SINDySettings
from hmid.simulate.params import MuscleParams, RigParams
from hmid.simulate.profiles import Chirp
from hmid.simulate.rig import integrate
from hmid.simulate.rigs.hydro_muscle import HydroMuscle

RIG = RigParams(muscle=MuscleParams(k2=0.0))  # no memory: the truth is in the library
TRUE = {"x": -3000.0, "P": 2e-4, "x^3": -2e6}
RATE = 1000.0


def truth_frame(seconds: float, seed: int = 0, noise: float = 0.01) -> pd.DataFrame:
    t = np.arange(1, int(seconds * RATE) + 1) / RATE
    traj = integrate(HydroMuscle(RIG), {"P_cmd": Chirp(f0=0.2, f1=3.0).command(t, None)}, RATE)
    m = RIG.muscle
    force = m.A_eff * traj.P + m.F0 - m.k1 * traj.x - m.k3 * traj.x**3
    rng = np.random.default_rng(seed)
    return pd.DataFrame(
        {"log": "chirp", "t": t, "x": traj.x, "v": traj.v, "P": traj.P,
         "F_m": force + noise * rng.standard_normal(len(t)), "stuck": traj.stuck}
    )  # fmt: skip


def fit_rows() -> tuple[pd.DataFrame, np.ndarray]:
    """The fit benchmarks' data: 30,000 sliding rows of a 40 s chirp (X: log, t, x, v, P; F_m)."""
    frame = truth_frame(40.0)
    rows_30k = frame[~frame["stuck"]].iloc[:30_000]
    return rows_30k[["log", "t", "x", "v", "P"]], rows_30k["F_m"].to_numpy()


def normalised_design(model: SINDyForceModel, X: pd.DataFrame, y: np.ndarray):
    """The fitted ``model``'s library on ``X``, each column divided by its RMS, and ``y`` by its
    standard deviation (a column): the problem the model's STLSQ solves, for pysindy."""
    design = model.library_.transform({c: X[c].to_numpy() for c in ("x", "v", "P")})
    design = design / np.sqrt(np.mean(design**2, axis=0))
    return design, (y / y.std()).reshape(-1, 1)


def bench_fit(rows) -> None:
    X, y = fit_rows()
    model = SINDyForceModel(SINDySettings(keep=()))
    ours = median_time(lambda: model.fit(X, y), 3)

    import pysindy as ps

    design, target = normalised_design(model, X, y)

    def baseline():
        state = np.random.get_state()  # noqa: NPY002 (EnsembleOptimizer uses the global state)
        try:
            np.random.seed(0)  # noqa: NPY002
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                opt = ps.EnsembleOptimizer(
                    ps.STLSQ(threshold=model.threshold_, alpha=0.0), bagging=True, n_models=50
                )
                opt.fit(design, target)
        finally:
            np.random.set_state(state)  # noqa: NPY002

    base = median_time(baseline, 3)
    rows.append(("SINDy fit: 30k rows, 17 terms, CV path (30 x 5 folds) + 50-model blocked "
                 "bootstrap", "pysindy EnsembleOptimizer(STLSQ), 50 row-bagged models, no CV",
                 ours, base, f"selected {', '.join(model.selected)}"))  # fmt: skip


# -- recovery and coverage study ---------------------------------------------------------------
def sensor_chain(seed: int, smooth_s: float, derivative_s: float) -> pd.DataFrame:
    """Training rows from a thesis-level sensor chain (10-bit ADC + noise), denoised and with F_m
    from the load cell and the true friction (the demo rig's balance, same filter both sides)."""
    from hmid.balance.prepare import prepare
    from hmid.denoise import denoise_log
    from hmid.experiment import MovingAverageSpec, SavitzkyGolaySpec
    from hmid.simulate.rigs.hydro_muscle_dataset import DynamicLog, HydroMuscleDataset

    profile = {"kind": "chirp", "f0": 0.2, "f1": 3.0}
    config = HydroMuscleDataset(
        seed=seed, rig=RIG, logs=[DynamicLog(name="chirp", duration=30, profile=profile)]
    )
    log = config.simulate(config.logs[0]).log
    smoother = MovingAverageSpec(window_s=smooth_s).build()
    differentiator = SavitzkyGolaySpec(window_s=derivative_s).build()
    log = denoise_log(log, smoother, differentiator, channels=("x", "P", "F"))
    fall = FallRig(RIG.M + RIG.m1, RIG.m1 * RIG.g)
    friction = FrictionEstimate.known(Coulomb(), {"Fc": RIG.friction.coulomb}, fall)
    units = {"x": "m", "P": "Pa", "F": "N", "v": "m/s", "a": "m/s^2", "target": "N"}
    signals = prepare(RigSection.model_validate(DEMO_RIG), {"chirp": [log]}, units,
                      smoother=smoother, differentiator=differentiator,
                      free_fall_law=friction.friction)  # fmt: skip
    frame = signals.frame.assign(F_m=signals.target)
    n = len(frame)
    frame = frame.iloc[50 : int(0.7 * n)]
    return frame[frame["usable"]]


def score(model: SINDyForceModel) -> dict:
    table = model.coefficient_table()
    table.index = [f.name for f in model.features_]
    low, high = table.columns[4], table.columns[5]
    right = set(model.selected) == set(TRUE)
    covered = [table.loc[k, low] <= v <= table.loc[k, high] for k, v in TRUE.items()]
    spurious = table.loc[[n for n in table.index if n not in TRUE], "inclusion"].max()
    k3 = table.loc["x^3", "value"]
    return {"right": right, "covered": sum(covered), "spurious": spurious,
            "k3_err": abs(k3 - TRUE["x^3"]) / abs(TRUE["x^3"])}  # fmt: skip


def study(seeds: int) -> str:
    cases = [("truth + white noise 0.01 N on F_m", None, {})] + [
        (f"sensor chain, smoothing {a * 1e3:g} ms, derivative {b * 1e3:g} ms", (a, b), {})
        for a, b in ((0.005, 0.03), (0.01, 0.05), (0.02, 0.1))
    ]
    cases += [
        (f"sensor chain, 10 ms / 50 ms, stick_speed {v * 1e3:g} mm/s", (0.01, 0.05),
         {"stick_speed": v})
        for v in (0.002, 0.005)
    ]  # fmt: skip
    lines = ["| data | right support | truth covered | max spurious inclusion (median) | "
             "|k3 error| (median) |", "|---|---:|---:|---:|---:|"]  # fmt: skip
    for label, windows, options in cases:
        results = []
        for seed in range(seeds):
            if windows is None:
                frame = truth_frame(30.0, seed=seed).pipe(lambda f: f[~f["stuck"]])
                frame = frame[frame["t"] < 21]
            else:
                frame = sensor_chain(seed, *windows)
            model = SINDyForceModel(SINDySettings(keep=(), **options), seed=seed)
            model.fit(frame[["log", "t", "x", "v", "P"]], frame["F_m"].to_numpy())
            results.append(score(model))
        n = len(results)
        lines.append(
            f"| {label} | {sum(r['right'] for r in results)}/{n} | "
            f"{sum(r['covered'] for r in results)}/{3 * n} | "
            f"{np.median([r['spurious'] for r in results]):.2f} | "
            f"{100 * np.median([r['k3_err'] for r in results]):.1f} % |"
        )
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    rows: list[tuple] = []
    bench_fit(rows)
    lines = ["| what | baseline | hmid [s] | baseline [s] | note |", "|---|---|---:|---:|---|"]
    for what, baseline, ours, base, note in rows:
        base_s = f"{base:.3f}" if base else "—"
        lines.append(f"| {what} | {baseline} | {ours:.3f} | {base_s} | {note} |")
    print("\n".join(lines))
    if argv and argv[0] == "--study":
        print()
        print(study(int(argv[1]) if len(argv) > 1 else 5))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
