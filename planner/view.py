"""What a domain tells the 3D view: the bodies of a scene, how sampled values are drawn, and how a
bound plan moves the bodies. Plain data, no viser (only ``app/`` touches viser).

A domain's :class:`DomainView` (its ``view`` hook) gives:

- :meth:`DomainView.scene`: the scene's bodies (:class:`Body`: a box, mesh files or a URDF, with
  a pose, a colour and an optional label), optionally where the camera starts and the floor;
- :meth:`DomainView.markers`: how a sampled value is drawn as a ghost where it lies
  (:class:`Marker`: boxes, a compound of boxes, an arrow on the floor, a path), in named layers
  the view counts and batches ("placements", "grasps", ...);
- :meth:`DomainView.failure_at`: where a failed query was about (a red diamond is drawn there);
- :meth:`DomainView.animate`: a bound plan as a :class:`Timeline` of body states, which the
  view plays in real time;
- optionally, :meth:`FocusView.focus`: where the bodies stand at one search node that the user
  selected (the robot at the node's configuration), given the queries on its branch; the view
  highlights the node's own ghosts and those of its branch either way.

Units are metres and radians; quaternions are ``xyzw`` (pybullet's order; ``app/`` converts).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Protocol, runtime_checkable

from planner.abstract.skeleton import GroundAction
from planner.pddl.structs import Problem

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]  # x, y, z, w
Rgb = tuple[int, int, int]  # 0-255
IDENTITY: Quat = (0.0, 0.0, 0.0, 1.0)
GREY: Rgb = (150, 150, 150)


def yaw_quat(yaw: float) -> Quat:
    """The rotation by ``yaw`` about +z."""
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


def _finite(values: Sequence[float], what: str) -> None:
    if not all(isinstance(v, int | float) and math.isfinite(v) for v in values):
        raise ValueError(f"{what} must be finite numbers, got {tuple(values)}")


@dataclass(frozen=True)
class Box:
    """An axis-aligned box centred on its body's pose."""

    size: Vec3

    def __post_init__(self) -> None:
        _finite(self.size, "box size")
        if min(self.size) <= 0:
            raise ValueError(f"box sizes must be positive, got {self.size}")


@dataclass(frozen=True)
class Mesh:
    """A mesh file in its body's frame, scaled: anything trimesh reads (.obj, .stl, .glb, ...)
    for the 3D view, .obj or .stl for ``tamp render``. It is drawn in ``color`` (the body's
    colour when None); the 3D view keeps the colours of a file that has its own."""

    path: Path
    scale: float = 1.0
    color: Rgb | None = None

    def __post_init__(self) -> None:
        _finite((self.scale,), "mesh scale")
        if self.scale <= 0:
            raise ValueError(f"a mesh's scale must be positive, got {self.scale}")


@dataclass(frozen=True)
class Meshes:
    """Several mesh files that make one body, e.g. one per colour (a table's top and legs)."""

    parts: tuple[Mesh, ...]

    def __post_init__(self) -> None:
        if not self.parts:
            raise ValueError("a Meshes shape needs at least one part")


@dataclass(frozen=True)
class Urdf:
    """A robot or articulated object from a URDF file, with its joints' start values (a joint
    not named stays at 0)."""

    path: Path
    joints: Mapping[str, float] = field(default_factory=dict)


Shape = Box | Mesh | Meshes | Urdf


@dataclass(frozen=True)
class Body:
    """One body of the scene at its start pose."""

    name: str
    shape: Shape
    position: Vec3 = (0.0, 0.0, 0.0)
    quat: Quat = IDENTITY
    color: Rgb = GREY  # boxes, and meshes without a colour of their own; URDFs keep theirs
    label: str | None = None  # drawn above the body
    opacity: float | None = None

    def __post_init__(self) -> None:
        if not self.name or "/" in self.name:
            raise ValueError(f"a body's name must be non-empty without '/', got {self.name!r}")
        _finite(self.position, f"body {self.name}: position")
        _finite(self.quat, f"body {self.name}: quat")


@dataclass(frozen=True)
class SceneView:
    """Everything the view draws before the search starts."""

    bodies: tuple[Body, ...]
    camera: tuple[Vec3, Vec3] | None = None  # (position, look at); None: fitted to the bodies
    floor_z: float = 0.0  # height of the ground plane
    # The ground drawn under the scene (a tiled floor), in place of the view's own (the 3D
    # view's grid, the renderer's grey plane); not a body of the scene: the camera and the
    # tree drawing are placed by the bodies alone. None: the view's own ground at floor_z.
    floor: Body | None = None

    def __post_init__(self) -> None:
        names = [b.name for b in self.bodies] + ([self.floor.name] if self.floor else [])
        if len(set(names)) != len(names):
            raise ValueError(f"two bodies share a name: {sorted(names)}")

    def body(self, name: str) -> Body:
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(f"no body {name!r}")


MarkerKind = Literal["box", "boxes", "arrow", "path"]


@dataclass(frozen=True)
class Marker:
    """How one sampled value is drawn: in ``layer`` (one batch, one count), a ``box`` of
    ``size``, a compound of ``parts`` (``(centre, size)`` boxes in the marker's frame, e.g. a
    gripper), an ``arrow`` on the floor along the marker's x axis, or a ``path`` through
    ``points``. Every marker of one layer must be of one kind (and, for ``boxes``, one set of
    parts)."""

    layer: str
    kind: MarkerKind
    position: Vec3 = (0.0, 0.0, 0.0)
    quat: Quat = IDENTITY
    size: Vec3 = (0.05, 0.05, 0.05)
    parts: tuple[tuple[Vec3, Vec3], ...] = ()
    points: tuple[Vec3, ...] = ()
    translucent: bool = False

    def __post_init__(self) -> None:
        if not self.layer or "/" in self.layer:
            raise ValueError(f"a marker layer must be non-empty without '/', got {self.layer!r}")
        _finite(self.position, "marker position")
        _finite(self.quat, "marker quat")
        if self.kind == "path" and not self.points:
            raise ValueError("a path marker needs points")
        if self.kind == "boxes" and not self.parts:
            raise ValueError("a boxes marker needs parts")


@dataclass(frozen=True)
class QueryView:
    """A query as the view reads it from its events: the stream, its input values (decoded
    with the domain's value types) and, for a success, its outputs."""

    stream: str
    inputs: tuple[Any, ...]
    outputs: tuple[Any, ...] = ()


@dataclass(frozen=True)
class BodyState:
    """Where a body is at one moment of a plan. ``attached`` puts it relative to a link of
    another body instead: ``(body, link, position, quat)``, e.g. a block in a gripper."""

    position: Vec3 = (0.0, 0.0, 0.0)
    quat: Quat = IDENTITY
    joints: Mapping[str, float] | None = None  # URDF bodies
    visible: bool = True
    attached: tuple[str, str, Vec3, Quat] | None = None


class Timeline(Protocol):
    """A bound plan in time: the state of every body that moves, at any second. A timeline
    may also carry ``steps`` (:class:`ActionSteps`): when each action starts, so the view can
    say which one plays."""

    @property
    def duration(self) -> float: ...

    def at(self, t: float) -> Mapping[str, BodyState]:
        """Body name -> state ``t`` seconds into the plan (bodies not named keep their start
        pose)."""
        ...


@dataclass(frozen=True)
class ActionSteps:
    """When each action of a plan starts (seconds into it) and its text, ``(move q0 q1 t1)``;
    an action that takes no time starts where the next one does."""

    starts: tuple[float, ...]
    labels: tuple[str, ...]

    def __post_init__(self) -> None:
        if len(self.starts) != len(self.labels):
            raise ValueError("action steps need as many labels as starts")
        if any(b < a for a, b in zip(self.starts, self.starts[1:], strict=False)):
            raise ValueError("action start times must not decrease")

    def at(self, t: float) -> tuple[int, str] | None:
        """``(index, text)`` of the action playing ``t`` seconds into the plan (the last one
        started by then: of several starting at once, the one that takes time), None before
        the first."""
        import bisect

        i = bisect.bisect_right(self.starts, t) - 1
        if i < 0:
            return None if not self.starts else (0, self.labels[0])
        return i, self.labels[i]


@dataclass(frozen=True)
class Keyframes:
    """A :class:`Timeline` from keyframes: each body moves in a straight line (and turns by
    the shortest rotation) between its states at consecutive keyframe times; joints are
    interpolated; ``visible`` and ``attached`` switch at the keyframe."""

    times: tuple[float, ...]
    states: tuple[Mapping[str, BodyState], ...]
    steps: ActionSteps | None = None  # which action plays when

    def __post_init__(self) -> None:
        if len(self.times) != len(self.states) or not self.times:
            raise ValueError("keyframes need as many states as times, and at least one")
        if any(b < a for a, b in zip(self.times, self.times[1:], strict=False)):
            raise ValueError("keyframe times must not decrease")

    @property
    def duration(self) -> float:
        return self.times[-1]

    def at(self, t: float) -> Mapping[str, BodyState]:
        import bisect

        if t <= self.times[0]:
            return self.states[0]
        if t >= self.times[-1]:
            return self.states[-1]
        j = bisect.bisect_right(self.times, t) - 1
        t0, t1 = self.times[j], self.times[j + 1]
        f = 0.0 if t1 <= t0 else (t - t0) / (t1 - t0)
        a, b = self.states[j], self.states[j + 1]
        out: dict[str, BodyState] = {}
        for name, sa in a.items():
            sb = b.get(name)
            if sb is None or sa.attached != sb.attached or sa.visible != sb.visible:
                out[name] = sa
                continue
            joints = sa.joints
            if sa.joints is not None and sb.joints is not None:
                joints = {k: v + f * (sb.joints.get(k, v) - v) for k, v in sa.joints.items()}
            position = (
                sa.position[0] + f * (sb.position[0] - sa.position[0]),
                sa.position[1] + f * (sb.position[1] - sa.position[1]),
                sa.position[2] + f * (sb.position[2] - sa.position[2]),
            )
            quat = _slerp(sa.quat, sb.quat, f)
            out[name] = BodyState(position, quat, joints, sa.visible, sa.attached)
        return out


def _slerp(a: Quat, b: Quat, f: float) -> Quat:
    dot = sum(x * y for x, y in zip(a, b, strict=True))
    if dot < 0:
        b, dot = (-b[0], -b[1], -b[2], -b[3]), -dot
    if dot > 0.9995:
        q = tuple(x + f * (y - x) for x, y in zip(a, b, strict=True))
    else:
        theta = math.acos(min(1.0, dot))
        s = math.sin(theta)
        wa, wb = math.sin((1 - f) * theta) / s, math.sin(f * theta) / s
        q = tuple(wa * x + wb * y for x, y in zip(a, b, strict=True))
    n = math.sqrt(sum(x * x for x in q)) or 1.0
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


class DomainView(Protocol):
    """A domain's 3D view hook (see the module docstring). Every method may raise for bad data
    (ValueError, KeyError, TypeError): the view logs it and draws what it can."""

    def scene(self, problem: Problem) -> SceneView: ...

    def markers(self, query: QueryView, problem: Problem) -> Sequence[Marker]:
        """Ghosts of a successful query's outputs (empty: nothing to draw)."""
        ...

    def failure_at(self, query: QueryView, problem: Problem) -> Vec3 | None:
        """Where a failed query was about (None: not drawn)."""
        ...

    def animate(
        self, actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
    ) -> Timeline | None:
        """The bound plan (actions over objects, objects' decoded values) in time; None when
        the domain has nothing to play."""
        ...


@dataclass(frozen=True)
class Focus:
    """Where one selected search node puts the bodies (e.g. the robot at the configuration the
    node bound), and markers to draw highlighted besides the node's own ghosts."""

    bodies: Mapping[str, BodyState] = field(default_factory=dict)
    markers: tuple[Marker, ...] = ()


@runtime_checkable
class FocusView(Protocol):
    """The optional part of a :class:`DomainView` that poses the scene at a search node."""

    def focus(self, branch: Sequence[QueryView], problem: Problem) -> Focus:
        """The scene at the node whose branch (from its stream plan down to the node, the
        successful queries in order) is ``branch``."""
        ...
