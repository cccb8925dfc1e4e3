"""What a manipulation domain's feature hook shares: numbers read from a recorded context, and
the types of a row's parts."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.values import JSON, FeatureError

FloatArray = npt.NDArray[np.float32]
Inputs = Sequence[JSON | None]  # a query's inputs, encoded (None: not bound yet)
Slots = Sequence[tuple[str, int, int]]  # each input slot's kind, offset and width in a row


def feature_numbers(value: Any, n: int, where: str) -> list[float]:
    """``n`` numbers read from a recorded context (a FeatureError says what is wrong)."""
    if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != n:
        raise FeatureError(f"{where}: expected {n} numbers, got {value!r}")
    try:
        return [float(v) for v in value]
    except (TypeError, ValueError) as exc:
        raise FeatureError(f"{where}: expected {n} numbers, got {value!r}") from exc
