"""The values the tabletop's samplers produce, and how each is stored and featurized.

Every kind of value a sampler returns needs a :class:`~planner.values.ValueType`: a name (the
``"type"`` of its JSON), the Python class, ``encode`` (the JSON fields of a value), ``decode``
(a value from those fields), ``features`` (``width`` numbers a learned model reads, computed
from the JSON) and, optionally, ``label`` (one line for the dashboard's inspector). Strings,
numbers and tuples of numbers need none: they are built in.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from planner.values import ValueType, numbers


@dataclass(frozen=True)
class Pose2D:
    """Where a block's centre is on the table, metres."""

    x: float
    y: float


@dataclass(frozen=True)
class Grasp2D:
    """Where the gripper holds a block: its offset from the block's centre along x, metres."""

    dx: float


@dataclass(frozen=True)
class Conf2D:
    """Where the gripper is over the table, metres."""

    x: float
    y: float


@dataclass(frozen=True)
class Path2D:
    """A straight gripper path and how long it takes; ``seconds`` is what the planner counts as
    execution time (any value with a ``seconds`` property is)."""

    start: Conf2D
    end: Conf2D
    duration: float

    @property
    def seconds(self) -> float:
        return self.duration

    @property
    def length(self) -> float:
        return math.dist((self.start.x, self.start.y), (self.end.x, self.end.y))


def _xy(d: Mapping[str, Any]) -> tuple[float, float]:
    x, y = numbers(d["xy"], 2, "xy")
    return x, y


POSE = ValueType(
    name="pose",
    python_type=Pose2D,
    encode=lambda p: {"xy": [p.x, p.y]},
    decode=lambda d: Pose2D(*_xy(d)),
    features=lambda d: list(_xy(d)),
    width=2,
    label=lambda d: "pose ({:.3f}, {:.3f})".format(*_xy(d)),
)
GRASP = ValueType(
    name="grasp",
    python_type=Grasp2D,
    encode=lambda g: {"dx": g.dx},
    decode=lambda d: Grasp2D(float(d["dx"])),
    features=lambda d: [float(d["dx"])],
    width=1,
    label=lambda d: f"grasp dx {float(d['dx']):+.3f}",
)
CONF = ValueType(
    name="conf",
    python_type=Conf2D,
    encode=lambda q: {"xy": [q.x, q.y]},
    decode=lambda d: Conf2D(*_xy(d)),
    features=lambda d: list(_xy(d)),
    width=2,
    label=lambda d: "gripper at ({:.3f}, {:.3f})".format(*_xy(d)),
)


def _decode_path(d: Mapping[str, Any]) -> Path2D:
    sx, sy, ex, ey = numbers(d["ends"], 4, "ends")
    return Path2D(Conf2D(sx, sy), Conf2D(ex, ey), float(d["seconds"]))


PATH = ValueType(
    name="path",
    python_type=Path2D,
    encode=lambda t: {
        "ends": [t.start.x, t.start.y, t.end.x, t.end.y],
        "seconds": t.duration,
    },
    decode=_decode_path,
    features=lambda d: [*numbers(d["ends"], 4, "ends"), float(d["seconds"])],
    width=5,
    label=lambda d: f"path {float(d['seconds']):.1f} s",
)

VALUE_TYPES = (POSE, GRASP, CONF, PATH)
