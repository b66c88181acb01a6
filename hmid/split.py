"""Train/validation split of dynamic logs: a time block at the end of each log, or whole logs.

Held-out data is never used for fitting; a time-block split keeps the validation block contiguous
(no interleaving), so autocorrelated samples do not leak between the sets.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from hmid.errors import ConfigError


class SplitSpec(BaseModel):
    """``time_block``: the last ``validation_fraction`` of every log; ``logs``: whole named logs."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    kind: Literal["time_block", "logs"] = "time_block"
    validation_fraction: Annotated[float, Field(gt=0, lt=1)] = 0.3
    validation_logs: tuple[str, ...] = ()

    @model_validator(mode="after")
    def _consistent(self) -> SplitSpec:
        if self.kind == "logs" and not self.validation_logs:
            raise ValueError("kind 'logs' needs validation_logs (names of the held-out logs)")
        if self.kind == "time_block" and self.validation_logs:
            raise ValueError("validation_logs is only used with kind 'logs'")
        return self


def validation_masks(lengths: Mapping[str, int], spec: SplitSpec) -> dict[str, np.ndarray]:
    """Per log, a boolean mask that is True on held-out (validation) samples."""
    if spec.kind == "logs":
        unknown = sorted(set(spec.validation_logs) - set(lengths))
        if unknown:
            raise ConfigError(
                f"split.validation_logs names {unknown}, which are not dynamic logs of this "
                f"experiment; known: {sorted(lengths)}"
            )
        if set(spec.validation_logs) == set(lengths):
            raise ConfigError("split.validation_logs holds every dynamic log: nothing left to fit")
        return {name: np.full(n, name in spec.validation_logs) for name, n in lengths.items()}
    masks = {}
    for name, n in lengths.items():
        start = round(n * (1.0 - spec.validation_fraction))
        mask = np.zeros(n, dtype=bool)
        mask[start:] = True
        masks[name] = mask
    return masks
