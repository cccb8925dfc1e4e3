"""A manipulation problem's common parts: an upright block's pose, the problem gathered from a
scene (the robot's and the blocks' start facts, the objects, the values), the values a problem
keeps, and lookups by name."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol, TypeVar

from planner.pddl.structs import Atom, Domain, Literal, Problem, TypedName
from planner.scene import Scene, goal_atoms
from planner.sim.transforms import Pose, quat_from_yaw


@dataclass(frozen=True)
class UprightPose:
    """A block standing upright: its centre and its turn about the vertical. A domain's pose
    type subclasses it (a class of its own, so that its value type knows it)."""

    x: float
    y: float
    z: float
    yaw: float


P = TypeVar("P", bound=UprightPose)
T = TypeVar("T")


def block_pose_to_pose(pose: UprightPose) -> Pose:
    """A block pose as a (position, xyzw quaternion) pose."""
    return ((pose.x, pose.y, pose.z), quat_from_yaw(pose.yaw))


def initial_pose_name(block: str) -> str:
    """The object naming a block's initial pose (its value depends on the seed)."""
    return f"p0-{block}"


class ProblemParts:
    """A problem's objects, start facts and values as a domain gathers them from its scene,
    starting with the robot at its configuration ``conf`` (``conf``, ``at-conf``, the hand
    empty, ``can-move``); ``values`` are the first values (the start configuration's, the
    geometry). Objects keep the order they are added in."""

    def __init__(self, conf: str, values: Mapping[str, object]) -> None:
        self.objects: list[TypedName] = [TypedName(conf)]
        self.names: set[str] = {conf}
        self.values: dict[str, object] = dict(values)
        self.init: set[Atom] = {
            Atom("conf", (conf,)),
            Atom("at-conf", (conf,)),
            Atom("hand-empty"),
            Atom("can-move"),
        }

    def fixture(self, name: str, *facts: Atom) -> None:
        """An object that stays where it is (a platform, a region), with its facts."""
        self.objects.append(TypedName(name))
        self.names.add(name)
        self.init.update(facts)

    def block(self, block: str, pose: UprightPose, on: str) -> str:
        """A block standing at ``pose`` on ``on``: the block and its initial pose (returned) as
        objects, the pose as a value, and ``block``, ``pose``, ``at-pose`` and ``on``."""
        name = initial_pose_name(block)
        self.names |= {block, name}
        self.values[name] = pose
        self.objects += [TypedName(block), TypedName(name)]
        self.init |= {
            Atom("block", (block,)),
            Atom("pose", (block, name)),
            Atom("at-pose", (block, name)),
            Atom("on", (block, on)),
        }
        return name

    def problem(self, scene: Scene, domain: Domain) -> Problem:
        """The problem of ``scene``: these objects, facts and values, and the scene's goal
        (checked against the domain's predicates and the objects' names)."""
        arity = {p.name: p.arity for p in domain.predicates}
        goal = tuple(Literal(Atom(p, a)) for p, a in goal_atoms(scene, arity, self.names))
        return Problem(
            scene.name,
            domain.name,
            tuple(self.objects),
            frozenset(self.init),
            goal,
            scene.source,
            self.values,
        )


def stored(problem: Problem, key: str, kind: type[T], what: str) -> T:
    """The value a problem keeps under ``key`` (its geometry), which must be a ``kind``; a
    ValueError says the problem was not built from a scene."""
    value = problem.values.get(key)
    if not isinstance(value, kind):
        raise ValueError(f"problem {problem.name}: no {what} in its values (build it from a scene)")
    return value


def start_poses(problem: Problem, blocks: Sequence[str], kind: type[P]) -> dict[str, P]:
    """Where ``blocks`` stand at the start (their initial poses' values), those it knows."""
    out = {}
    for block in blocks:
        pose = problem.values.get(initial_pose_name(block))
        if isinstance(pose, kind):
            out[block] = pose
    return out


class Named(Protocol):
    @property
    def name(self) -> str: ...


N = TypeVar("N", bound=Named)


def by_name(items: Sequence[N], name: str, kind: str) -> N:
    """The item called ``name``; a KeyError names the known ones."""
    for item in items:
        if item.name == name:
            return item
    raise KeyError(f"no {kind} {name!r} (known: {', '.join(i.name for i in items)})")
