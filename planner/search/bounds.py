"""Bounds of a run that do not depend on the machine: stream queries and search iterations.

A run's seconds depend on where it runs: the same run on a laptop, on a cluster node, or beside
other work on a busy machine gets through more or fewer queries in its ``budget_s``. Its stream
queries and its search iterations do not: a run bounded by them (``RunConfig.max_queries``,
``RunConfig.max_iterations``) stops at the same point everywhere, so a result can be repeated
on another machine and a test's outcome does not depend on the machine's load. The seconds
bound stays (a run stops at whichever bound it reaches first), and the skeleton source's time
counts against the seconds only.

What is counted:

- a **query** is a stream query a sampler answered (``QueryResult.reused`` false: an answer
  taken again from an identical earlier query, a test asked again or a known failure is not
  one), as ``RunResult.queries`` and ``run_finished.queries`` count them;
- an **iteration** is one pass of a tree search's loop (:meth:`planner.search.mcts.TreeSearch.run`:
  a selection from the root and what follows it), or one skeleton tried by the sequential
  binder (one try at binding it, with its attempts and restarts).
"""

from __future__ import annotations

from dataclasses import dataclass


def check_bound(name: str, value: int | None) -> None:
    """A bound is a positive integer or None (unbounded); ValueError naming ``name`` otherwise."""
    if value is None:
        return
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"{name} must be a positive integer or None, got {value!r}")


def time_reached(budget_s: float) -> str:
    """Why a run ended that spent its seconds: the phrase its message carries."""
    return f"time budget of {budget_s:g} s reached"


@dataclass(frozen=True)
class SearchBounds:
    """A search's bounds besides its deadline; None: unbounded."""

    max_queries: int | None = None
    max_iterations: int | None = None

    def __post_init__(self) -> None:
        check_bound("max_queries", self.max_queries)
        check_bound("max_iterations", self.max_iterations)

    def reached(self, queries: int, iterations: int) -> str | None:
        """Which bound ``queries`` answered and ``iterations`` made have reached, as the phrase
        a run's message carries ("query budget of 500 reached"); None while neither has."""
        if self.max_queries is not None and queries >= self.max_queries:
            return f"query budget of {self.max_queries} reached"
        if self.max_iterations is not None and iterations >= self.max_iterations:
            return f"iteration budget of {self.max_iterations} reached"
        return None

    def queries_reached(self, queries: int) -> bool:
        """Whether ``queries`` answered reach the query bound (a rollout stops there)."""
        return self.max_queries is not None and queries >= self.max_queries
