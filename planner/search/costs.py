"""The arithmetic of the learned search: Eq. 1 and Eq. 4 of Bradley & Roy, and the corrections of
them that the learned planner's named parts use (pure functions, no state).

- **Eq. 1**: the expected seconds to get one success of a stream query,
  ``R_S + R_M + (1 - P_S) / P_S * R_F``: every failure costs ``R_F`` and one success in
  ``1 / P_S`` queries costs ``R_S`` and executes for ``R_M``.
- **Eq. 4**: the expected seconds for the rest of a stream plan, the sum of Eq. 1 over its
  remaining streams.

The learned planner's ``dead_ends`` part (a field of
:class:`planner.search.learned.LearnedConfig`) adds two things: how many failures in a row make a
query a dead end (:func:`dead_after`), and the price of a dead end (:func:`dead_end_cost`).

``P_S`` is used as the model gives it, floored at :data:`P_FLOOR` only because Eq. 1 divides by
it (a clamp to [0.02, 0.98] was measured and made no difference on any domain, so it went).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

P_FLOOR = 1e-6  # the least P_S anywhere: Eq. 1 divides by it
DEAD_END_MAX = 0.95  # a dead end is taken to fail this often whatever is chosen below it
DEAD_END_DOUBT = 0.1  # a run of failures less likely than this under P_S means a dead end
DEAD_END_MIN = 2  # failures in a row before any node is taken for a dead end


@dataclass(frozen=True)
class StreamCost:
    """Predicted outcome and costs of one stream query (seconds)."""

    p_s: float
    r_s: float
    r_f: float
    r_m: float

    @functools.cached_property
    def expected(self) -> float:
        """Eq. 1 (:func:`expected`), computed once: a prediction is summed into the Q of every
        node whose rows it stays one of."""
        return expected(self)


def expected(cost: StreamCost) -> float:
    """Eq. 1: expected seconds to get one success, execution included."""
    p = min(max(cost.p_s, P_FLOOR), 1.0)
    return cost.r_s + cost.r_m + (1.0 - p) / p * cost.r_f


def remaining_cost(costs: Sequence[StreamCost]) -> float:
    """Eq. 4: expected seconds for the rest of a stream plan."""
    return sum(c.expected for c in costs)


def dead_end_cost(q: float) -> float:
    """What going on below a dead end is taken to cost: its ``Q`` paid again each time a
    continuation fails, taken to fail a :data:`DEAD_END_MAX` share of the time, so
    ``Q / (1 - DEAD_END_MAX)`` (Eq. 1 one level up)."""
    return q / (1.0 - DEAD_END_MAX)


def dead_after(p_s: float, *, doubt: float = DEAD_END_DOUBT) -> int:
    """Failures in a row after which a query predicted to succeed with ``p_s`` is taken for a
    dead end: the least n with (1 - p_s)^n < ``doubt`` (the run of failures is then less likely
    than ``doubt`` under the prediction), never fewer than :data:`DEAD_END_MIN`: the models are
    over-confident where success is chance (a placement predicted almost certain fails when its
    draw lands where a block already stands), so one failure is never enough."""
    p = min(max(p_s, P_FLOOR), 1.0)
    if p >= 1.0:
        return DEAD_END_MIN
    return max(DEAD_END_MIN, math.ceil(math.log(doubt) / math.log(1.0 - p)))
