"""A data-driven hint for structure no candidate explains: a sparse regression (pysindy's STLSQ)
of the residual on a generic library of the signals. It names terms, not physics."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hmid.loop.data import LoopData
from hmid.loop.diagnostics import signals

MAX_TERMS = 6


@dataclass(frozen=True)
class Hint:
    terms: pd.DataFrame  # term, coefficient (on standardised signals), held-out share
    heldout_r2: float  # share of the held-out residual variance the sparse fit explains


def library(data: LoopData) -> pd.DataFrame:
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
    s = np.sign(raw["v"])
    for key in list(feats):
        if key != "t":
            feats[f"sign(v)·{key}" if key != "1" else "sign(v)"] = s * feats[key]
    return pd.DataFrame(feats)


def sparse_hint(residual: np.ndarray, data: LoopData) -> Hint:
    """STLSQ over a threshold grid; the sparsest fit (at most MAX_TERMS terms) with the best
    held-out share of residual variance."""
    from pysindy.optimizers import STLSQ

    X = library(data)
    train, held = data.train, data.validation
    r_held = residual[held]
    total = float(((r_held - r_held.mean()) ** 2).sum())
    best = None
    for threshold in np.geomspace(1e-3, 1.0, 25) * np.std(residual[train]):
        opt = STLSQ(threshold=threshold, alpha=1e-6, max_iter=50)
        with warnings.catch_warnings():  # a threshold that removes every term is part of the scan
            warnings.filterwarnings("ignore", "Sparsity parameter is too big", UserWarning)
            opt.fit(X.to_numpy()[train], residual[train].reshape(-1, 1))
        coef = np.asarray(opt.coef_).ravel()
        if 0 < np.count_nonzero(coef) <= MAX_TERMS:
            r2 = 1.0 - float(((r_held - X.to_numpy()[held] @ coef) ** 2).sum()) / total
            if best is None or r2 > best[0]:
                best = (r2, coef)
    if best is None:
        return Hint(pd.DataFrame(columns=["term", "coefficient"]), 0.0)
    r2, coef = best
    used = np.flatnonzero(coef)
    order = used[np.argsort(-np.abs(coef[used]))]
    terms = pd.DataFrame({"term": X.columns[order], "coefficient [N]": coef[order]})
    return Hint(terms.reset_index(drop=True), float(r2))
