"""The classical task the top-k planners get: unchanged for STRIPS domains (the kitchen's
seeded trials stay the same trials), and what K* searches it with."""

from __future__ import annotations

import hashlib
import logging

import pytest

from planner.abstract import compile_task, instantiate
from planner.domains import problem_for_scene
from tests.pddl.domains import abstract, load

# sha256 of compile_task's domain and problem text for kitchen-2 and kitchen-4 at seed 1000,
# as the code before the ADL compilation (e5923b3) wrote them.
KITCHEN = {
    "kitchen-2": (
        "656808b70e15880bf03af5f21d49b43cfa3fae6d66c27a390ff3d086ed903a69",
        "f0dd7f4c56bee052c99f9654091f2646ae3b2b1be115997cb53ba7a446cdac22",
    ),
    "kitchen-4": (
        "656808b70e15880bf03af5f21d49b43cfa3fae6d66c27a390ff3d086ed903a69",
        "ab9a597b18b5f6abd4a44cc2b987228d50b7399962647bfd055bad14fd7ccb5a",
    ),
}


@pytest.mark.parametrize("scene", sorted(KITCHEN))
def test_the_kitchens_task_is_written_as_before(scene: str) -> None:
    loaded, problem = problem_for_scene(scene, seed=1000)
    inst = instantiate(loaded.streams, problem, max_levels=4, max_instances=50_000)
    domain, problem_text = compile_task(loaded.domain, problem, inst)
    digest = tuple(hashlib.sha256(t.encode()).hexdigest() for t in (domain, problem_text))
    assert digest == KITCHEN[scene]


@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "heuristic"),
    [("functions", "lmcut"), ("derived", "lmcut"), ("tower", "blind"), ("disjunction", "blind")],
)
def test_kstar_searches_a_translation_without_axioms_with_lmcut(
    name: str, heuristic: str, caplog: pytest.LogCaptureFixture
) -> None:
    """Function costs translate to plain operators. So does the derived domain's (unsafe ...):
    with every (cfree ...) fact assumed, the translator proves it false and drops the axiom.
    The tower's recursive (above ...) and the disjunctive goal stay axioms: blind."""
    with caplog.at_level(logging.INFO, logger="planner.abstract.topk"):
        abstract(load(name), "kstar", k=2)
    assert f"kstar: the translated task needs {heuristic}" in caplog.text
