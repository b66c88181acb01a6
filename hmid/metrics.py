"""Error metrics for force models on held-out data (thesis Ch. 5 figures, plus R², NRMSE)."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np


@dataclass(frozen=True)
class Scores:
    """Errors of a prediction against measurements; ``kind`` says one-step or free-run."""

    kind: str
    n: int
    r2: float
    rmse: float
    max_abs_error: float
    error_variance: float
    nrmse_fit_pct: float  # 100 (1 - ||y - y_hat|| / ||y - mean(y)||), as in system identification

    def to_dict(self) -> dict:
        return asdict(self)


def score(y: np.ndarray, y_hat: np.ndarray, kind: str = "one-step") -> Scores:
    """Scores of ``y_hat`` against ``y`` (same length, finite)."""
    y, y_hat = np.asarray(y, dtype=float), np.asarray(y_hat, dtype=float)
    if y.shape != y_hat.shape or y.ndim != 1 or len(y) < 2:
        raise ValueError(f"need two 1-d arrays of equal length >= 2, got {y.shape}, {y_hat.shape}")
    error = y - y_hat
    spread = y - y.mean()
    ss_res, ss_tot = float(error @ error), float(spread @ spread)
    return Scores(
        kind=kind,
        n=len(y),
        r2=1.0 - ss_res / ss_tot if ss_tot > 0 else float("nan"),
        rmse=float(np.sqrt(ss_res / len(y))),
        max_abs_error=float(np.max(np.abs(error))),
        error_variance=float(np.var(error, ddof=1)),
        nrmse_fit_pct=100.0 * (1.0 - np.sqrt(ss_res / ss_tot)) if ss_tot > 0 else float("nan"),
    )
