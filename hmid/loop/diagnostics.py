"""Residual diagnostics on the training rows: whiteness, independence from the inputs, and
nonlinear dependence on the signals (which linear tests miss).

* autocorrelation to ``max_lag_s`` with the 99 % bound of a white residual, +-2.576/sqrt(n);
* cross-correlation with the rig's channels (position, velocity, the others) over
  +-``max_lag_s``;
* Ljung-Box (statsmodels) on the residual decimated to ``stride_s`` (the smoothing filters
  correlate neighbouring samples by construction; past their reach a white residual is white);
* pattern scan (the residual's pattern; a fitted balance's terms are its
  :class:`~hmid.balance.Structure`): for each signal, the residual's conditional mean in quantile
  bins (split by the direction of motion) is estimated on three of four interleaved folds of
  0.5 s blocks and predicts the fourth:
  the cross-fitted share of residual variance it explains is a correlation ratio eta² that sees
  any smooth or stepwise dependence, multiplicative ones included, and is ~0 for noise (at
  least 0: a cross-fitted share below zero is noise);
* the residual's power spectrum (Welch).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from hmid.balance import Signals
from hmid.stats import autocorrelation, integrated_time, lag_count, masked_series

N_BINS = 24
N_BINS_TIME = 6  # coarser than a fold block, so every time bin is seen by the other folds
FOLDS = 4
FOLD_BLOCK_S = 0.5  # folds interleave blocks of this length
HUGE = 1e100  # a residual this large is scaled before it is squared
SPECTRUM_ROWS = 1024  # consecutive finite rows a Welch segment of the spectrum needs
MIN_DIAGNOSED_ROWS = 50  # finite training rows of a residual below which it is not diagnosed


def inputs(data: Signals) -> dict[str, np.ndarray]:
    """The channels a residual is correlated with: the position, its velocity, the others."""
    names = [data.position, "v"] if data.position is not None else []
    names += [c for c in data.channels if c not in ("v", "a") and c != data.position]
    return {name: data[name] for name in names}


def signals(data: Signals) -> dict[str, np.ndarray]:
    """The signals a residual is scanned against: :func:`inputs`, the rate of change of each
    input other than the position and its velocity (a Savitzky-Golay derivative over ~50 ms per
    segment: a 10-bit pressure differenced at 1 kHz is mostly quantisation steps), and t."""
    from scipy.signal import savgol_filter

    out = inputs(data)
    t = data["t"]
    window = lag_count(data, 0.05, 5) | 1
    for name in [n for n in out if n not in (data.position, "v")]:
        values, rate = out[name], np.empty(len(data))
        for rows in data.segments():
            dt = float(np.median(np.diff(t[rows]))) if len(rows) > 1 else 1.0
            if len(rows) > window:
                rate[rows] = savgol_filter(values[rows], window, 2, deriv=1, delta=dt)
            else:
                rate[rows] = np.gradient(values[rows], t[rows]) if len(rows) > 1 else 0.0
        out[f"d{name}/dt"] = rate
    out["t"] = t
    return out


def unit(data: Signals, name: str) -> str:
    """SI unit of a scanned signal (``dP/dt`` is the unit of P per second)."""
    if name == "t":
        return "s"
    if name.startswith("d") and name.endswith("/dt"):
        return f"{data.unit(name[1:-3])}/s"
    return data.unit(name)


@dataclass(frozen=True)
class Diagnostics:
    lags_s: np.ndarray
    acf: np.ndarray
    acf_bound: float  # 99 % bound of a white residual at full rate
    tau_int: float  # integrated autocorrelation time, samples
    ljung_box_p: float
    ljung_box_n: int
    ccf: pd.DataFrame  # index lag [s], a column per input
    pattern: pd.DataFrame  # signal -> eta² (cross-fitted), binned means for plots
    spectrum: tuple[np.ndarray, np.ndarray]  # frequency [Hz], PSD [unit²/Hz]
    rms: float

    @property
    def strongest(self) -> tuple[str, float]:
        """The signal that explains most of the residual, and its η² (``("none", 0.0)`` where
        no signal could be scanned: a residual with too few finite rows)."""
        eta2 = self.pattern["eta2"].dropna()
        if eta2.empty:
            return "none", 0.0
        row = eta2.idxmax()
        return str(row), float(eta2[row])


def _ccf(residual, rows, data, inputs, lags) -> pd.DataFrame:
    out = {}
    for name, u in inputs.items():
        r = masked_series(residual, rows, data, lags.max())
        s = masked_series(u, rows, data, lags.max())
        values = []
        for k in lags:
            a, b = (r[: len(r) - k], s[k:]) if k >= 0 else (r[-k:], s[: len(s) + k])
            ok = np.isfinite(a) & np.isfinite(b)
            values.append(np.corrcoef(a[ok], b[ok])[0, 1] if ok.sum() > 2 else np.nan)
        out[name] = values
    return pd.DataFrame(out, index=pd.Index(lags, name="lag"))


def _folds(data: Signals) -> np.ndarray:
    """Interleaved time blocks, so every fold spans the whole log (drifts included)."""
    return (np.floor(data["t"] / FOLD_BLOCK_S).astype(int) + data["segment"]) % FOLDS


def pattern_scan(residual: np.ndarray, rows: np.ndarray, data: Signals) -> pd.DataFrame:
    """Cross-fitted eta² of the residual on each signal (binned, split by direction)."""
    direction = (data["v"] >= 0).astype(int)
    fold = _folds(data)[rows]
    r = residual[rows]
    total = float(((r - r.mean()) ** 2).sum())
    out = {}
    for name, values in signals(data).items():
        n_bins = N_BINS_TIME if name == "t" else N_BINS
        edges = np.unique(np.quantile(values[rows], np.linspace(0, 1, n_bins + 1)))
        cell = np.clip(np.searchsorted(edges, values[rows], side="right") - 1, 0, len(edges) - 2)
        cell = cell * 2 + direction[rows]
        predicted = np.zeros_like(r)
        for k in range(FOLDS):
            fit, test = fold != k, fold == k
            sums = np.bincount(cell[fit], weights=r[fit], minlength=2 * N_BINS)
            counts = np.bincount(cell[fit], minlength=2 * N_BINS)
            means = np.divide(sums, counts, out=np.zeros_like(sums), where=counts > 0)
            predicted[test] = means[cell[test]]
        eta2 = 1.0 - float(((r - predicted) ** 2).sum()) / total if total > 0 else 0.0
        # cross-fitted, a signal that explains nothing predicts worse than the mean: below
        # zero is noise, and a share of variance is never negative
        eta2 = max(eta2, 0.0)
        out[name] = {"eta2": eta2}
    return pd.DataFrame.from_dict(out, orient="index")


def binned_mean(
    residual: np.ndarray, rows: np.ndarray, values: np.ndarray, data: Signals
) -> pd.DataFrame:
    """Residual mean per quantile bin of ``values``, per direction (for plots)."""
    edges = np.unique(np.quantile(values[rows], np.linspace(0, 1, N_BINS + 1)))
    centre = 0.5 * (edges[1:] + edges[:-1])
    frame = pd.DataFrame(
        {
            "bin": np.clip(
                np.searchsorted(edges, values[rows], side="right") - 1, 0, len(centre) - 1
            ),
            "direction": np.where(data["v"][rows] >= 0, "v >= 0", "v < 0"),
            "r": residual[rows],
        }
    )
    table = frame.groupby(["direction", "bin"])["r"].agg(["mean", "count"]).reset_index()
    table["centre"] = centre[table["bin"]]
    return table


def _spectrum(series: np.ndarray, dt: float, nperseg: int = SPECTRUM_ROWS):
    """Welch PSD averaged over the finite runs of ``series`` that hold a whole segment length."""
    from scipy.signal import welch

    finite = np.concatenate([[False], np.isfinite(series), [False]])
    edges = np.flatnonzero(np.diff(finite.astype(int)))
    runs = [series[a:b] for a, b in zip(edges[::2], edges[1::2], strict=True) if b - a >= nperseg]
    if not runs:
        return np.array([0.0]), np.array([0.0])
    spectra = [welch(run, fs=1 / dt, nperseg=nperseg) for run in runs]
    weights = [len(run) for run in runs]
    return spectra[0][0], np.average([s[1] for s in spectra], axis=0, weights=weights)


def diagnose(
    residual: np.ndarray, data: Signals, *, max_lag_s: float = 0.5, stride_s: float = 0.05
) -> Diagnostics:
    """All diagnostics of ``residual`` (every row of ``data``) on its training rows."""
    from statsmodels.stats.diagnostic import acorr_ljungbox

    # a model's prediction may be non-finite or astronomically large (a diverged fit): the
    # diagnostics read the finite rows, and the scale-free ones a residual scaled to order one
    rows = data.train & np.isfinite(residual)
    dt = float(np.median(np.diff(data["t"][:1000])))
    finite = residual[rows]
    scale = float(np.max(np.abs(finite))) if len(finite) else 0.0
    if rows.sum() < MIN_DIAGNOSED_ROWS or not np.isfinite(scale) or scale == 0.0:
        return _undiagnosed(residual, rows, data, dt, lag_count(data, max_lag_s))
    if scale < HUGE:  # as it is: the same numbers as ever
        scale = 1.0
    else:
        residual = np.where(rows, residual / scale, 0.0)
    nlags = lag_count(data, max_lag_s)
    acf = autocorrelation(residual, rows, data, nlags)
    stride = lag_count(data, stride_s, 1)
    decimated = masked_series(residual, rows, data, 0)[::stride]
    decimated = decimated[np.isfinite(decimated)]
    lb = acorr_ljungbox(decimated, lags=[min(20, len(decimated) // 5)])
    lags = np.unique(np.linspace(-nlags, nlags, 41).round().astype(int))
    ccf = _ccf(residual, rows, data, inputs(data), lags)
    ccf.index = ccf.index * dt
    freq, psd = _spectrum(masked_series(residual, rows, data, 1), dt)
    return Diagnostics(
        lags_s=np.arange(nlags + 1) * dt,
        acf=acf,
        acf_bound=2.576 / np.sqrt(rows.sum()),
        tau_int=integrated_time(acf),
        ljung_box_p=float(lb["lb_pvalue"].iloc[0]),
        ljung_box_n=len(decimated),
        ccf=ccf,
        pattern=pattern_scan(residual, rows, data),
        spectrum=(freq, psd * np.float64(scale) ** 2),
        rms=scale * float(np.sqrt(np.mean(residual[rows] ** 2))),
    )


def _undiagnosed(residual, rows, data: Signals, dt: float, nlags: int) -> Diagnostics:
    """What a residual with too few finite rows (or none but zeros) gets: no test, no
    pattern (NaN), its RMS where it has one."""
    finite = residual[rows]
    lags = np.unique(np.linspace(-nlags, nlags, 41).round().astype(int))
    names = list(signals(data))
    with np.errstate(over="ignore"):
        rms = float(np.sqrt(np.mean(finite**2))) if len(finite) else float("nan")
    return Diagnostics(
        lags_s=np.arange(nlags + 1) * dt,
        acf=np.full(nlags + 1, np.nan),
        acf_bound=float("nan"),
        tau_int=float("nan"),
        ljung_box_p=float("nan"),
        ljung_box_n=0,
        ccf=pd.DataFrame(np.nan, index=lags * dt, columns=list(inputs(data))),
        pattern=pd.DataFrame({"eta2": np.full(len(names), np.nan)}, index=names),
        spectrum=(np.array([0.0]), np.array([0.0])),
        rms=rms,
    )
