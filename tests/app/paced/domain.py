"""A domain whose one sampler answers a query only when the test allows it: a run of the
dashboard's browser tests that grows one node per token, whatever the machine's speed.

The test names a folder in ``PACED_TOKENS`` (in the server's environment, which its workers
inherit) and drops files into it; each query takes one file away before it answers. A query
that finds no token within ``WAIT_S`` fails (so a forgotten run ends on its own).
"""

from __future__ import annotations

import os
import random
import time
from collections.abc import Mapping
from itertools import pairwise
from pathlib import Path

from planner.domains import DomainSpec
from planner.pddl import Atom, Domain, Literal, Problem, TypedName
from planner.scene import Scene
from planner.streams import Failure, StreamAdapter, from_fn

TOKENS_ENV = "PACED_TOKENS"
WAIT_S = 600.0
POLL_S = 0.05


def _take_token() -> bool:
    folder = Path(os.environ[TOKENS_ENV])
    deadline = time.monotonic() + WAIT_S
    while time.monotonic() < deadline:
        for token in sorted(folder.iterdir()):
            try:
                token.unlink()
            except FileNotFoundError:
                continue
            return True
        time.sleep(POLL_S)
    return False


def problem_from_scene(scene: Scene, domain: Domain, seed: int = 0) -> Problem:
    steps = int(scene.get("steps", int))
    levels = [f"l{i}" for i in range(steps + 1)]
    init = {Atom("point", ("p0",)), Atom("at", ("l0", "p0"))}
    init |= {Atom("next", (a, b)) for a, b in pairwise(levels)}
    objects = tuple(TypedName(n) for n in ["p0", *levels])
    goal = (Literal(Atom("reached", (levels[-1],))),)
    return Problem(scene.name, domain.name, objects, frozenset(init), goal, scene.source, {"p0": 0})


def bindings(problem: Problem, rng: random.Random) -> Mapping[str, StreamAdapter]:
    def sample_step(a: int) -> tuple[int] | Failure:
        if not _take_token():
            return Failure(f"no token in ${TOKENS_ENV} within {WAIT_S:.0f} s")
        return (a + 1,)

    return {"sample-step": from_fn(sample_step)}


DOMAIN = DomainSpec(
    name="paced",
    description="a walk whose every step waits for the test's token",
    problem_from_scene=problem_from_scene,
    bindings=bindings,
)
