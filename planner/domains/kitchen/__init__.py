"""The PR2 kitchen: blocks are cleaned at the sink and cooked on the stove."""

from __future__ import annotations

from planner.domains import DomainSpec
from planner.pddl.structs import Atom, Domain, Literal, Problem, TypedName
from planner.scene import Scene, check_name, goal_atoms

PLATFORM_KINDS = ("table", "sink", "stove")  # every kitchen has at least one of each
START_CONF = "q0"  # the robot's initial base and arm configuration


def problem_from_scene(scene: Scene, domain: Domain) -> Problem:
    """Objects, initial facts and goal of a kitchen scene (geometry is the samplers' business)."""
    platforms = scene.get("platforms", list)
    kinds: dict[str, str] = {}
    for i, plat in enumerate(platforms):
        if not isinstance(plat, dict):
            raise scene.field_error(f"platforms[{i}]", "expected an object with name and kind")
        name = check_name(scene, f"platforms[{i}].name", plat.get("name"))
        kind = plat.get("kind")
        if kind not in PLATFORM_KINDS:
            raise scene.field_error(
                f"platforms[{i}].kind", f"expected one of {', '.join(PLATFORM_KINDS)}, got {kind!r}"
            )
        if name in kinds:
            raise scene.field_error(f"platforms[{i}].name", f"platform {name!r} is repeated")
        kinds[name] = kind
    for kind in PLATFORM_KINDS:
        if kind not in kinds.values():
            raise scene.field_error("platforms", f"the kitchen needs a platform of kind {kind!r}")
    blocks = scene.get("blocks", list)
    if not blocks:
        raise scene.field_error("blocks", "expected at least one block")
    default_start = next(n for n, k in kinds.items() if k == "table")
    init: set[Atom] = {
        Atom("conf", (START_CONF,)),
        Atom("at-conf", (START_CONF,)),
        Atom("hand-empty"),
        Atom("can-move"),
    }
    objects = [TypedName(START_CONF)]
    for name, kind in kinds.items():
        objects.append(TypedName(name))
        init.add(Atom("platform", (name,)))
        if kind in ("sink", "stove"):
            init.add(Atom(kind, (name,)))
    names = set(kinds) | {START_CONF}
    for i, block in enumerate(blocks):
        if not isinstance(block, dict):
            raise scene.field_error(f"blocks[{i}]", "expected an object with a name")
        name = check_name(scene, f"blocks[{i}].name", block.get("name"))
        if name in names:
            raise scene.field_error(f"blocks[{i}].name", f"name {name!r} is already used")
        start = block.get("on", default_start)
        if start not in kinds:
            raise scene.field_error(f"blocks[{i}].on", f"unknown platform {start!r}")
        pose = f"p0-{name}"
        names |= {name, pose}
        objects += [TypedName(name), TypedName(pose)]
        init |= {
            Atom("block", (name,)),
            Atom("pose", (name, pose)),
            Atom("supported", (name, pose, start)),
            Atom("at-pose", (name, pose)),
            Atom("on", (name, start)),
        }
    arity = {p.name: p.arity for p in domain.predicates}
    goal = tuple(Literal(Atom(p, a)) for p, a in goal_atoms(scene, arity, names))
    return Problem(scene.name, domain.name, tuple(objects), frozenset(init), goal, scene.source)


SPEC = DomainSpec(
    name="kitchen",
    problem_from_scene=problem_from_scene,
    bindings=None,  # TODO(#3): pybullet grasp, placement, IK and motion samplers
    diversity_ignore=("move",),  # moves only connect configurations; compare what is done
)
