"""pysindy's STLSQ with columns spared from thresholding (its own module: importing pysindy
costs about a second, which a process that only reads a fitted model need not pay)."""

from __future__ import annotations

import numpy as np
import pysindy as ps


class KeepSTLSQ(ps.STLSQ):
    """pysindy's STLSQ whose thresholding spares the columns marked in ``keep`` (a boolean mask).

    pysindy's own ``sparse_ind`` option does this in principle, but in pysindy 2.1 it fails in
    the unbiasing step (an index error) whenever a column is spared.
    """

    def __init__(self, threshold=0.1, alpha=0.0, max_iter=20, keep=None):
        # the compressed problem is float64 and checked upstream: sklearn's input checks in
        # each ridge solve were a fifth of a fit
        super().__init__(
            threshold=threshold,
            alpha=alpha,
            max_iter=max_iter,
            unbias=True,
            ridge_kw={"check_input": False},
        )
        self.keep = keep

    def _sparse_coefficients(self, dim, ind_nonzero, coef, threshold):
        c, big = super()._sparse_coefficients(dim, ind_nonzero, coef, threshold)
        if self.keep is not None and np.any(self.keep):
            full = np.zeros(dim)
            full[ind_nonzero] = coef
            big = big | self.keep
            c = np.where(big, full, 0.0)
        return c, big
