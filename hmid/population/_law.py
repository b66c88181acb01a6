"""The scaling law: which specifications set which parameter, with the exponents physics expects.

Each parameter p of the SLS muscle follows a power law of the build (see
:mod:`hmid.simulate.specs` for the physics):

    log p = c_p + e_p,bore log(bore area) + e_p,wall log(wall area) + e_p,len log(length)
            + m_p log(modulus)

with the modulus's exponent m_p known (the stiffnesses are proportional to it; a population of
one latex carries it in c_p) and the others estimated, their prior centred on the expected
values below. The features are centred on the population's means, so c_p is the log of a typical
muscle's parameter.
"""

from __future__ import annotations

import math

import numpy as np

from hmid.simulate.specs import MuscleSpec

#: The SLS parameters the population models, in the model file's order (A_eff, F0, k1, k3, k2)
#: then tau.
PARAMETERS = ("A_eff", "F0", "k1", "k3", "k2", "tau")
UNITS = {"A_eff": "m²", "F0": "N", "k1": "N/m", "k3": "N/m³", "k2": "N/m", "tau": "s"}

#: The specifications' features, by name: the bore's area, the wall's cross-section, the length.
FEATURES = ("bore_area", "wall_area", "length")

#: Expected exponents of each feature (thesis §8.1; hmid.simulate.specs): A_eff ~ bore area,
#: F0 = prestress x wall area, k1 ~ k2 ~ E A_w / L, k3 ~ E A_w / L^3, tau a material constant.
EXPECTED = {
    "A_eff": (1.0, 0.0, 0.0),
    "F0": (0.0, 1.0, 0.0),
    "k1": (0.0, 1.0, -1.0),
    "k3": (0.0, 1.0, -3.0),
    "k2": (0.0, 1.0, -1.0),
    "tau": (0.0, 0.0, 0.0),
}

#: The modulus's exponent, known: the stiffnesses scale with E.
MODULUS = {"A_eff": 0.0, "F0": 0.0, "k1": 1.0, "k3": 1.0, "k2": 1.0, "tau": 0.0}

#: Parameters whose muscle-to-muscle scatter is additive (N), not a log-normal factor: a preload
#: can be near zero (the simulator's Scatter.F0 is additive too).
ADDITIVE = frozenset({"F0"})


def spec_features(spec: MuscleSpec) -> np.ndarray:
    """log(bore area), log(wall area), log(length) of one build."""
    return np.array([math.log(spec.bore_area), math.log(spec.wall_area), math.log(spec.length)])


def feature_matrix(specs) -> np.ndarray:
    """One row of :func:`features` per build."""
    return np.array([spec_features(s) for s in specs])


def offsets(spec: MuscleSpec) -> np.ndarray:
    """The known part of each parameter's log: its modulus exponent times log(modulus)."""
    return np.array([MODULUS[p] * math.log(spec.modulus) for p in PARAMETERS])


def expected_matrix() -> np.ndarray:
    """The expected exponents, parameters x features."""
    return np.array([EXPECTED[p] for p in PARAMETERS])
