"""The pick-and-place's values for the store, the page and the learned models. Poses and
configurations are numpy arrays and grasps numbers (built-in kinds: nothing to declare); only
the trajectory needs a value type."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from planner.values import ValueType, numbers

from .primitives import Trajectory


def _decode(d: Mapping[str, Any]) -> Trajectory:
    x1, y1, x2, y2 = numbers(d["ends"], 4, "ends")
    return Trajectory((x1, y1), (x2, y2), float(d["speed"]))


TRAJECTORY = ValueType(
    name="trajectory",
    python_type=Trajectory,
    encode=lambda t: {"ends": [*t.start, *t.end], "speed": t.speed},
    decode=_decode,
    features=lambda d: [*numbers(d["ends"], 4, "ends"), _decode(d).seconds],
    width=5,
    label=lambda d: f"trajectory {_decode(d).seconds:.1f} s",
)

VALUE_TYPES = (TRAJECTORY,)
