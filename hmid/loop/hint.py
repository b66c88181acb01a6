"""Data-driven hints for a residual pattern no candidate explains. They name terms, not physics:

* a sparse regression (orthogonal matching pursuit) of the residual on a generic library of the
  signals;
* a periodicity check (Lomb-Scargle, scipy) of the residual, and of residual x sign(v), against
  the signal it depends on most: oscillation along a coordinate is a fingerprint that no
  polynomial library shows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from hmid.balance import Signals
from hmid.loop.diagnostics import signals, unit

MAX_TERMS = 6


@dataclass(frozen=True)
class Hint:
    terms: pd.DataFrame  # term, coefficient (on standardised signals), held-out share
    heldout_r2: float  # share of the held-out residual variance the sparse fit explains
    periodic: str = ""  # a dominant period of the residual along its strongest signal


def features(data: Signals) -> pd.DataFrame:
    """Generic features on standardised signals: monomials to degree 2, each also times
    sign(v), and t; nothing tied to a candidate effect."""
    raw = signals(data)
    z = {k: (v - v.mean()) / (v.std() or 1.0) for k, v in raw.items() if k != "t"}
    feats: dict[str, np.ndarray] = {"1": np.ones(len(data)), "t": raw["t"] / raw["t"].max()}
    names = list(z)
    for i, a in enumerate(names):
        feats[a] = z[a]
        for b in names[i:]:
            feats[f"{a}·{b}" if a != b else f"{a}²"] = z[a] * z[b]
    s = np.sign(raw["v"]) if "v" in raw else np.ones(len(data))
    for key in list(feats):
        if key != "t":
            feats[f"sign(v)·{key}" if key != "1" else "sign(v)"] = s * feats[key]
    return pd.DataFrame(feats)


def sparse_hint(residual: np.ndarray, data: Signals, signal: str | None = None) -> Hint:
    """Orthogonal matching pursuit (scikit-learn) with 1..MAX_TERMS terms, fitted on the training
    rows; the size with the best held-out share of residual variance is kept. (Thresholded least
    squares such as STLSQ jumps from many terms to none on this collinear library.) With
    ``signal``, also its periodicity check."""
    from sklearn.linear_model import OrthogonalMatchingPursuit

    X = features(data)
    values = X.to_numpy()
    train, held = data.train, data.validation
    r_held = residual[held]
    total = float(((r_held - r_held.mean()) ** 2).sum())
    best: tuple[float, np.ndarray] | None = None
    for k in range(1, MAX_TERMS + 1):
        fit = OrthogonalMatchingPursuit(n_nonzero_coefs=k, fit_intercept=False)
        fit.fit(values[train], residual[train])
        r2 = 1.0 - float(((r_held - values[held] @ fit.coef_) ** 2).sum()) / total
        if best is None or r2 > best[0] + 0.01:  # a term must earn 1 % of held-out variance
            best = (r2, fit.coef_.copy())
    periodic = periodicity(residual, data, signal) if signal else ""
    assert best is not None  # the first size always sets it
    r2, coef = best
    used = np.flatnonzero(coef)
    order = used[np.argsort(-np.abs(coef[used]))]
    terms = pd.DataFrame({"term": X.columns[order], "coefficient": coef[order]})
    return Hint(terms.reset_index(drop=True), float(r2), periodic)


#: Readable units for periods along a signal in these SI units.
READABLE = {"m": ("mm", 1e3), "m/s": ("mm/s", 1e3), "Pa": ("kPa", 1e-3), "Pa/s": ("kPa/s", 1e-3)}
MIN_SHARE = 0.25  # a period is reported when one sinusoid explains this share of the residual


def periodicity(residual: np.ndarray, data: Signals, signal: str, points: int = 6000) -> str:
    """The dominant period of the residual (or of residual x sign(v)) along ``signal``, if one
    sinusoid in it explains at least MIN_SHARE of the variance; "" otherwise."""
    from scipy.signal import lombscargle

    rows = np.flatnonzero(data.train)
    rows = rows[np.linspace(0, len(rows) - 1, min(points, len(rows))).astype(int)]
    s = signals(data)[signal][rows]
    span = float(np.ptp(s))
    spacing = float(np.median(np.diff(np.sort(s)))) or span / len(s)
    if span <= 0:
        return ""
    freqs = 2 * np.pi * np.geomspace(2 / span, 1 / (50 * spacing), 800)
    found = []
    for label, r in (("residual", residual[rows]), ("residual x sign(v)",
                      residual[rows] * np.sign(data["v"][rows]))):  # fmt: skip
        r = r - r.mean()
        power = lombscargle(s, r, freqs, normalize=True)
        k = int(np.argmax(power))
        found.append((float(power[k]), label, 2 * np.pi / freqs[k]))
    share, label, period = max(found)
    gap = float(np.max(np.diff(np.sort(s))))
    if share < MIN_SHARE or gap > period / 4:
        # a period is claimed only where samples cover it: between clusters of a signal (tests
        # at a few pressures) any sinusoid through the clusters fits
        return ""
    si = unit(data, signal)
    name, factor = READABLE.get(si, (si, 1.0))
    return (
        f"{label} oscillates along {signal} with period {period * factor:.3g} {name} "
        f"(one sinusoid explains {100 * share:.0f} % of its variance)"
    )
