"""emcee moves for the SLS posterior: a corrected differential-evolution snooker update."""

import emcee
import numpy as np


class SnookerMove(emcee.moves.DESnookerMove):
    """The DE snooker update of ter Braak & Vrugt (2008), correcting emcee 3.1.6's.

    The walker x moves along the line through a walker z of another sub-ensemble by
    ``gamma * e·(z1 - z2)`` (``e`` the unit vector from z to x, z1 and z2 two more walkers) and
    is accepted with the extra factor ``(|q - z| / |x - z|) ** (D - 1)``. emcee's
    ``DESnookerMove`` divides by ``sqrt(|x - z|)`` where it means ``|x - z|`` (the step scales
    with the distance, not reversible) and uses the exponent ``(D - 1) / 2``: alone on a
    correlated 3-D Gaussian it gives standard deviations 7-10 % too small.
    """

    def get_proposal(self, s, c, random):
        n, dim = s.shape
        picks = np.stack([cj[random.randint(len(cj), size=n)] for cj in c], axis=1)
        order = np.argsort(random.rand(n, len(c)), axis=1)[:, :3, None]
        z, z1, z2 = np.moveaxis(np.take_along_axis(picks, order, axis=1), 1, 0)
        norm = np.linalg.norm(s - z, axis=1)
        e = (s - z) / np.where(norm > 0, norm, 1.0)[:, None]
        q = s + self.gammas * e * np.sum(e * (z1 - z2), axis=1, keepdims=True)
        with np.errstate(divide="ignore"):
            factor = (dim - 1) * (np.log(np.linalg.norm(q - z, axis=1)) - np.log(norm))
        return q, np.where(norm > 0, factor, -np.inf)
