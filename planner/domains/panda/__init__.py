"""A Franka Panda at a table: blocks go from a cluttered table into a tray (or onto a shelf) with
little room; tall obstacles stand in the way of some blocks' grasps until they are moved.

A fixed-base arm executes in seconds, so planning is most of a run's time (the paper's regime).
The domain object :data:`DOMAIN` is registered through the ``guided_tamp.domains`` entry point
like any other; pybullet is imported only when samplers, the validator or the world are used.
See docs/panda.md.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from planner.domains.manipulation.domain import (
    LazySamplers,
    LazyValidator,
    stream_inputs,
    with_bindings,
)
from planner.domains.manipulation.problem import initial_pose_name
from planner.domains.panda.features import PandaFeatures
from planner.domains.panda.problem import (
    GEOMETRY_KEY,
    START_CONF,
    problem_from_scene,
    static_context,
)
from planner.domains.panda.values import VALUE_TYPES
from planner.domains.panda.view import PandaView
from planner.domains.spec import DomainSpec, LoadedDomain

if TYPE_CHECKING:
    from planner.domains.panda.samplers import SamplerConfig

SAMPLERS = "planner.domains.panda.samplers"  # imported when first sampling: pybullet then
MODEL = Path(__file__).resolve().parent / "model.pt"  # the shipped model (docs/panda.md)


DOMAIN = DomainSpec(
    name="panda",
    description="a Franka Panda clears a cluttered table into a tray with little room",
    problem_from_scene=problem_from_scene,
    bindings=LazySamplers(SAMPLERS),
    value_types=VALUE_TYPES,
    validate=LazyValidator("planner.domains.panda.validate"),
    static_context=static_context,
    view=PandaView(),
    features=PandaFeatures(),
    input_kinds=stream_inputs("panda_pose", "panda_grasp", "panda_conf"),
    model=MODEL if MODEL.is_file() else None,
    diversity_ignore=("move",),  # moves only connect configurations; compare what is done
    # Where the arm is and how it holds the block do not change where a block fits.
    evidence_ignore=("at-conf", "can-move", "holding", "obstructed"),
    # A placement reads only the blocks already in the region, not the arm or the hand.
    unread={"sample-placement": ("at-conf", "can-move", "holding", "hand-empty", "obstructed")},
)


def with_samplers(loaded: LoadedDomain, config: SamplerConfig) -> LoadedDomain:
    """The loaded Panda domain with its samplers set by ``config`` instead of the defaults."""
    return with_bindings(loaded, DOMAIN.name, LazySamplers(SAMPLERS, config))


__all__ = ["DOMAIN", "GEOMETRY_KEY", "MODEL", "START_CONF", "initial_pose_name", "with_samplers"]
