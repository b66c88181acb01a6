"""Model families the pipeline can fit (each registers itself; see base.py)."""

from hmid.families import polynomial  # noqa: F401  (registers the family)
from hmid.families.base import FAMILIES, FamilySpec, FitContext, FitData, Fitted, make_family

__all__ = ["FAMILIES", "FamilySpec", "FitContext", "FitData", "Fitted", "make_family"]
