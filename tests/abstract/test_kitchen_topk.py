"""The kitchen through both real top-k planners: k unique skeletons with valid stream plans."""

from __future__ import annotations

import pytest

from planner.abstract import AbstractConfig, canonical_key, plan_abstract, replay
from planner.domains import problem_for_scene

pytestmark = pytest.mark.slow


def test_kitchen_4_gives_50_unique_valid_skeletons() -> None:
    loaded, problem = problem_for_scene("kitchen-4")
    config = AbstractConfig(k=50, backend="kstar")
    result = plan_abstract(loaded.domain, loaded.streams, problem, config)
    assert len(result.plans) == 50
    assert len({canonical_key(p.actions, p.stream_plan) for p in result.plans}) == 50
    for plan in result.plans:
        replay(plan, loaded.domain, problem)
        streams = {s.stream for s in plan.stream_plan}
        assert streams == {"sample-grasp", "sample-placement", "inverse-kinematics", "plan-motion"}
        cooked = [a.args[0] for a in plan.actions if a.name == "cook"]
        assert sorted(cooked) == ["b1", "b2", "b3", "b4"]


@pytest.mark.parametrize("backend", ["kstar", "symk"])
def test_both_backends_find_the_optimal_kitchen_2_plans(backend: str) -> None:
    loaded, problem = problem_for_scene("kitchen-2")
    config = AbstractConfig(k=10, backend=backend)
    result = plan_abstract(loaded.domain, loaded.streams, problem, config)
    assert result.backend == backend and len(result.plans) == 10
    # Two blocks: move, pick, move, place at the sink, clean, pick, move, cook = 8 actions each.
    assert result.plans[0].cost == 16
    for plan in result.plans:
        replay(plan, loaded.domain, problem)
