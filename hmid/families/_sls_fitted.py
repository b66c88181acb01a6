"""The fitted SLS family member: a posterior (exact draws or an emcee chain) that predicts on
pipeline rows, states its terms for the loop, and reports its diagnostics."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from hmid.balance import RigSection, Structure
from hmid.families.base import Extras, FigureSpec, FitData, FittedModel
from hmid.intervals import IntervalNote

PREDICT_BATCH = 25  # posterior draws predicted at once for the band


#: The longest residual correlation time (samples) at which the widened SLS intervals were
#: measured: AR(1) phi = 0.8 and the smoothed white noise (tau_int 20) of
#: benchmarks/bench_sls_calibration.py.
SLS_CALIBRATED_TAU = 20.0
#: The fewest effectively independent rows per parameter (n / tau_int / 6) measured there: 4,000
#: fitted rows of the smoothed noise, 33 at its tau_int 20.
SLS_CALIBRATED_PER_TERM = 30.0


@dataclass(frozen=True)
class SLSFitted(FittedModel):
    """A sampled SLS posterior that predicts on FitData rows (pickled by the stage cache)."""

    spec: Any  # hmid.families.sls.SLSSpec
    noise: str
    result: Any  # hmid.models.sls.SamplerResult
    lag1_rho: float
    lag1_p: float
    correlated: bool
    seed: int
    start_notes: tuple[str, ...]
    rig: RigSection
    method: str = "mcmc"  # "exact": independent draws from the collapsed posterior
    grid: Any = None  # hmid.models.sls.collapsed.PosteriorGrid of the exact posterior
    adjustment: Any = None  # hmid.models.sls._sandwich.Adjustment, if the draws were widened

    def structure(self) -> Structure:
        """The SLS terms at the posterior median's relaxation times."""
        physical = self._physical(self.theta_median[None])
        names = (
            ["tau"] if self.spec.arms == 1 else [f"tau_{i}" for i in range(1, self.spec.arms + 1)]
        )
        return self.spec.structure(self.rig, tuple(float(physical[n][0]) for n in names))

    @property
    def model(self):
        from hmid.models.sls import SLSModel

        linear = "identity" if self.method == "exact" else "log"
        return SLSModel(self.spec.spring, self.spec.arms, self.noise, linear)

    @property
    def theta_median(self) -> np.ndarray:
        return np.median(self.result.chain, axis=0)

    def _physical(self, chain: np.ndarray) -> dict[str, np.ndarray]:
        return {k: np.asarray(v) for k, v in self.model.space.to_physical(chain).items()}

    def posterior_draws(self) -> dict[str, np.ndarray]:
        """The posterior's draws in physical units, shape (chains, draws) each: the exact
        posterior's independent draws as one chain; an emcee run's walkers after burn-in as
        chains (thinned as the summary's)."""
        if self.method == "exact" or self.result.walkers is None:
            chains = self.result.chain[None]
        else:
            burn, thin = int(self.result.burn_in), max(int(self.result.thin), 1)
            chains = np.swapaxes(self.result.walkers[burn::thin], 0, 1)
        shape = chains.shape[:2]
        physical = self._physical(chains.reshape(-1, chains.shape[-1]))
        return {name: np.asarray(v).reshape(shape) for name, v in physical.items()}

    def posterior_table(self) -> pd.DataFrame:
        space = self.model.space
        units = dict(zip(space.physical_names, space.units, strict=True))
        return self.result.summary(units, self.spec.confidence, transform=self._physical)

    def equation(self, table: pd.DataFrame) -> str:
        terms = ", ".join(f"{n} = {r['median']:.4g} {r['unit']}" for n, r in table.iterrows())
        spring = "k1·x + k3·x³" if self.spec.spring == "cubic" else "k1·x"
        return f"F_m = A_eff·P + F0 − ({spring} + q), dq/dt = −q/τ + k2·dx/dt; {terms}"

    def notes(self) -> tuple[str, ...]:
        r = self.result
        if self.method == "exact":
            axes = "tau and phi" if self.noise == "ar1" else "tau"
            how = (
                f"exact posterior: A_eff, F0, k1{', k3' if self.spec.spring == 'cubic' else ''}, "
                f"k2 and sigma integrated out (flat prior on the force parameters, 1/sigma on "
                f"sigma), {axes} on a grid of {self.grid.log_density.size} points; "
                f"{r.n_steps} independent draws"
            )
        else:
            how = (
                f"posterior from emcee ({r.n_walkers} walkers, {r.n_steps} steps, stopped: "
                f"{r.stop_reason}); min ESS {np.min(r.ess):.0f}, acceptance "
                f"{r.acceptance_mean:.2f}"
            )
        notes = [how, self._interval_method()]
        notes += [
            f"noise model {self.noise}: lag-1 autocorrelation of the start fit's residuals "
            f"{self.lag1_rho:.2f} (Ljung-Box p = {self.lag1_p:.2g})",
        ]
        if self.correlated and self.noise == "iid" and self.adjustment is None:
            notes.append(
                "residuals are clearly correlated, so these i.i.d.-likelihood intervals are too "
                "narrow (optimistic); noise: ar1 widens them but can bias the point estimate"
            )
        if self.method != "exact" and not r.converged:
            notes.append("the chain did not reach 50 autocorrelation times: intervals are rough")
        notes += self._unsettled_signs()
        said = self.reused()  # None unless the chain was read back
        if said is not None:
            notes.append(said)
        return (*notes, *self.start_notes)

    def interval_note(self) -> IntervalNote:
        """What the posterior intervals are, for the table's columns."""
        level, a = self.spec.confidence, self.adjustment
        if a is not None:
            return IntervalNote(
                level, "posterior, widened to the autocovariance sandwich", a.tau_int,
                SLS_CALIBRATED_TAU, "benchmarks/bench_sls_calibration.py", a.window is not None,
                **self._rows_and_terms(),
            )  # fmt: skip
        if self.noise == "ar1":
            return IntervalNote(level, "posterior, AR(1) likelihood",
                                claim="calibrated on AR(1) residuals")  # fmt: skip
        return IntervalNote(level, "posterior, i.i.d. likelihood")

    def _rows_and_terms(self) -> dict[str, Any]:
        """The adjusted fit's rows and parameters, for the label's effective rows per term
        (none from a cached adjustment made before they were recorded)."""
        a = self.adjustment
        if not np.isfinite(getattr(a, "n_eff", np.nan)):
            return {}
        return {"n_rows": round(a.n_eff * a.tau_int), "n_terms": len(a.widening),
                "calibrated_per_term": SLS_CALIBRATED_PER_TERM}  # fmt: skip

    def _interval_method(self) -> str:
        """The intervals' level, method and calibration (benchmarks/bench_sls_calibration.py)."""
        level = f"{100 * self.spec.confidence:g} % posterior intervals"
        a = self.adjustment
        if a is not None:
            widest = max(a.widening, key=a.widening.get)
            within = bool(self.interval_note().within)
            return (
                f"{level}, widened to the sandwich covariance for the residual's autocovariance "
                f"(correlation time {a.tau_int:.3g} samples; widths x{min(a.widening.values()):.2f}"
                f"-{a.widening[widest]:.2f}, most for {widest}; corrected for the fit's "
                f"projection, the residual's own reads {a.raw_tau_int:.3g}); calibrated for "
                f"residual correlation times up to {SLS_CALIBRATED_TAU:g} samples and at least "
                f"{SLS_CALIBRATED_PER_TERM:g} effective rows per parameter, this fit "
                f"{'within' if within else 'BEYOND'} that range"
            )
        if self.noise == "ar1":
            return f"{level} of the AR(1) likelihood (calibrated on AR(1) residuals)"
        if self.method == "exact":
            return f"{level} of the i.i.d. likelihood, not adjusted (errors: likelihood)"
        return f"{level} of the i.i.d. likelihood (emcee: no sandwich adjustment)"

    def _unsettled_signs(self) -> list[str]:
        """The flat prior lets the data decide a force parameter's sign: say where they don't."""
        if self.method != "exact":
            return []
        physical = self._physical(self.result.chain)
        out = []
        for name in ("A_eff", "k1", "k3", "k2"):
            if name in physical and (share := float(np.mean(physical[name] <= 0))) > 0.01:
                out.append(
                    f"{name}: {100 * share:.0f} % of the posterior lies at or below 0; the data "
                    "do not establish its physical (positive) sign"
                )
        return out

    def reused(self) -> str | None:
        """Said when the chain was read back: the numbers are a fresh run's, the time is not."""
        r = self.result
        if not r.reused_steps:
            return None
        return (
            f"the chain's first {r.reused_steps} of {r.n_steps} steps were read back from "
            f"{r.backend_path} (every row checked against its digest; a fresh run stops at the "
            "same step with the same draws)"
        )

    # -- predictions on pipeline rows ---------------------------------------------------------
    def _rows(self, data: FitData):
        """Every sample (the recursion is exact at any rate; stride only eases sampling), and
        the mask of the role's rows."""
        from hmid.models.sls import sls_data

        frames = self.spec._segments(data, data.role, stride=1)
        # prediction needs no forces: every row is "used", the role's rows are picked after
        return sls_data([f.assign(F=0.0, use=True) for f in frames]), data.rows

    def predict(self, data: FitData) -> np.ndarray:
        full, rows = self._rows(data)
        return data.slot_sign * self.model.predict(self.theta_median, full)[rows]

    def predict_interval(self, data: FitData) -> tuple[np.ndarray, np.ndarray]:
        """Posterior predictive band: parameter draws plus the noise model's marginal spread."""
        full, rows = self._rows(data)
        rng = np.random.default_rng([self.seed, 5])
        draws = self.result.draws(self.spec.predictive_draws, rng)
        sigma, phi = (np.asarray(v) for v in self.model.space.noise_params(draws))
        scale = sigma / np.sqrt(1.0 - phi**2) if self.noise == "ar1" else sigma
        # in batches of draws: the whole-log (n, draws) prediction would dominate peak memory
        noisy = np.empty((int(rows.sum()), len(draws)))
        for lo in range(0, len(draws), PREDICT_BATCH):
            hi = min(lo + PREDICT_BATCH, len(draws))
            noisy[:, lo:hi] = self.model.predict(draws[lo:hi], full)[rows]
        noisy += rng.standard_normal(noisy.shape) * scale[None, :]
        tail = (1.0 - self.spec.confidence) / 2.0
        lower, upper = np.quantile(data.slot_sign * noisy, [tail, 1.0 - tail], axis=1)
        return lower, upper

    def _corner(self) -> FigureSpec:
        """The corner plot in physical units (a simulator's truth marked where the report
        knows one)."""
        from hmid.models.sls.diagnostics import CORNER_DRAWS, physical_corner_plot

        draws = {k: v.ravel() for k, v in self.posterior_draws().items()}
        n = len(next(iter(draws.values())))
        if n > CORNER_DRAWS:  # thinned here: only what is drawn goes to the worker
            keep = np.linspace(0, n - 1, CORNER_DRAWS).astype(int)
            draws = {k: v[keep] for k, v in draws.items()}
        space = self.model.space
        units = dict(zip(space.physical_names, space.units, strict=True))
        return FigureSpec(physical_corner_plot, (draws, units), "corner.png",
                          "Posterior corner plot in physical units (5, 50 and 95 % quantiles)",
                          dear=True, takes_truth=True)  # fmt: skip

    def report_extras(self) -> Extras:
        from hmid.models.sls.diagnostics import trace_plot

        r = self.result  # the corner plot, the dearest, is among the first drawn
        if self.method == "exact":
            from hmid.models.sls.diagnostics import grid_plot

            text = (
                f"Exact posterior, {r.n_steps} independent draws: the force "
                "parameters and sigma integrated out analytically (flat prior on A_eff, F0, k1, "
                "k3, k2, so their signs come from the data; p(sigma) ∝ 1/sigma), the relaxation "
                "time (and phi) on a grid spanning 8 posterior standard deviations. Intervals "
                f"are {100 * self.spec.confidence:.0f} % equal-tailed posterior intervals."
            )
            return Extras(
                text=text,
                tables=[],
                figures=[
                    FigureSpec(
                        grid_plot, (self.grid,), "grid.png", "Marginal posterior on the grid"
                    ),
                    self._corner(),
                ],
            )
        diag = pd.DataFrame(
            {
                "parameter": list(r.names),
                "autocorr. time [steps]": r.tau,
                "effective samples": r.ess,
            }
        )
        from hmid.portable.posterior import diagnostics

        arviz = diagnostics(self.posterior_draws()).rename(
            columns={"r_hat": "R-hat (rank-normalised)", "ess_bulk": "ESS bulk",
                     "ess_tail": "ESS tail"}
        )  # fmt: skip
        text = (
            f"Sampler: {r.n_walkers} walkers, {r.n_steps} steps, burn-in {r.burn_in}, thinning "
            f"{r.thin}, stopped by **{r.stop_reason}**; mean acceptance "
            f"{r.acceptance_mean:.2f}. Intervals are {100 * self.spec.confidence:.0f} % "
            "equal-tailed posterior intervals."
        )
        return Extras(
            text=text,
            tables=[
                (diag, "MCMC diagnostics per sampled coordinate (emcee)"),
                (arviz, "ArviZ diagnostics per parameter, the walkers read as chains"),
            ],
            figures=[
                FigureSpec(trace_plot, (r,), "trace.png", "Trace of every walker (burn-in shaded)"),
                self._corner(),
            ],
        )
