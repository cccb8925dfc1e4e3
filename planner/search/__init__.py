"""Search over stream bindings: the tree (``tree.py``), the loop (``mcts.py``), the baseline and
learned policies, and a sequential binder (``binding.py``)."""

from planner.search.binding import BoundPlan, bind_sequentially, stream_contexts

__all__ = ["BoundPlan", "bind_sequentially", "stream_contexts"]
