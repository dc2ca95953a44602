"""The strict scenario section (no unknown keys, no coercion) and its constrained number types."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

__all__ = [
    "NonNegativeFloat",
    "NonNegativePair",
    "Pair",
    "PositiveFloat",
    "PositiveInt",
    "Section",
    "Vector3",
]

PositiveFloat = Annotated[float, Field(gt=0)]
NonNegativeFloat = Annotated[float, Field(ge=0)]
PositiveInt = Annotated[int, Field(gt=0)]
Pair = Annotated[list[float], Field(min_length=2, max_length=2)]
NonNegativePair = Annotated[list[NonNegativeFloat], Field(min_length=2, max_length=2)]
Vector3 = Annotated[list[float], Field(min_length=3, max_length=3)]


class Section(BaseModel):
    """Strict section: no unknown keys, no string-to-number coercion (ints pass as floats)."""

    model_config = ConfigDict(strict=True, extra="forbid", frozen=True)
