"""The tabletop2d domain object: what guided-tamp loads from this folder.

A domain folder holds ``domain.pddl``, ``stream.pddl``, ``scenes/`` and this module, which exports
``DOMAIN``. Only the name, the problem builder and the sampler bindings are required; every
other hook has a default (docs/domains.md).
"""

from __future__ import annotations

from planner.domains import DomainSpec

from .samplers import bindings
from .scene import problem_from_scene
from .validate import validate
from .values import VALUE_TYPES
from .view import TabletopView

DOMAIN = DomainSpec(
    name="tabletop2d",
    description="a 2-D tabletop: move blocks into a crowded region, within the arm's reach",
    problem_from_scene=problem_from_scene,
    bindings=bindings,
    value_types=VALUE_TYPES,
    validate=validate,
    view=TabletopView(),
    diversity_ignore=("move",),  # moves only connect configurations; compare what is done
    # The collision test reads which blocks stand where, not where the gripper is or what it
    # holds: the learned search may test a placement before the moves around it are bound.
    unread={"test-cfree": ("at-conf", "can-move", "holding", "hand-empty")},
)
