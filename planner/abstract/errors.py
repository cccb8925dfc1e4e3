"""Typed failures of abstract planning."""

from __future__ import annotations


class AbstractPlanningError(Exception):
    """Base class: abstract planning could not produce stream plans."""


class UnreachableGoalError(AbstractPlanningError):
    """No plan reaches the goal even if every stream succeeds."""


class TopKPlannerError(AbstractPlanningError):
    """The top-k planner crashed, timed out or answered something unreadable."""

    def __init__(self, message: str, *, backend: str, output: str = "") -> None:
        self.backend = backend
        self.output = output
        super().__init__(f"{backend}: {message}")


class InstantiationLimitError(AbstractPlanningError):
    """Optimistic instantiation exceeded its bound on stream instances."""


class PlannerTimeoutError(TopKPlannerError):
    """The planner (top-k, Fast Downward's search or translator) ran out of its time."""
