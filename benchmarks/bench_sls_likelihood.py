"""SLS log-likelihood: 20,000 samples x 32 walkers, hmid (JAX, jitted) against per-walker SciPy.

Run: ``.venv/bin/python benchmarks/bench_sls_likelihood.py``. Prints a Markdown table of medians
over repeats (after a warm-up call that compiles):

* hmid's ``SLSModel.log_likelihood`` on (32, D) walkers, uneven steps (0.5-2 ms), for each way of
  evaluating the arm recursion (sequential ``lax.scan`` - the default -, ``associative_scan``,
  blocked scan) and for ``jax.vmap`` of the one-walker function (JAX's batch layout);
* per walker ``scipy.integrate.solve_ivp`` (RK45, rtol 1e-6) of the same model, with the
  velocity piecewise constant between samples: a few walkers are timed and scaled to 32;
* per walker ``scipy.signal.lfilter`` of the exact recursion, for the uniform-step case (1 ms).
"""

from __future__ import annotations

import math
import statistics
import time

import jax
import jax.numpy as jnp
import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp
from scipy.signal import lfilter

from hmid.models.sls import likelihood as lik
from hmid.models.sls._data import sls_data
from hmid.models.sls.model import SLSModel
from hmid.signal.maxwell import SCAN  # the library's default scan

N, WALKERS, IVP_WALKERS = 20_000, 32, 2


def median_time(fn, repeats: int) -> float:
    return median_times({"": fn}, repeats)[""]


def median_times(fns: dict, repeats: int) -> dict:
    """Median wall time of each function; repeats interleaved so load drifts hit all alike."""
    for fn in fns.values():
        fn()  # warm-up: compilation
    times = {name: [] for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            start = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - start)
    return {name: statistics.median(values) for name, values in times.items()}


def make_data(rng, uniform: bool):
    steps = np.full(N - 1, 1e-3) if uniform else rng.uniform(0.5e-3, 2e-3, N - 1)
    t = np.concatenate([[0.0], np.cumsum(steps)])
    x = 0.006 + 0.003 * np.sin(2 * np.pi * 0.7 * t) + 0.0008 * np.sin(2 * np.pi * 3.3 * t)
    P = 1.4e5 + 8e4 * np.sin(2 * np.pi * 0.7 * t + 0.3)
    frame = pd.DataFrame({"t": t, "x": x, "P": P, "F": np.zeros(N), "use": True})
    model = SLSModel(spring="cubic", arms=1, noise="iid")
    truth = {"A_eff": 2e-4, "F0": 0.0, "k1": 3000.0, "k3": 2e6, "k2": 1500.0, "tau": 0.2}
    F = model.predict(truth, sls_data([frame])) + rng.normal(0.0, 0.01, N)
    frame["F"] = F
    theta0 = model.theta_from({**truth, "sigma": 0.01})
    walkers = theta0 + 0.01 * rng.normal(size=(WALKERS, theta0.size))
    return model, sls_data([frame]), frame, walkers


def scipy_loglik(space, theta, frame, arm_force) -> float:
    """The model's iid log-likelihood with the arms from ``arm_force(k2, tau)`` (NumPy)."""
    phys = space.to_physical(np.asarray(theta))
    x, P, F = (frame[c].to_numpy() for c in ("x", "P", "F"))
    q = arm_force(phys["k2"], phys["tau"])
    model = phys["A_eff"] * P + phys["F0"] - phys["k1"] * x - phys["k3"] * x**3 - q
    r, sigma = F - model, phys["sigma"]
    return float(
        -0.5 * np.sum(r**2) / sigma**2 - N * (math.log(sigma) + 0.5 * math.log(2 * math.pi))
    )


def ivp_arm(frame):
    t, x = frame["t"].to_numpy(), frame["x"].to_numpy()
    v = np.diff(x) / np.diff(t)

    def arm(k2, tau):
        def rhs(s, q):
            k = min(np.searchsorted(t, s, side="right") - 1, len(v) - 1)
            return -q / tau + k2 * v[k]

        sol = solve_ivp(rhs, (t[0], t[-1]), [0.0], t_eval=t, method="RK45", rtol=1e-6, atol=1e-9)
        return sol.y[0]

    return arm


def lfilter_arm(frame):
    t, x = frame["t"].to_numpy(), frame["x"].to_numpy()
    dt = t[1] - t[0]
    v = np.concatenate([[0.0], np.diff(x) / dt])

    def arm(k2, tau):
        a = math.exp(-dt / tau)
        return lfilter([k2 * tau * (1 - a)], [1.0, -a], v)

    return arm


def main() -> None:
    rng = np.random.default_rng(2024)
    rows = []
    model, data, frame, walkers = make_data(rng, uniform=False)
    reference = np.asarray(model.log_likelihood(walkers, data))
    scans = ("sequential", "associative", "blocked")
    space = model.space
    with jax.enable_x64(True):
        per_walker = jax.jit(jax.vmap(lambda th, d: lik.log_likelihood(space, th[None], d)[0],
                                      in_axes=(0, None)))  # fmt: skip
        theta64 = jnp.asarray(walkers)
        fns = {scan: lambda scan=scan: model.log_likelihood(walkers, data, scan=scan)
               .block_until_ready() for scan in scans}  # fmt: skip
        fns["vmap"] = lambda: per_walker(theta64, data).block_until_ready()
        times = median_times(fns, 40)
        vmapped = np.asarray(per_walker(theta64, data))
    for scan in scans:
        agree = np.max(
            np.abs(np.asarray(model.log_likelihood(walkers, data, scan=scan)) - reference)
        )
        rows.append((f"hmid, {scan} scan (walkers batched time-major)", times[scan], None, None,
                     f"max abs. Δ loglik vs {SCAN} (default) {agree:.1e}"))  # fmt: skip
    agree = np.max(np.abs(vmapped - reference))
    rows.append((f"hmid, jax.vmap of the one-walker function ({SCAN})", times.pop("vmap"),
                 None, None, f"max abs. Δ loglik {agree:.1e}"))  # fmt: skip

    ivp = ivp_arm(frame)
    start = time.perf_counter()
    ivp_ll = [scipy_loglik(space, w, frame, ivp) for w in walkers[:IVP_WALKERS]]
    t_ivp = (time.perf_counter() - start) / IVP_WALKERS * WALKERS
    rel = np.max(
        np.abs(np.array(ivp_ll) - reference[:IVP_WALKERS]) / np.abs(reference[:IVP_WALKERS])
    )
    # the real default, fastest or not: it is what a fit uses
    rows.append((f"hmid, {SCAN} scan (default)", times[SCAN],
                 f"solve_ivp RK45 per walker ({IVP_WALKERS} timed, x{WALKERS // IVP_WALKERS})",
                 t_ivp, f"uneven steps; loglik rel. diff {rel:.1e}"))  # fmt: skip

    model_u, data_u, frame_u, walkers_u = make_data(rng, uniform=True)
    lf = lfilter_arm(frame_u)
    uniform = median_times({
        "hmid": lambda: model_u.log_likelihood(walkers_u, data_u).block_until_ready(),
        "lfilter": lambda: [scipy_loglik(space, w, frame_u, lf) for w in walkers_u],
    }, 20)  # fmt: skip
    t_hmid_u, t_lf = uniform["hmid"], uniform["lfilter"]
    lf_ll = np.array([scipy_loglik(space, w, frame_u, lf) for w in walkers_u])
    ref_u = np.asarray(model_u.log_likelihood(walkers_u, data_u))
    rel = np.max(np.abs(lf_ll - ref_u) / np.abs(ref_u))
    rows.append((f"hmid, {SCAN} scan (default), uniform 1 ms steps", t_hmid_u,
                 "lfilter per walker (uniform steps only)", t_lf,
                 f"loglik rel. diff {rel:.1e}"))  # fmt: skip

    model_a = SLSModel(spring="cubic", arms=1, noise="ar1")
    walkers_a = np.concatenate([walkers, np.full((WALKERS, 1), 0.3)], axis=1)
    t_ar1 = median_time(lambda: model_a.log_likelihood(walkers_a, data).block_until_ready(), 40)
    rows.append((f"hmid, AR(1) noise, {SCAN} scan (default)", t_ar1, None, None, "uneven steps"))

    print(f"SLS log-likelihood, {N:,} samples x {WALKERS} walkers, median of repeats "
          f"({jax.devices()[0].platform}, jax {jax.__version__})\n")  # fmt: skip
    print("| case | hmid (ms) | baseline | baseline (ms) | speed-up | note |")
    print("|---|---:|---|---:|---:|---|")
    for case, ours, base_name, base, note in rows:
        speed = f"{base / ours:,.0f}x" if base else "—"
        base_ms = f"{base * 1e3:,.1f}" if base else "—"
        print(f"| {case} | {ours * 1e3:.2f} | {base_name or '—'} | {base_ms} | {speed} | {note} |")


if __name__ == "__main__":
    main()
