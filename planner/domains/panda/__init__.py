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
    manipulation_spec,
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
from planner.domains.spec import LoadedDomain

if TYPE_CHECKING:
    from planner.domains.panda.samplers import SamplerConfig

SAMPLERS = "planner.domains.panda.samplers"  # imported when first sampling: pybullet then
MODEL = Path(__file__).resolve().parent / "model.pt"  # the shipped model (docs/panda.md)


DOMAIN = manipulation_spec(
    name="panda",
    description="a Franka Panda clears a cluttered table into a tray with little room",
    package="planner.domains.panda",
    problem_from_scene=problem_from_scene,
    static_context=static_context,
    value_types=VALUE_TYPES,
    view=PandaView(),
    features=PandaFeatures(),
    kinds=("panda_pose", "panda_grasp", "panda_conf"),
    model=MODEL if MODEL.is_file() else None,
    blocking=("obstructed",),  # a tall obstacle in the way of a grasp
    placement_unread=("hand-empty", "obstructed"),
)


def with_samplers(loaded: LoadedDomain, config: SamplerConfig) -> LoadedDomain:
    """The loaded Panda domain with its samplers set by ``config`` instead of the defaults."""
    return with_bindings(loaded, DOMAIN.name, LazySamplers(SAMPLERS, config))


__all__ = ["DOMAIN", "GEOMETRY_KEY", "MODEL", "START_CONF", "initial_pose_name", "with_samplers"]
