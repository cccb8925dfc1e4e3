"""What the dashboard's services refuse with; the routers turn each into its HTTP answer."""

from __future__ import annotations


class RequestError(ValueError):
    """A request that names something that does not exist or does not fit (a 422); ``field``
    says which part of the body is wrong (``"scene"``, or ``["runs", 2]`` for an item)."""

    def __init__(self, field: str | list[str | int], message: str) -> None:
        super().__init__(message)
        self.field = field


class BusyError(Exception):
    """The server already does as much of this as it may (a 429): a benchmark or a training
    job runs."""


class NotLiveError(Exception):
    """Cancelling or resuming something that is not in a state for it (a 409)."""
