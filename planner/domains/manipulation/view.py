"""What a manipulation domain's 3D view shares: the blocks drawn at their start poses, the ghosts
of sampled placements and grasps, and the configuration a branch of the search last bound."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from planner.domains.manipulation.problem import UprightPose, block_pose_to_pose
from planner.sim.transforms import Pose, multiply
from planner.view import GREY, Body, Marker, QueryView, Rgb, Shape, Vec3

Parts = tuple[tuple[Vec3, Vec3], ...]  # a ghost's boxes: (centre, size) in its frame


def block_body(name: str, shape: Shape, pose: UprightPose | None, color: Rgb = GREY) -> Body:
    """Block ``name`` drawn as ``shape`` at ``pose`` (at the origin when it has none)."""
    position, quat = block_pose_to_pose(pose) if pose else ((0.0, 0.0, 0.0), (0, 0, 0, 1))
    return Body(name, shape, position, quat, color)


@dataclass(frozen=True)
class SceneBlocks:
    """A problem's blocks as the view's ghosts read them: each block's size (x, y, z extent) and
    where it starts (those whose start pose the problem knows)."""

    sizes: Mapping[str, Vec3]
    starts: Mapping[str, UprightPose]

    def named_in(self, query: QueryView) -> str | None:
        """The block a query is about: its first input naming one."""
        return next((v for v in query.inputs if isinstance(v, str) and v in self.sizes), None)

    def placement_ghost(self, pose: UprightPose, block: str | None) -> Marker:
        """A translucent block where ``pose`` stands it (layer ``placements``), of ``block``'s
        size (without one, the first block's)."""
        size = self.sizes[block] if block else next(iter(self.sizes.values()))
        position, quat = block_pose_to_pose(pose)
        return Marker("placements", "box", position, quat, size, translucent=True)

    def grasp_ghost(self, block: str | None, tool_in_block: Pose, parts: Parts) -> Marker | None:
        """The hand's ``parts`` where a grasp puts its tool frame (``tool_in_block``) around
        ``block`` at its start pose (layer ``grasps``); None without a start pose."""
        if block is None or block not in self.starts:
            return None
        position, quat = multiply(block_pose_to_pose(self.starts[block]), tool_in_block)
        return Marker("grasps", "boxes", position, quat, parts=parts, translucent=True)


def ghosts(
    query: QueryView, blocks: SceneBlocks, ghost: Callable[[Any, str | None], Marker | None]
) -> list[Marker]:
    """The markers of a query's outputs: a block pose's placement ghost, and what ``ghost``
    draws of any other value (given the block the query is about), if anything."""
    block = blocks.named_in(query)
    out = []
    for value in query.outputs:
        marker = (
            blocks.placement_ghost(value, block)
            if isinstance(value, UprightPose)
            else ghost(value, block)
        )
        if marker is not None:
            out.append(marker)
    return out


def last_output(branch: Sequence[QueryView], kinds: tuple[type, ...]) -> Any | None:
    """The last value of one of ``kinds`` that the branch's queries bound (None: none)."""
    found = None
    for query in branch:
        for value in query.outputs:
            if isinstance(value, kinds):
                found = value
    return found
