"""The PR2 kitchen: blocks are cleaned at the sink and cooked on the stove.

The domain object :data:`DOMAIN` is registered through the ``guided_tamp.domains`` entry point
like any other domain; pybullet is imported only when samplers or the validator are used.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from planner.domains.kitchen.codec import VALUE_TYPES
from planner.domains.kitchen.features import KitchenFeatures
from planner.domains.kitchen.problem import (
    ARM,
    GEOMETRY_KEY,
    START_CONF,
    problem_from_scene,
    static_context,
)
from planner.domains.kitchen.view import KitchenView
from planner.domains.manipulation.domain import (
    LazySamplers,
    manipulation_spec,
    with_bindings,
)
from planner.domains.manipulation.problem import initial_pose_name
from planner.domains.spec import LoadedDomain

if TYPE_CHECKING:
    from planner.domains.kitchen.samplers import SamplerConfig

SAMPLERS = "planner.domains.kitchen.samplers"  # imported when first sampling: pybullet then
MODEL = Path(__file__).resolve().parent / "model.pt"  # the shipped model (docs/learning.md)


DOMAIN = manipulation_spec(
    name="kitchen",
    description="the PR2 kitchen: clean blocks at the sink, cook them on the stove",
    package="planner.domains.kitchen",
    problem_from_scene=problem_from_scene,
    static_context=static_context,
    value_types=VALUE_TYPES,
    view=KitchenView(),
    features=KitchenFeatures(),
    kinds=("pose", "grasp", "conf"),
    model=MODEL,
)


def with_samplers(loaded: LoadedDomain, config: SamplerConfig) -> LoadedDomain:
    """The loaded kitchen with its samplers set by ``config`` instead of the defaults: for
    probes that compare sampler settings (pass it to :func:`planner.api.solve` as ``loaded``)."""
    return with_bindings(loaded, DOMAIN.name, LazySamplers(SAMPLERS, config))


__all__ = [
    "ARM",
    "DOMAIN",
    "GEOMETRY_KEY",
    "MODEL",
    "START_CONF",
    "initial_pose_name",
    "with_samplers",
]
