"""The strict base of every file table (a scenario's tables, a geometry's format keys)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class Strict(BaseModel):
    """Base of scenario tables: unknown keys are refused, values are frozen, and ``inf``
    and ``nan`` are no number."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
