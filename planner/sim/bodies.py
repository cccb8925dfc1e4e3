"""pybullet bodies and collision queries; the physics client id is always passed explicitly."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import pybullet as p

from planner.sim.transforms import Pose, Vec3

Color = tuple[float, float, float, float]


def connect() -> int:
    """A headless physics client (no GUI), without gravity: bodies stay where they are put."""
    return int(p.connect(p.DIRECT))


def disconnect(client: int) -> None:
    p.disconnect(physicsClientId=client)


def add_box(client: int, half_extents: Vec3, pose: Pose, color: Color, *, mass: float = 0.0) -> int:
    collision = p.createCollisionShape(p.GEOM_BOX, halfExtents=half_extents, physicsClientId=client)
    visual = p.createVisualShape(
        p.GEOM_BOX, halfExtents=half_extents, rgbaColor=color, physicsClientId=client
    )
    return int(
        p.createMultiBody(
            baseMass=mass,
            baseCollisionShapeIndex=collision,
            baseVisualShapeIndex=visual,
            basePosition=pose[0],
            baseOrientation=pose[1],
            physicsClientId=client,
        )
    )


def set_pose(client: int, body: int, pose: Pose) -> None:
    p.resetBasePositionAndOrientation(body, pose[0], pose[1], physicsClientId=client)


def get_pose(client: int, body: int) -> Pose:
    pos, quat = p.getBasePositionAndOrientation(body, physicsClientId=client)
    return ((pos[0], pos[1], pos[2]), (quat[0], quat[1], quat[2], quat[3]))


def link_pose(client: int, body: int, link: int) -> Pose:
    state = p.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=client)
    pos, quat = state[4], state[5]
    return ((pos[0], pos[1], pos[2]), (quat[0], quat[1], quat[2], quat[3]))


def joint_indices(client: int, body: int) -> dict[str, int]:
    """Joint name -> index."""
    n = p.getNumJoints(body, physicsClientId=client)
    return {p.getJointInfo(body, i, physicsClientId=client)[1].decode(): i for i in range(n)}


def link_indices(client: int, body: int) -> dict[str, int]:
    """Link name -> index (the child link of each joint; the base is -1)."""
    n = p.getNumJoints(body, physicsClientId=client)
    return {p.getJointInfo(body, i, physicsClientId=client)[12].decode(): i for i in range(n)}


def set_joints(client: int, body: int, indices: Sequence[int], values: Sequence[float]) -> None:
    for i, v in zip(indices, values, strict=True):
        p.resetJointState(body, i, v, physicsClientId=client)


def in_contact(
    client: int,
    a: int,
    b: int,
    *,
    margin: float = 0.0,
    link_a: int | None = None,
) -> bool:
    """True when bodies a and b (optionally only a's link) are closer than ``margin``."""
    if link_a is None:
        pts = p.getClosestPoints(a, b, distance=margin, physicsClientId=client)
    else:
        pts = p.getClosestPoints(a, b, distance=margin, linkIndexA=link_a, physicsClientId=client)
    return len(pts) > 0


def any_contact(client: int, body: int, others: Iterable[int], *, margin: float = 0.0) -> bool:
    return any(in_contact(client, body, o, margin=margin) for o in others if o != body)
