"""Least-squares covariance on a short record whose errors are AR(1) plus white noise.

A sensor's noise filtered in time (AR(1), correlation phi) and its quantisation (white) add up;
on a record only a few correlation times long (a 0.3 s free fall under noise correlated for
20 ms), the residual's own autocovariance is both truncated by any lag window and biased low by
the fit, which has taken the errors' slow part into its smooth columns. Here the errors'
covariance ``s_a phi^|i-j| + s_w I`` is fitted instead, by matching the residual's sums of lag
products at lags 0, 1 and 2 to their expectations *through the fit's projection* ``M = I - H``
(E[r r'] = M Sigma M), and the least-squares covariance is the sandwich with that Sigma.
Records of one sensor (the free falls of a rig) share one model, fitted on their summed lag
sums: a single 0.18 s record reads phi 0.97 too low as often as not, three of them much less
often. Everything is O(n p): products with ``phi^|i-j|`` are two first-order recursions.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

#: The range phi is searched in (the end whose lag-2 gap is smaller where no root lies inside)
PHI_LOW, PHI_HIGH = 0.01, 0.999


def _times_ar(z: np.ndarray, phi: float) -> np.ndarray:
    """``S z`` for ``S[i, j] = phi^|i - j|`` (columns of ``z``), by a forward and a backward
    first-order recursion."""
    from scipy.signal import lfilter

    forward = lfilter([1.0], [1.0, -phi], z, axis=0)
    backward = lfilter([1.0], [1.0, -phi], z[::-1], axis=0)[::-1]
    return forward + backward - z


def _shifted(z: np.ndarray, k: int) -> np.ndarray:
    """Row t holds z[t + k] (zero past the end)."""
    out = np.zeros_like(z)
    out[: len(z) - k] = z[k:]
    return out


def _expected(q: np.ndarray, phi: float | None) -> np.ndarray:
    """E[sum_t r_t r_{t+k}] for k = 0, 1, 2 when the errors' covariance is phi^|i-j| (None: the
    identity) and r = M e, with ``q`` an orthonormal basis of the fit's columns."""
    n = len(q)
    sq = q if phi is None else _times_ar(q, phi)  # S Q
    qsq = q.T @ sq
    out = np.empty(3)
    for k in range(3):
        if phi is None:  # tr(A_k S): the k-th diagonal of S
            diagonal = float(n) if k == 0 else 0.0
        else:
            diagonal = (n - k) * phi**k
        ahead, behind = _shifted(q, k), np.zeros_like(q)
        behind[k:] = q[: n - k]
        qjq = q.T @ ahead
        out[k] = (diagonal - np.sum(sq * ahead) - np.sum(behind * sq)
                  + np.sum(qsq * qjq.T))  # fmt: skip
    return out


@dataclass(frozen=True)
class ARWhite:
    """Errors of covariance ``s_a phi^|i-j| + s_w I`` on each record, fitted on ``n_rows``."""

    phi: float
    s_a: float
    s_w: float
    n_rows: int

    @property
    def tau_int(self) -> float:
        """The errors' integrated correlation time, samples: 1 + 2 s_a / (s_a + s_w) phi /
        (1 - phi)."""
        share = self.s_a / (self.s_a + self.s_w) if self.s_a + self.s_w > 0 else 0.0
        return float(1 + 2 * share * self.phi / (1 - self.phi))

    @property
    def dof(self) -> float:
        """Degrees of freedom of the variances, n (1 - phi) / (1 + phi) over the rows fitted."""
        return self.n_rows * (1 - self.phi) / (1 + self.phi)

    def covariance(self, design: np.ndarray) -> np.ndarray:
        """Covariance of the least-squares coefficients on ``design`` under these errors."""
        meat = self.s_a * (design.T @ _times_ar(design, self.phi)) + self.s_w * (design.T @ design)
        bread = np.linalg.pinv(design.T @ design)
        return bread @ meat @ bread


def fit_ar_white(records: Sequence[tuple[np.ndarray, np.ndarray]]) -> ARWhite | None:
    """AR(1) + white errors shared by ``records`` (each ``(design, residual)`` of its own
    least-squares fit: the falls of one sensor), matched through each fit's projection on the
    records' summed lag products at lags 0, 1 and 2 (one record: its own). None where the summed
    lag-1 autocorrelation lies below white noise's one-sided 97.5 % bound 1.96 / sqrt(n), or the
    lag-2 sum is not positive: phi, taken from the lags' ratio, would then be noise, and a
    spurious phi near 1 widens a white residual's intervals several times."""
    from scipy.optimize import brentq

    n = sum(len(r) for _, r in records)
    p = sum(d.shape[1] for d, _ in records)
    # start at zeros, not 0: an array whatever the records (0.0 + x is x exactly)
    found = sum(
        (np.array([r[k:] @ r[: len(r) - k] for k in range(3)]) for _, r in records), np.zeros(3)
    )
    if n < 4 * p or found[1] <= 1.96 / np.sqrt(n) * found[0] or found[2] <= 0:
        return None
    bases = [np.linalg.qr(d)[0] for d, _ in records]
    white = sum((_expected(q, None) for q in bases), np.zeros(3))

    def scales(phi: float) -> tuple[np.ndarray, float]:
        """(s_a, s_w) matching lags 0 and 1, and the gap left at lag 2."""
        ar = sum((_expected(q, phi) for q in bases), np.zeros(3))
        s = np.linalg.solve([[ar[0], white[0]], [ar[1], white[1]]], found[:2])
        return s, float(ar[2] * s[0] + white[2] * s[1] - found[2])

    low, high = scales(PHI_LOW)[1], scales(PHI_HIGH)[1]
    if low * high > 0:  # no root: the end whose lag-2 gap is smaller
        phi = PHI_HIGH if abs(high) < abs(low) else PHI_LOW
    else:
        phi = float(brentq(lambda f: scales(f)[1], PHI_LOW, PHI_HIGH, xtol=1e-6))
    s_a, s_w = np.maximum(scales(phi)[0], 0.0)
    return ARWhite(phi, float(s_a), float(s_w), n)
