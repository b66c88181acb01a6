"""The user's log-probability as the sampler calls it: output checked, NaN counted as a
rejection, and any error (Ctrl-C included) held until the step ends, because emcee's wrapper would
print a parameter dump."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from hmid.models.sls._errors import SamplerError


class LogProb:
    """The user's log-probability with its output checked; NaN -> -inf (counted)."""

    def __init__(self, fn: Callable[[np.ndarray], np.ndarray], pad: np.ndarray, batch: int):
        self.fn, self.pad, self.batch, self.n_nan = fn, pad, batch, 0
        self.error: BaseException | None = None

    def reraise(self) -> None:
        """Raise what a call during emcee's step caught (emcee would print a parameter dump)."""
        if self.error is not None:
            error, self.error = self.error, None
            raise error

    def padded(self, theta: np.ndarray) -> np.ndarray:
        """Evaluate any number of rows in batches of ``batch`` (padding with ``pad``)."""
        n = len(theta)
        rows = -(-n // self.batch) * self.batch
        full = np.concatenate([theta, np.broadcast_to(self.pad, (rows - n, theta.shape[1]))])
        out = np.concatenate([self(full[i : i + self.batch]) for i in range(0, rows, self.batch)])
        self.reraise()
        return out[:n]

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        if self.error is not None:
            return np.full(len(theta), -np.inf)
        try:
            return self._call(theta)
        except BaseException as err:  # Ctrl-C lands here while JAX computes
            self.error = err
            return np.full(len(theta), -np.inf)

    def _call(self, theta: np.ndarray) -> np.ndarray:
        theta = np.asarray(theta, dtype=float)
        out = np.asarray(self.fn(theta), dtype=float)
        if out.shape != (len(theta),):
            raise SamplerError(
                f"sampler: log_prob must return shape ({len(theta)},) for theta of shape "
                f"{theta.shape}, got {out.shape}"
            )
        if np.any(np.isposinf(out)):
            bad = theta[np.argmax(np.isposinf(out))]
            raise SamplerError(f"sampler: log_prob returned +inf at theta = {bad.tolist()}")
        nan = np.isnan(out)
        self.n_nan += int(nan.sum())
        return np.where(nan, -np.inf, out)
