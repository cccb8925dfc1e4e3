"""The eTAMP baseline (Ren et al., "Extended Tree Search"): progressive-widening UCT.

Pure functions over numbers; the constants are those of the public eTAMP code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class BaselineConfig:
    """Constants of eTAMP's PW-UCT (source: the public eTAMP code)."""

    c_node: float = 0.1  # exploration weight inside a plan: value + c * sqrt(ln N / n)
    widen_k: float = 13.5  # query again when visits > widen_k * children^2 (alpha = 0.5)
    c_plan: float = 1.1  # exploration weight when choosing among stream plans at the root
    root_widen_k: float = 6.0  # add a stream plan when root visits > root_widen_k * plans^2
    fail_scale: float = 0.1  # a failed node at depth d is worth fail_scale * d / plan depth
    success_value: float = 1.0  # a fully bound plan is worth this ...
    action_bonus: float = 0.1  # ... plus action_bonus * exp(-cost) per action (unit costs)


def ucb(value: float, visits: int, parent_visits: int, c: float) -> float:
    """Upper confidence bound; unvisited children first."""
    if visits == 0:
        return math.inf
    return value + c * math.sqrt(math.log(max(parent_visits, 1)) / visits)


def should_widen(visits: int, children: int, k: float) -> bool:
    """Progressive widening: a new query when the node's visits exceed k * children^2."""
    return children == 0 or visits > k * children * children


def failure_value(depth: int, plan_depth: int, config: BaselineConfig) -> float:
    """What a failed query at ``depth`` of a plan with ``plan_depth`` streams is worth."""
    return config.fail_scale * depth / max(plan_depth, 1)


def success_value(action_costs: list[float], config: BaselineConfig) -> float:
    return config.success_value + sum(config.action_bonus * math.exp(-c) for c in action_costs)
