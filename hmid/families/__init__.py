"""Model families the pipeline can fit (each registers itself; see base.py)."""

from hmid.families import balance, polynomial, sindy, sls  # noqa: F401  (register the families)
from hmid.families.base import (
    FAMILIES,
    Extras,
    FamilySpec,
    FigureSpec,
    FitContext,
    FitData,
    FitSummary,
    Fitted,
    FittedModel,
    FittedTerms,
    make_family,
)

__all__ = [
    "FAMILIES",
    "Extras",
    "FamilySpec",
    "FigureSpec",
    "FitContext",
    "FitData",
    "FitSummary",
    "Fitted",
    "FittedModel",
    "FittedTerms",
    "make_family",
]
