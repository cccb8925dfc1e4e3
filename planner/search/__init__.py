"""Search over stream bindings (the tree search arrives with issue 4)."""

from planner.search.binding import BoundPlan, bind_sequentially, stream_contexts

__all__ = ["BoundPlan", "bind_sequentially", "stream_contexts"]
