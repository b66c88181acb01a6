"""The polynomial regression family of thesis Ch. 4: F_m as a polynomial in x, v (and P)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

from hmid.families.base import FamilySpec, FitContext, FitData, Fitted

THESIS_VARIANTS = ("quadratic_xv", "cubic_xv", "quadratic_xvP", "cubic_xvP")


class CustomTerms(BaseModel):
    """Every monomial in ``variables`` up to total ``degree``, single variables capped by
    ``max_degree`` (e.g. ``{P: 1}``: pressure only linearly, as in the thesis)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]+$")]
    variables: tuple[Literal["x", "v", "P"], ...] = ("x", "v", "P")
    degree: Annotated[int, Field(ge=1, le=6)] = 3
    max_degree: dict[Literal["x", "v", "P"], Annotated[int, Field(ge=0, le=6)]] = {"P": 1}

    def terms(self):
        from hmid.models.terms import polynomial_terms

        return polynomial_terms(self.variables, self.degree, self.max_degree)


class PolynomialSpec(FamilySpec):
    """``variants``: named term sets (the thesis's four by default), plus ``custom`` term sets;
    every one fitted by OLS on the same training rows."""

    family: Literal["polynomial"] = "polynomial"
    variants: Annotated[
        tuple[Literal["quadratic_xv", "cubic_xv", "quadratic_xvP", "cubic_xvP"], ...],
        Field(min_length=1),
    ] = THESIS_VARIANTS
    custom: tuple[CustomTerms, ...] = ()
    confidence: Annotated[float, Field(gt=0.5, lt=1)] = 0.95
    scale: bool = True
    # "hac": Newey-West errors. Not the default: with slow periodic regressors and persistent
    # residuals they were measured no closer to nominal coverage than OLS (and sometimes
    # narrower); OLS intervals carry a Durbin-Watson warning instead.
    errors: Literal["ols", "hac"] = "ols"

    def fit(self, train: FitData, context: FitContext) -> list[Fitted]:
        from hmid.models.polynomial import PolynomialModel

        fitted = []
        term_sets = [(v, v) for v in self.variants] + [(c.name, c.terms()) for c in self.custom]
        for variant, terms in term_sets:
            model = PolynomialModel(
                terms=terms, confidence=self.confidence, scale=self.scale, errors=self.errors
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
