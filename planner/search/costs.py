"""The arithmetic of the learned search: Eq. 1 and Eq. 4 of Bradley & Roy, and the corrections of
them that the learned planner's named parts use (pure functions, no state).

- **Eq. 1**: the expected seconds to get one success of a stream query,
  ``R_S + R_M + (1 - P_S) / P_S * R_F``: every failure costs ``R_F`` and one success in
  ``1 / P_S`` queries costs ``R_S`` and executes for ``R_M``.
- **Eq. 4**: the expected seconds for the rest of a stream plan, the sum of Eq. 1 over its
  remaining streams.

The corrections (each switched by a field of :class:`planner.search.learned.LearnedConfig`):
a dead-end chance read from a prediction below the stream's usual rate (``dead_end_prior``),
Eq. 1 after attempts already made from a node (``attempt_posterior``), and how many failures in a
row make a query a dead end (``dead_ends``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

P_FLOOR = 1e-6  # the least P_S anywhere: Eq. 1 divides by it
P_MIN = 0.02  # p_clamp: P_S is clamped here, a stream never looks hopeless ...
P_MAX = 0.98  # ... nor certain once it has failed from a node
INFEASIBLE_PRIOR = 0.3  # least chance that a binding makes its next stream impossible
INFEASIBLE_MAX = 0.95  # most chance of it, before trying (1 - P_S when the model is doubtful)
ITERATION_S = 0.05  # seconds of search (descent, predictions, events) around each query
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
        """Eq. 1, with ``P_S`` clamped at :data:`P_MIN` (:func:`expected`)."""
        return expected(self)

    @property
    def dead_end(self) -> float:
        """:func:`dead_end_chance` of this prediction."""
        return dead_end_chance(self)


def expected(cost: StreamCost, *, p_min: float = P_MIN) -> float:
    """Eq. 1: expected seconds to get one success, execution included."""
    p = min(max(cost.p_s, p_min, P_FLOOR), 1.0)
    return cost.r_s + cost.r_m + (1.0 - p) / p * cost.r_f


def remaining_cost(costs: Sequence[StreamCost], *, p_min: float = P_MIN) -> float:
    """Eq. 4: expected seconds for the rest of a stream plan."""
    return sum(expected(c, p_min=p_min) for c in costs)


def dead_end_chance(cost: StreamCost, *, p_min: float = P_MIN) -> float:
    """Chance that the query fails whatever is retried here: the part of the predicted failure
    beyond the stream's usual rate (``p_prior``), which comes from this query's inputs and scene
    (a region already crowded, a pose out of reach) rather than from chance; 0 without a prior
    rate, at most :data:`DEAD_END_MAX`."""
    if cost.p_prior is None or cost.p_prior <= 0.0:
        return 0.0
    p = min(max(cost.p_s, p_min, P_FLOOR), 1.0)
    return min(max(1.0 - p / cost.p_prior, 0.0), DEAD_END_MAX)


def with_dead_ends(cost: float, feasible: float) -> float:
    """Eq. 4 when the rest of the plan is feasible from here with chance ``feasible`` (the
    product of 1 - dead-end chance over its streams): a dead end means choosing again here and
    paying for the rest again, so the expected cost is ``cost / feasible`` (Eq. 1 one level
    up)."""
    return cost / max(feasible, 1.0 - DEAD_END_MAX)


def after_attempts(
    cost: StreamCost,
    successes: int,
    failures: int,
    *,
    p_min: float = P_MIN,
    p_max: float = P_MAX,
) -> float:
    """Eq. 1 for a node's next stream once it has been queried from that node.

    A success proves the binding feasible: the success chance becomes a Beta posterior around
    the prediction (weight 2). Failures only: the binding may make the stream impossible
    (prior ``1 - P_S``, between :data:`INFEASIBLE_PRIOR` and :data:`INFEASIBLE_MAX`); each
    failure makes that likelier, so the expected cost of insisting grows without bound, and the
    search backs up to re-sample an ancestor once insisting costs more than redoing the streams
    in between. Every failure also costs :data:`ITERATION_S` of search around it.
    """
    if successes == 0 and failures == 0:
        return expected(cost, p_min=p_min)
    p = min(max(cost.p_s, p_min, P_FLOOR), 1.0)
    if successes > 0:
        p_eff = (2.0 * p + successes) / (2.0 + successes + failures)
    else:
        # A stream the model expects to fail is likelier to be impossible from here.
        p = min(p, p_max)
        infeasible = min(max(INFEASIBLE_PRIOR, 1.0 - p), INFEASIBLE_MAX)
        feasible = (1.0 - infeasible) * (1.0 - p) ** failures
        p_eff = p * feasible / (feasible + infeasible)
    p_eff = max(p_eff, P_FLOOR)
    return cost.r_s + cost.r_m + (1.0 - p_eff) / p_eff * (cost.r_f + ITERATION_S)


def dead_after(
    p_s: float,
    *,
    p_prior: float | None = None,
    doubt: float = DEAD_END_DOUBT,
    p_min: float = P_MIN,
    p_max: float = P_MAX,
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
    p = min(max(p_s, p_min, P_FLOOR), p_max)
    if p >= 1.0:
        return DEAD_END_MIN
    n = max(DEAD_END_MIN, math.ceil(math.log(doubt) / math.log(1.0 - p)))
    if p_prior is None:
        return n
    dead = dead_end_chance(StreamCost(p_s, 0.0, 0.0, 0.0, p_prior=p_prior), p_min=p_min)
    if dead <= 0.0:
        return n
    miss = 1.0 - min(max(p_prior, p_min, P_FLOOR), p_max)  # a failure, when the query is feasible
    for k in range(DEAD_END_MIN, n):
        feasible = (1.0 - dead) * miss**k
        if feasible / (dead + feasible) < doubt:
            return k
    return n
