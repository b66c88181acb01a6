"""The polynomial regression family of thesis Ch. 4: F_m as a polynomial in x, v (and P)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from hmid.families.base import FamilySpec, FitData, Fitted

THESIS_VARIANTS = ("quadratic_xv", "cubic_xv", "quadratic_xvP", "cubic_xvP")


class PolynomialSpec(FamilySpec):
    """``variants``: named term sets (the thesis's four by default), fitted by OLS."""

    family: Literal["polynomial"] = "polynomial"
    variants: Annotated[
        tuple[Literal["quadratic_xv", "cubic_xv", "quadratic_xvP", "cubic_xvP"], ...],
        Field(min_length=1),
    ] = THESIS_VARIANTS
    confidence: Annotated[float, Field(gt=0.5, lt=1)] = 0.95
    scale: bool = True
    # "hac": Newey-West errors. Not the default: with slow periodic regressors and persistent
    # residuals they were measured no closer to nominal coverage than OLS (and sometimes
    # narrower); OLS intervals carry a Durbin-Watson warning instead.
    errors: Literal["ols", "hac"] = "ols"

    def fit(self, train: FitData) -> list[Fitted]:
        from hmid.models.polynomial import PolynomialModel

        fitted = []
        for variant in self.variants:
            model = PolynomialModel(
                terms=variant, confidence=self.confidence, scale=self.scale, errors=self.errors
            )
            model.fit(train.X, train.y)
            fitted.append(
                Fitted(
                    name=f"poly:{variant}",
                    family=self.family,
                    model=model,
                    kind="one-step",
                    fit_summary=model.summary_.to_dict(),
                    coefficients=model.coefficient_table(),
                    equation=model.equation(),
                    notes=tuple(model.summary_.warnings),
                )
            )
        return fitted
