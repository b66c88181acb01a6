"""Model families of the muscle force F_m = f(x, v, P), all following one fit contract.

Each family subclasses :class:`ForceModel` (scikit-learn style: ``fit(X, y)`` returns the model,
fitted attributes end in ``_``, :class:`NotFittedError` before ``fit``) and summarises its fit as
a :class:`FitStatistics` with :class:`Coefficient` values in physical units.
"""

from hmid.balance.monomial import Monomial
from hmid.models.base import (
    Coefficient,
    FitStatistics,
    ForceModel,
    NotFittedError,
    fit_statistics,
)
from hmid.models.polynomial import (
    CONDITION_LIMIT,
    DURBIN_WATSON_LIMIT,
    PolynomialModel,
    fit_table,
)
from hmid.models.terms import (
    VARIANTS,
    coefficient_unit,
    polynomial_terms,
    variant_terms,
)

__all__ = [
    "CONDITION_LIMIT",
    "DURBIN_WATSON_LIMIT",
    "VARIANTS",
    "Coefficient",
    "FitStatistics",
    "ForceModel",
    "Monomial",
    "NotFittedError",
    "PolynomialModel",
    "coefficient_unit",
    "fit_statistics",
    "fit_table",
    "polynomial_terms",
    "variant_terms",
]
