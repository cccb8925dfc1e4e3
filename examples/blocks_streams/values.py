"""The blocksworld's one value type: a carry (blocks and slots are names)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from planner.values import ValueType, numbers

from .primitives import Carry


def _decode(d: Mapping[str, Any]) -> Carry:
    x1, y1, x2, y2 = numbers(d["ends"], 4, "ends")
    return Carry(str(d["block"]), (x1, y1), (x2, y2), float(d["travel_y"]), float(d["speed"]))


CARRY = ValueType(
    name="carry",
    python_type=Carry,
    encode=lambda c: {
        "block": c.block,
        "ends": [*c.start, *c.end],
        "travel_y": c.travel_y,
        "speed": c.speed,
    },
    decode=_decode,
    features=lambda d: [*numbers(d["ends"], 4, "ends"), _decode(d).seconds],
    width=5,
    label=lambda d: f"carry {d['block']} {_decode(d).seconds:.1f} s",
)

VALUE_TYPES = (CARRY,)
