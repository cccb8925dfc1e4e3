"""What a manipulation domain's samplers and validator share: the world set as a stream's
context says (the blocks at their ``at-pose`` poses, the hand ``holding`` its block), the four
streams around what each domain samples (one world, the random draws, OMPL seeded from them,
placements tried against the placed blocks), and a sampler config set from text."""

from __future__ import annotations

import random
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Generic, Protocol, TypeVar

from planner.domains.manipulation.problem import UprightPose
from planner.domains.manipulation.world import BlocksWorld
from planner.sim.motion import seed_ompl
from planner.streams.adapters import Failure, StreamAdapter, StreamContext, from_fn

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

P = TypeVar("P", bound=UprightPose)  # a domain's block pose
G = TypeVar("G")  # a domain's grasp
C = TypeVar("C", bound="DataclassInstance")  # a domain's sampler config
W = TypeVar("W", bound=BlocksWorld[Any])  # a domain's world
Q = TypeVar("Q")  # a domain's robot configuration
J = TypeVar("J")  # a domain's trajectory


class Hand(Protocol[G]):
    """What staging a scene asks of a world (:class:`~planner.domains.manipulation.world
    .BlocksWorld` and its domain's hand)."""

    held: tuple[str, G] | None
    placed: dict[str, UprightPose]

    def hold(self, block: str | None, grasp: G | None = None) -> None: ...

    def set_blocks(self, poses: Mapping[str, UprightPose]) -> None: ...


def stage(world: Hand[G], poses: Mapping[str, UprightPose], held: tuple[str, G] | None) -> None:
    """The blocks of ``poses`` placed, every other away, the hand holding ``held`` (a block and
    how it is held) or nothing."""
    world.hold(None)
    world.set_blocks(poses)
    if held is not None:
        world.hold(*held)


def context_state(
    context: StreamContext | None, pose_type: type[P], grasp_type: type[G]
) -> tuple[dict[str, P], tuple[str, G] | None]:
    """Where the context's blocks stand (its ``at-pose`` facts) and what the hand holds (its
    ``holding`` fact), read from the values it binds; nothing without a context."""
    poses: dict[str, P] = {}
    held: tuple[str, G] | None = None
    if context is not None:
        for block, pose in context.holds("at-pose"):
            value = context.values.get(pose)
            if isinstance(value, pose_type):
                poses[block] = value
        for block, grasp in context.holds("holding"):
            found = context.values.get(grasp)
            if isinstance(found, grasp_type):
                held = (block, found)
    return poses, held


def stage_grasp(world: Hand[G], block: str, pose: UprightPose) -> bool:
    """The scene of an IK query for holding ``block`` at ``pose``, from the world as its
    context set it: picking, the block stands at the pose; placing (the hand holds it), it does
    not yet. The hand is emptied either way; True when placing."""
    placing = world.held is not None and world.held[0] == block
    standing = dict(world.placed)
    if not placing:
        standing[block] = pose
    world.hold(None)
    world.set_blocks(standing)
    return placing


@dataclass(frozen=True)
class Reach(Generic[P, G]):
    """What an IK query asks for: the robot holding ``block`` at ``pose`` by ``grasp``, to pick
    it there or (``placing``) to put it down there, from the state its ``context`` says."""

    block: str
    pose: P
    grasp: G
    placing: bool
    context: StreamContext | None


class BlockSamplers(Generic[W, P, G, Q, J]):
    """The samplers of one problem, sharing one pybullet ``world`` (:meth:`close` it) and the
    random draws ``rng`` (the first seeds OMPL, which takes one seed per process: the first
    run's); poses are ``pose_type``, grasps ``grasp_type``.

    The four streams are written here: each but the grasp sets the world as the query's context
    says (the blocks at their poses, the hand on what it holds), then asks the domain's part
    (:meth:`_placement`, :meth:`_inverse_kinematics`, :meth:`_motion`) for its outputs; a
    configuration is a ``Q``, a trajectory a ``J``.
    """

    def __init__(
        self, world: W, rng: random.Random, pose_type: type[P], grasp_type: type[G]
    ) -> None:
        self.world = world
        self.rng = rng
        self._types = (pose_type, grasp_type)
        seed_ompl(rng.randrange(1, 2**31))

    def close(self) -> None:
        self.world.close()

    def bindings(self) -> dict[str, StreamAdapter]:
        """The four streams' bindings: ``sample-grasp`` (no context), and ``sample-placement``,
        ``inverse-kinematics`` and ``plan-motion``, which read the state where their output is
        first needed."""
        return {
            "sample-grasp": from_fn(self.sample_grasp),
            "sample-placement": from_fn(self.sample_placement, context=True),
            "inverse-kinematics": from_fn(self.inverse_kinematics, context=True),
            "plan-motion": from_fn(self.plan_motion, context=True),
        }

    # --- the streams -------------------------------------------------------------------------

    def sample_grasp(self, block: str) -> tuple[G]:
        raise NotImplementedError

    def sample_placement(
        self, block: str, fixture: str, *, context: StreamContext | None = None
    ) -> tuple[P] | Failure:
        """A pose for ``block`` on (or in) ``fixture``, clear of the blocks standing there."""
        self._apply(context)
        return self._placement(block, fixture)

    def inverse_kinematics(
        self, block: str, pose: P, grasp: G, *, context: StreamContext | None = None
    ) -> tuple[Q] | Failure:
        """A configuration holding ``block`` at ``pose`` by ``grasp``: picking it there (the
        block stands at the pose) or placing it (the hand holds it, as the context says)."""
        placing = self._stage_grasp(context, block, pose)
        return self._inverse_kinematics(Reach(block, pose, grasp, placing, context))

    def plan_motion(
        self, q1: Q, q2: Q, *, context: StreamContext | None = None
    ) -> tuple[J] | Failure:
        """A collision-free trajectory from ``q1`` to ``q2``, with what the hand holds."""
        self._apply(context)
        return self._motion(q1, q2)

    # --- the domain's part -------------------------------------------------------------------

    def _placement(self, block: str, fixture: str) -> tuple[P] | Failure:
        raise NotImplementedError

    def _inverse_kinematics(self, reach: Reach[P, G]) -> tuple[Q] | Failure:
        raise NotImplementedError

    def _motion(self, q1: Q, q2: Q) -> tuple[J] | Failure:
        raise NotImplementedError

    # --- helpers -----------------------------------------------------------------------------

    def _apply(self, context: StreamContext | None) -> None:
        """Put the blocks where the context says and the hand on what it holds."""
        stage(self.world, *context_state(context, *self._types))

    def _stage_grasp(self, context: StreamContext | None, block: str, pose: P) -> bool:
        """The world as the context says, then as :func:`stage_grasp` sets it for an IK query;
        True when placing."""
        self._apply(context)
        return stage_grasp(self.world, block, pose)

    def _free_place(
        self, block: str, candidates: Iterable[P | None], gap: float, where: str
    ) -> tuple[P] | Failure:
        """The first of ``candidates`` (None: a draw that did not fit) at which ``block`` keeps
        ``gap`` from the placed blocks (and whatever else the world checks a block against);
        a Failure says how many were tried ``where`` ("on the stove") when none is free."""
        poses = dict(self.world.placed)
        tries = 0
        for pose in candidates:
            tries += 1
            if pose is None:
                continue
            poses[block] = pose
            self.world.set_blocks(poses)
            if not self.world.block_collides(block, margin=gap):
                return (pose,)
        return Failure(f"no free place {where} in {tries} tries")


def with_text(config: C, name: str, text: str) -> C:
    """``config`` with its text, number or true/false field ``name`` set from ``text`` (as a
    command line gives it); a ValueError says what is wrong."""
    default = getattr(config, name, None)
    if not isinstance(default, str | int | float):
        raise ValueError(
            f"{name!r} is not a text, number or true/false field of {type(config).__name__}"
        )
    if isinstance(default, bool):  # bool("off") is True: spell the two values out
        words = {"true": True, "on": True, "1": True, "false": False, "off": False, "0": False}
        if text.lower() not in words:
            raise ValueError(f"{name} is true or false (on/off, 1/0), got {text!r}")
        return replace(config, **{name: words[text.lower()]})
    changes: dict[str, Any] = {name: type(default)(text)}
    return replace(config, **changes)
