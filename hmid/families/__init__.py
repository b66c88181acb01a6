"""Model families the pipeline can fit (each registers itself; see base.py)."""

from hmid.families import polynomial, sindy, sls  # noqa: F401  (register the families)
from hmid.families.base import FAMILIES, FamilySpec, FitContext, FitData, Fitted, make_family

__all__ = ["FAMILIES", "FamilySpec", "FitContext", "FitData", "Fitted", "make_family"]
