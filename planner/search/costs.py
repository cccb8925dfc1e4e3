"""The arithmetic of the learned search: Eq. 1 and Eq. 4 of Bradley & Roy, and the corrections of
them that the learned planner's named parts use (pure functions, no state).

- **Eq. 1**: the expected seconds to get one success of a stream query,
  ``R_S + R_M + (1 - P_S) / P_S * R_F``: every failure costs ``R_F`` and one success in
  ``1 / P_S`` queries costs ``R_S`` and executes for ``R_M``.
- **Eq. 4**: the expected seconds for the rest of a stream plan, the sum of Eq. 1 over its
  remaining streams.

The corrections (each switched by a field of :class:`planner.search.learned.LearnedConfig`):
a dead-end chance read from a prediction below the stream's usual rate (``dead_end_prior``), and
how many failures in a row make a query a dead end (``dead_ends``).

``P_S`` is used as the model gives it, floored at :data:`P_FLOOR` only because Eq. 1 divides by
it (a clamp to [0.02, 0.98] was measured and made no difference on any domain, so it went).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

P_FLOOR = 1e-6  # the least P_S anywhere: Eq. 1 divides by it
DEAD_END_MAX = 0.95  # most chance that a query not yet made is a dead end
DEAD_END_DOUBT = 0.1  # a run of failures less likely than this under P_S means a dead end
DEAD_END_MIN = 2  # failures in a row before any node is taken for a dead end


@dataclass(frozen=True)
class StreamCost:
    """Predicted outcome and costs of one stream query (seconds)."""

    p_s: float
    r_s: float
    r_f: float
    r_m: float
    p_prior: float | None = None  # the stream's success rate over all its training queries

    @property
    def expected(self) -> float:
        """Eq. 1 (:func:`expected`)."""
        return expected(self)

    @property
    def dead_end(self) -> float:
        """:func:`dead_end_chance` of this prediction."""
        return dead_end_chance(self)


def expected(cost: StreamCost) -> float:
    """Eq. 1: expected seconds to get one success, execution included."""
    p = min(max(cost.p_s, P_FLOOR), 1.0)
    return cost.r_s + cost.r_m + (1.0 - p) / p * cost.r_f


def remaining_cost(costs: Sequence[StreamCost]) -> float:
    """Eq. 4: expected seconds for the rest of a stream plan."""
    return sum(expected(c) for c in costs)


def dead_end_chance(cost: StreamCost) -> float:
    """Chance that the query fails whatever is retried here: the part of the predicted failure
    beyond the stream's usual rate (``p_prior``), which comes from this query's inputs and scene
    (a region already crowded, a pose out of reach) rather than from chance; 0 without a prior
    rate, at most :data:`DEAD_END_MAX`."""
    if cost.p_prior is None or cost.p_prior <= 0.0:
        return 0.0
    p = min(max(cost.p_s, P_FLOOR), 1.0)
    return min(max(1.0 - p / cost.p_prior, 0.0), DEAD_END_MAX)


def with_dead_ends(cost: float, feasible: float) -> float:
    """Eq. 4 when the rest of the plan is feasible from here with chance ``feasible`` (the
    product of 1 - dead-end chance over its streams): a dead end means choosing again here and
    paying for the rest again, so the expected cost is ``cost / feasible`` (Eq. 1 one level
    up)."""
    return cost / max(feasible, 1.0 - DEAD_END_MAX)


def dead_after(
    p_s: float,
    *,
    p_prior: float | None = None,
    doubt: float = DEAD_END_DOUBT,
) -> int:
    """Failures in a row after which a query predicted to succeed with ``p_s`` is taken for a
    dead end, never fewer than :data:`DEAD_END_MIN`. Whichever comes first:

    - the run of failures is less likely than ``doubt`` under the prediction: the least n with
      (1 - p_s)^n < ``doubt``. The models are over-confident where success is chance (a
      placement predicted almost certain fails when its draw lands where a block already
      stands), so one failure is never enough;
    - with ``p_prior`` (the stream's usual rate), the model foresaw the dead end and the
      failures confirm it: a prediction below the usual rate is read as a dead end with chance
      :func:`dead_end_chance` and otherwise as the usual rate; the least n after which the
      query is still feasible with chance below ``doubt``.
    """
    p = min(max(p_s, P_FLOOR), 1.0)
    if p >= 1.0:
        return DEAD_END_MIN
    n = max(DEAD_END_MIN, math.ceil(math.log(doubt) / math.log(1.0 - p)))
    if p_prior is None:
        return n
    dead = dead_end_chance(StreamCost(p_s, 0.0, 0.0, 0.0, p_prior=p_prior))
    if dead <= 0.0:
        return n
    miss = 1.0 - min(max(p_prior, P_FLOOR), 1.0)  # a failure, when the query is feasible
    # Feasible after k failures: (1 - dead) miss^k / (dead + (1 - dead) miss^k) < doubt, that is
    # miss^k < doubt dead / ((1 - doubt) (1 - dead)): the least such k, in closed form.
    bound = doubt * dead / ((1.0 - doubt) * (1.0 - dead))
    if miss <= 0.0 or bound >= 1.0:
        return DEAD_END_MIN
    k = math.floor(math.log(bound) / math.log(miss)) + 1
    return min(max(k, DEAD_END_MIN), n)
