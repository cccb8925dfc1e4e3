"""The viser 3D view of a run: the domain's scene, its search tree drawn where it means something,
and the bound plan played in real time.

The dashboard server makes one :class:`RunViewer` at start-up and calls it from ordinary threads:
:meth:`RunViewer.show` resets the view to a run after the first ``k`` events (the page's step),
:meth:`RunViewer.extend` adds live events of that run. Nothing it is given raises into the caller:
bad data is logged and skipped. What is drawn (docs/viewer.md) comes from the domain's view hook
(``DomainSpec.view``, :mod:`planner.view`); a domain without one gets the note "There is no 3D
view for this domain":

- the scene's bodies (boxes, mesh files through trimesh, URDFs' visual meshes posed by yourdfpy)
  at their start poses, with their labels, on the scene's floor (or a grid);
- every successful sample as the hook's markers (ghosts), in its layers, coloured by the node's
  predicted cost ``Q`` (green low, red high, grey without a prediction); failed queries as red
  diamonds where they were about;
- the tree's shape as a node-link drawing on a panel beyond the scene, the solution's branch in
  blue;
- once the events hold ``solution_found`` and the run's plan file is given, the hook's timeline
  plays (Play/Pause and a time slider in the GUI);
- the node the page selected: its ghosts highlighted (its ancestors' too, in another colour),
  labelled, and the bodies where the hook's ``focus`` puts them (the robot at the node's
  configuration); a click on a ghost names its node (``picked``), which the page then selects.
"""

from __future__ import annotations

import contextlib
import functools
import io
import itertools
import logging
import math
import threading
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import trimesh
import viser

from app.viewer_search import Ghost, SearchFold, tree_layout
from planner import figures
from planner.domains import LoadedDomain, problem_for_scene
from planner.pddl.structs import Problem
from planner.plans import PlanFileError, parse_plan
from planner.scene import SceneError
from planner.sim.transforms import Pose, multiply, to_wxyz
from planner.view import (
    IDENTITY,
    ActionSteps,
    Body,
    BodyState,
    Box,
    FocusView,
    Marker,
    Mesh,
    Meshes,
    Rgb,
    SceneView,
    Timeline,
    Urdf,
    Vec3,
)

log = logging.getLogger(__name__)

TICK_S = 1 / 20  # the animation and deferred redraws run at 20 Hz
REDRAW_S = 0.25  # live events are drawn at most this often
REDRAW_LOAD = 5  # and a redraw that took s seconds waits at least 5 s before the next
MAX_GHOSTS = 2000  # ghosts drawn per layer (the latest); the GUI says when some are left out
MAX_PATHS = 500  # paths drawn per layer (the latest)
GHOST_OPACITY = 0.45  # translucent markers
FAILED_RGB = (230, 20, 20)  # failed queries, in the scene and in the tree drawing
SOLUTION_RGB = (40, 110, 230)  # the solution's branch in the tree drawing
FOCUS_RGB = (225, 0, 190)  # the selected node's own ghosts
BRANCH_RGB = (0, 190, 230)  # the ghosts of the selected node's ancestors
LOOK_DISTANCE = 1.4  # metres from the selected node's ghost, "Look at the selected node"
ROOT_RGB = (90, 90, 90)  # the tree's root
PANEL_GAP = 1.0  # the tree drawing stands this far beyond the farthest body, metres
PANEL_HEIGHT = 1.6  # its height, metres
PANEL_TOP = 2.3  # the height of its root above the floor (SceneView.floor_z), metres
PANEL_MIN_WIDTH = 2.4  # its least width, metres
MAX_LEVEL_STEP = 0.3  # the most height between tree levels, metres
SLIDER_STEP = 0.1  # seconds
NO_VIEW = "There is no 3D view for this domain"
SPEEDS = ("0.5x", "1x", "2x", "5x", "10x", "20x")  # the plan's playback speeds
DEFAULT_SPEED = "1x"
# Layers a user can hide besides the domain's ghost layers (each gets a checkbox when it
# first has ghosts): the failed queries' diamonds and the tree's panel.
FIXED_LAYERS = (("failed", "failed queries (red diamonds)"), ("tree", "the search tree panel"))
FRAME_MARGIN = 1.15  # "Frame the scene" leaves this much room around what it frames


@dataclass(frozen=True)
class _Panel:
    """Where the tree drawing stands: a vertical plane facing the scene's start."""

    x: float
    y_left: float  # the first leaf's y (the panel runs towards -y)
    width: float
    top: float
    height: float


@dataclass(frozen=True)
class Picked:
    """The ghost last clicked in the 3D view: its node, the run it was clicked in, and how many
    clicks there were."""

    node_id: int
    label: str
    count: int
    run_id: str | None = None


class _BodyView:
    """One scene body in viser: a frame carrying its shape (a URDF's links below the frame)."""

    def __init__(self, server: viser.ViserServer, body: Body) -> None:
        self.body = body
        self.urdf: _UrdfView | None = None
        name = f"/scene/bodies/{body.name}"
        scene = server.scene
        shape = body.shape
        self.frame = scene.add_frame(name, show_axes=False)
        bounds: tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]] | None = None
        if isinstance(shape, Box):
            scene.add_box(
                f"{name}/shape",
                color=body.color,
                dimensions=shape.size,
                opacity=body.opacity,
            )
            half = np.array(shape.size, dtype=np.float64) / 2
            bounds = (-half, half)
        elif isinstance(shape, Urdf):
            self.urdf = _UrdfView(server, shape.path, name)
        else:
            parts = shape.parts if isinstance(shape, Meshes) else (shape,)
            for i, part in enumerate(parts):
                mesh = _load_mesh(part, body.color)
                scene.add_mesh_trimesh(f"{name}/shape{i}", mesh, scale=part.scale)
                lo, hi = (np.asarray(b, dtype=np.float64) * part.scale for b in mesh.bounds)
                if bounds is not None:
                    lo, hi = np.minimum(bounds[0], lo), np.maximum(bounds[1], hi)
                bounds = (lo, hi)
        if body.label:
            top = float(bounds[1][2]) + 0.05 if bounds is not None else 0.3
            scene.add_label(
                f"{name}/label",
                body.label,
                position=(0.0, 0.0, top),
                font_screen_scale=0.7,
                anchor="bottom-center",
            )
        self.corners = _corners((body.position, body.quat), bounds)
        self.pose: Pose = (body.position, body.quat)
        self.set(BodyState(body.position, body.quat, _urdf_joints(body)))

    def set(self, state: BodyState) -> None:
        self.pose = (state.position, state.quat)
        self.frame.position = state.position
        self.frame.wxyz = to_wxyz(state.quat)
        self.frame.visible = state.visible
        if self.urdf is not None and state.joints is not None:
            self.urdf.update(state.joints)

    def link_pose(self, link: str) -> Pose:
        """A link's pose in the world (a URDF body's link; the body's own pose otherwise)."""
        if self.urdf is None:
            return self.pose
        return multiply(self.pose, self.urdf.link_pose(link))


class _UrdfView:
    """A URDF's visual meshes in viser: a frame per link that has any, below the body's frame,
    placed by yourdfpy's forward kinematics. (``viser.extras.ViserUrdf`` does the same but
    drops the meshes' normals, so every mesh would be drawn faceted.)"""

    def __init__(self, server: viser.ViserServer, path: Path, root: str) -> None:
        import yourdfpy  # type: ignore[import-untyped]  # viser's URDF loader (viser[urdf])

        self.urdf = yourdfpy.URDF.load(str(path))
        self.joints: tuple[str, ...] = tuple(self.urdf.actuated_joint_names)
        self.frames: dict[str, viser.FrameHandle] = {}
        graph = self.urdf.scene.graph
        for geometry, mesh in self.urdf.scene.geometry.items():
            link = graph.transforms.parents[geometry]
            if link not in self.frames:
                self.frames[link] = server.scene.add_frame(f"{root}/{link}", show_axes=False)
            placed = mesh.copy()
            placed.apply_transform(self.urdf.get_transform(geometry, link))
            _ = placed.vertex_normals  # computed now, so the GLB carries them
            server.scene.add_mesh_trimesh(f"{root}/{link}/{geometry}", placed)

    def update(self, joints: Mapping[str, float]) -> None:
        self.urdf.update_cfg(np.array([joints.get(j, 0.0) for j in self.joints]))
        for link, frame in self.frames.items():
            position, quat = self.link_pose(link)
            frame.position = position
            frame.wxyz = to_wxyz(quat)

    def link_pose(self, link: str) -> Pose:
        """A link's pose relative to the URDF's root."""
        m = np.asarray(self.urdf.get_transform(link, self.urdf.base_link), dtype=np.float64)
        return _pose_from_matrix(m)


def _load_mesh(part: Mesh, color: Rgb) -> trimesh.Trimesh:
    """A mesh file, in the part's colour (else the body's) unless it has colours of its own."""
    mesh = trimesh.load(str(part.path), force="mesh")
    if not isinstance(mesh, trimesh.Trimesh):
        raise ValueError(f"{part.path} is not a single mesh")
    if mesh.visual is None or not mesh.visual.defined:
        rgb = part.color or color
        mesh.visual = trimesh.visual.ColorVisuals(mesh, face_colors=(*rgb, 255))
    _ = mesh.vertex_normals  # computed now, so the GLB carries them (else it is drawn faceted)
    return mesh


def _corners(
    pose: Pose, bounds: tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]] | None
) -> list[Vec3]:
    """The corners of a body's box of ``bounds`` (in its frame) in the world; its position
    alone without bounds."""
    if bounds is None:
        return [pose[0]]
    lo, hi = bounds
    local = [(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    return [multiply(pose, ((float(x), float(y), float(z)), IDENTITY))[0] for x, y, z in local]


def _urdf_joints(body: Body) -> Mapping[str, float] | None:
    return body.shape.joints if isinstance(body.shape, Urdf) else None


class RunViewer:
    """One viser server showing one run at a time (thread-safe: one internal lock)."""

    def __init__(self, host: str = "127.0.0.1", port: int = 8080) -> None:
        self._host = host
        self._lock = threading.RLock()
        # viser prints a banner naming its own port, which only the gate (app/viewgate.py)
        # reaches: `tamp serve` names the one address a user opens.
        banner = io.StringIO()
        with contextlib.redirect_stdout(banner):
            self._server = viser.ViserServer(host=host, port=port, verbose=False)
        log.debug("viser: %s", banner.getvalue().strip())
        self._server.scene.set_up_direction("+z")
        gui = self._server.gui
        # A narrow panel: the view stands beside the page's tree. No share button: a run's
        # scene is not for a public tunnel.
        gui.configure_theme(control_width="small", show_share_button=False)
        self._status = gui.add_markdown("No run shown yet.")
        with gui.add_folder("Camera"):
            self._frame_button = gui.add_button("Frame the scene", icon=viser.Icon.FOCUS_2)
            self._reset_button = gui.add_button("Reset the camera", icon=viser.Icon.HOME)
        with gui.add_folder("Plan"):
            self._play = gui.add_button("Play", icon=viser.Icon.PLAYER_PLAY, disabled=True)
            self._time = gui.add_slider(
                "Time (s)", min=0.0, max=1.0, step=SLIDER_STEP, initial_value=0.0, disabled=True
            )
            self._speed = gui.add_dropdown("Speed", SPEEDS, initial_value=DEFAULT_SPEED)
            self._plan_note = gui.add_markdown("No plan yet.")
        with gui.add_folder("Layers") as self._layers_folder:
            self._legend = gui.add_markdown(_legend_text(None))
        self._toggles: dict[str, viser.GuiCheckboxHandle] = {}
        for layer, label in FIXED_LAYERS:
            self._toggle(layer, label)
        with gui.add_folder("Selected node"):
            self._selection = gui.add_markdown(
                "Select a node in the page's tree, or click a ghost."
            )
            self._look = gui.add_checkbox("Look at the selected node", initial_value=False)
        self._play.on_click(self._on_play)
        self._time.on_update(self._on_seek)
        self._speed.on_update(lambda _: self._on_speed())
        self._look.on_update(lambda _: self._look_at_focus())
        self._frame_button.on_click(lambda _: self.frame())
        self._reset_button.on_click(lambda _: self.reset_camera())
        self._key: tuple[str, int, str | None] | None = None  # (scene, seed, domain) built
        self._run: str | None = None  # the run shown: its own picks, selection and camera
        self._home: tuple[Vec3, Vec3] | None = None  # the scene's camera (position, look at)
        self._scene = ""
        self._note = ""  # why there is no 3D view of the scene shown, if there is none
        self._steps = 0  # events shown of a scene without a 3D view
        self._loaded: LoadedDomain | None = None
        self._problem: Problem | None = None
        self._view: SceneView | None = None
        self._panel: _Panel | None = None
        self._fold: SearchFold | None = None
        self._bodies: dict[str, _BodyView] = {}
        self._groups: dict[str, viser.FrameHandle] = {}
        self._layers: dict[str, viser.SceneNodeHandle] = {}
        self._shown: dict[str, int] = _nothing_shown()  # instances drawn, as counts names them
        self._anim: Timeline | None = None
        self._plan: Mapping[str, Any] | None = None
        self._t = 0.0
        self._playing = False
        self._dirty = False
        self._drawn_at = 0.0
        self._focus: int | None = None  # the node the page selected
        self._focus_bodies: Mapping[str, BodyState] = {}  # where it puts the bodies
        self._focus_at: Vec3 | None = None  # where its first ghost (or failure) is
        self._picked: Picked | None = None
        self._closed = False
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._tick, name="run-viewer", daemon=True)
        self._thread.start()
        log.info("3D viewer at %s", self.url)

    # --- public --------------------------------------------------------------------------------

    @property
    def url(self) -> str:
        host = "127.0.0.1" if self._host in ("", "0.0.0.0", "::") else self._host
        return f"http://{host}:{self._server.get_port()}"

    @property
    def counts(self) -> dict[str, int]:
        """What the view shows (anything not drawn yet is drawn first): events folded, tree
        nodes (the root included), failed queries and how many are marked in the scene, ghosts
        drawn per layer, ghosts left out by the caps, model predictions, malformed events
        skipped."""
        with self._lock:
            fold = self._fold
            if fold is None:
                return {"events": self._steps, "nodes": 0, "failed": 0, "failed_marked": 0}
            if self._dirty:
                self._draw()
            total = sum(len(g) for g in fold.ghosts.values())
            drawn = sum(self._shown.get(layer, 0) for layer in fold.ghosts)
            return {
                "events": fold.events,
                "nodes": fold.trace.shown,
                "failed": fold.failed,
                "predictions": len(fold.trace.predictions()),
                "skipped": fold.skipped,
                "hidden": total - drawn,
                "focus": -1 if self._focus is None else self._focus,
                "focus_bodies": len(self._focus_bodies),
                **self._shown,
            }

    @property
    def note(self) -> str:
        """Why the scene shown has no 3D view ("" when it has one)."""
        with self._lock:
            return self._note

    @property
    def plan_seconds(self) -> float | None:
        """Duration of the plan being animated, None without one."""
        with self._lock:
            return None if self._anim is None else self._anim.duration

    @property
    def picked(self) -> Picked | None:
        """The node of the ghost last clicked, if any."""
        with self._lock:
            return self._picked

    @property
    def focus_bodies(self) -> dict[str, BodyState]:
        """Where the selected node puts the bodies (empty without one, or a hook to say)."""
        with self._lock:
            return dict(self._focus_bodies)

    @property
    def playhead(self) -> float:
        """Seconds into the plan the scene is shown at."""
        with self._lock:
            return self._t

    def show(
        self,
        scene: str,
        seed: int,
        events: Sequence[Mapping[str, Any]],
        plan: Mapping[str, Any] | None,
        *,
        domain: str | None = None,
        focus: int | None = None,
        run_id: str | None = None,
    ) -> None:
        """Reset the view to this run: build the scene (if it changed) and draw the state after
        exactly ``events`` (the page's current step). ``plan`` is the run's bound plan file dict
        when solved (else None); ``domain`` the run's domain reference (its folder, or None);
        ``focus`` the search node the page selected (None: none); ``run_id`` the run (another
        run than the one shown forgets the ghost clicked, puts the plan back at its start and
        every camera where the scene starts)."""
        with self._lock:
            if self._closed:
                return
            try:
                other_run = run_id != self._run or (scene, seed, domain) != self._key
                self._run = run_id
                if other_run:
                    self._picked = None
                    self._t = 0.0
                    self._playing = False
                self._focus = focus
                self._show(scene, seed, events, plan, domain)
                if other_run:
                    self.reset_camera()
            except Exception:
                log.exception("viewer: could not show scene %r (seed %r)", scene, seed)
                self._set_status(f"The 3D view could not show **{scene}**; see the server log.")

    def extend(self, events: Sequence[Mapping[str, Any]]) -> None:
        """More live events of the run currently shown (appended after the ones already drawn)."""
        with self._lock:
            if self._closed or self._key is None:
                return
            try:
                if self._fold is None:
                    self._steps += len(events)
                    self._set_status(self._note_text())
                    return
                for event in events:
                    self._fold.fold(event)
                self._dirty = True
                if time.perf_counter() - self._drawn_at >= REDRAW_S:
                    self._draw()
            except Exception:
                log.exception("viewer: could not add %d live events", len(events))

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            self._playing = False
        self._stop.set()
        self._thread.join(timeout=5.0)
        with contextlib.redirect_stdout(io.StringIO()):  # viser says it stopped, on stdout
            self._server.stop()
        log.info("3D viewer stopped")

    # --- showing a run -------------------------------------------------------------------------

    def _show(
        self,
        scene: str,
        seed: int,
        events: Sequence[Mapping[str, Any]],
        plan: Mapping[str, Any] | None,
        domain: str | None,
    ) -> None:
        if (scene, seed, domain) != self._key:
            self._load(scene, seed, domain)
        if self._loaded is None or self._problem is None:
            self._steps = len(events)
            self._set_status(self._note_text())
            return
        fold = SearchFold(self._loaded, self._problem, self._loaded.spec.view)
        for event in events:
            fold.fold(event)
        self._fold = fold
        self._set_plan(scene, seed, plan)
        self._draw()

    def _load(self, scene: str, seed: int, domain: str | None) -> None:
        """Forget what was built and build the scene (or note why there is none)."""
        for name in list(self._layers):  # the selection's labels too: not under a group
            self._drop(name)
        for group in self._groups.values():
            group.remove()
        self._groups.clear()
        self._home = None
        self._bodies.clear()
        self._shown = _nothing_shown()
        self._loaded = self._problem = self._view = None
        self._panel = self._fold = self._anim = self._plan = None
        self._playing = False
        self._t = 0.0
        self._update_plan_gui()
        self._key = (scene, seed, domain)
        self._scene = scene
        self._note = ""
        try:
            loaded, problem = problem_for_scene(scene, seed=seed, domain=domain)
        except (SceneError, OSError, TypeError, ValueError) as exc:
            log.warning("viewer: no 3D view of scene %r (seed %r): %s", scene, seed, exc)
            self._note = f"No 3D view: {exc}"
            return
        hook = loaded.spec.view
        if hook is None:
            self._note = f"{NO_VIEW} (**{loaded.name}** describes no scene to draw)."
            return
        try:
            view = hook.scene(problem)
        except (KeyError, TypeError, ValueError) as exc:
            log.warning("viewer: the %s domain cannot describe %r: %s", loaded.name, scene, exc)
            self._note = f"No 3D view: {exc}"
            return
        self._loaded, self._problem, self._view = loaded, problem, view
        self._build(view)

    def _build(self, view: SceneView) -> None:
        scene = self._server.scene
        for name in ("scene", "search", "tree"):
            self._groups[name] = scene.add_frame(f"/{name}", show_axes=False)
        for body in view.bodies:
            try:
                self._bodies[body.name] = _BodyView(self._server, body)
            except (ImportError, OSError, ValueError) as exc:
                log.warning("viewer: cannot show body %s (%s); showing the rest", body.name, exc)
        lo, hi = _bounds(view.bodies, self._bodies)
        cx, cy = (lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2
        if view.floor is not None:
            try:
                _BodyView(self._server, view.floor)
            except (OSError, ValueError) as exc:
                log.warning("viewer: cannot show the floor (%s)", exc)
        else:
            span = max(hi[0] - lo[0], hi[1] - lo[1]) + 3.0
            scene.add_grid(
                "/scene/floor",
                width=span + PANEL_GAP * 2,
                height=span,
                position=(cx + PANEL_GAP, cy, view.floor_z),
                cell_size=0.25,
                section_size=1.0,
                plane_color=(236, 236, 232),
                plane_opacity=0.0,
            )
        width = max(PANEL_MIN_WIDTH, hi[1] - lo[1])
        top = view.floor_z + PANEL_TOP
        self._panel = _Panel(hi[0] + PANEL_GAP, cy + width / 2, width, top, PANEL_HEIGHT)
        camera = self._server.initial_camera
        if view.camera is not None:
            self._home = view.camera
        else:
            self._home = (
                (lo[0] - 1.9, cy - 1.5, max(2.4, hi[2] + 1.5)),
                (cx + 0.5, cy, (lo[2] + hi[2]) / 2),
            )
        camera.position, camera.look_at = self._home

    def _note_text(self) -> str:
        return f"**{self._scene}** · {self._steps} events\n\n{self._note}"

    # --- the plan ------------------------------------------------------------------------------

    def _set_plan(self, scene: str, seed: int, plan: Mapping[str, Any] | None) -> None:
        fold, loaded, problem = self._fold, self._loaded, self._problem
        anim: Timeline | None = None
        hook = loaded.spec.view if loaded is not None else None
        if (
            plan is not None
            and fold is not None
            and hook is not None
            and problem is not None
            and loaded is not None
            and fold.trace.solution is not None
        ):
            if plan.get("scene", scene) != scene or plan.get("seed", seed) != seed:
                log.warning(
                    "viewer: the plan is for %r seed %r, not %r seed %r; not animating it",
                    plan.get("scene"),
                    plan.get("seed"),
                    scene,
                    seed,
                )
            else:
                try:
                    parsed = parse_plan(dict(plan), "the run's plan")
                    values = parsed.decoded_values(loaded)
                    anim = hook.animate(parsed.actions, values, problem)
                except (PlanFileError, KeyError, TypeError, ValueError) as exc:
                    log.warning("viewer: cannot animate the plan: %s", exc)
        if anim is None or self._anim is None or plan != self._plan:
            self._t = 0.0
            self._playing = False
        self._anim = anim
        self._plan = plan if anim is not None else None
        self._update_plan_gui()
        self._pose_bodies()

    def _update_plan_gui(self) -> None:
        anim = self._anim
        self._play.disabled = anim is None
        self._play.label = "Pause" if self._playing else "Play"
        self._play.icon = viser.Icon.PLAYER_PAUSE if self._playing else viser.Icon.PLAYER_PLAY
        self._time.disabled = anim is None
        if anim is None:
            found = self._fold is not None and self._fold.trace.solution is not None
            _set_markdown(
                self._plan_note,
                "A plan was found; it plays here once its plan file is given."
                if found
                else "No plan yet.",
            )
            _set_slider(self._time, 0.0)
            return
        steps = max(math.ceil(anim.duration / SLIDER_STEP), 1)
        self._time.max = round(steps * SLIDER_STEP, 6)  # 28.4, not 28.400000000000002
        _set_slider(self._time, min(self._t, anim.duration))
        _set_markdown(self._plan_note, self._plan_text())

    def _on_play(self, _: viser.GuiEvent[viser.GuiButtonHandle]) -> None:
        with self._lock:
            if self._anim is None or self._closed:
                return
            if not self._playing and self._t >= self._anim.duration:
                self._t = 0.0
            self._playing = not self._playing
            self._update_plan_gui()

    def _on_speed(self) -> None:
        with self._lock:
            if not self._closed:
                _set_markdown(self._plan_note, self._plan_text())

    def set_speed(self, speed: str) -> None:
        """Play the plan at ``speed`` (one of SPEEDS), as the GUI's dropdown does."""
        if speed not in SPEEDS:
            raise ValueError(f"unknown speed {speed!r} (known: {', '.join(SPEEDS)})")
        with self._lock:
            self._speed.value = speed  # type: ignore[misc]  # hidden from mypy
            _set_markdown(self._plan_note, self._plan_text())

    def _on_seek(self, event: viser.GuiEvent[viser.GuiSliderHandle[float]]) -> None:
        if event.client is None:  # our own update of the slider
            return
        with self._lock:
            if self._anim is None or self._closed:
                return
            self._t = min(max(0.0, float(self._time.value)), self._anim.duration)
            self._pose_bodies()
            _set_markdown(self._plan_note, self._plan_text())

    def _plan_text(self) -> str:
        """The plan's length, the speed it plays at, and the action playing now."""
        anim = self._anim
        if anim is None:
            return "No plan yet."
        speed = self._speed.value
        lines = [
            f"Plan: {anim.duration:.1f} s of motion, played "
            + ("in real time." if speed == "1x" else f"at {speed}.")
        ]
        now = self.action
        if now is not None:
            steps = getattr(anim, "steps", None)
            total = len(steps.labels) if isinstance(steps, ActionSteps) else 0
            lines.append(f"Now: action {now[0] + 1} of {total}, `{now[1]}`")
        return "\n\n".join(lines)

    @property
    def action(self) -> tuple[int, str] | None:
        """The action of the plan playing at the playhead (its index and text), if the
        domain's timeline says."""
        with self._lock:
            steps = getattr(self._anim, "steps", None)
            return steps.at(self._t) if isinstance(steps, ActionSteps) else None

    def _speed_factor(self) -> float:
        return float(str(self._speed.value).removesuffix("x"))

    def _advance(self, dt: float) -> None:
        anim = self._anim
        if anim is None:
            self._playing = False
            return
        self._t = min(self._t + dt * self._speed_factor(), anim.duration)
        if self._t >= anim.duration:
            self._playing = False
            self._update_plan_gui()
        _set_slider(self._time, round(self._t, 3))
        self._pose_bodies()
        _set_markdown(self._plan_note, self._plan_text())

    def _tick(self) -> None:
        last = time.perf_counter()
        while not self._stop.wait(TICK_S):
            now = time.perf_counter()
            with self._lock:
                if self._closed:
                    return
                try:
                    if self._playing:
                        self._advance(now - last)
                    if self._dirty and now - self._drawn_at >= REDRAW_S:
                        self._draw()
                except Exception:
                    log.exception("viewer: the animation or a redraw failed")
                    self._playing = False
            last = now

    def _pose_bodies(self) -> None:
        """Put every body where the plan has it at the playhead (at its start without a plan):
        free bodies first, then those attached to a link of another."""
        view = self._view
        if view is None or not self._bodies:
            return
        states: dict[str, BodyState] = {
            b.name: BodyState(b.position, b.quat, _urdf_joints(b)) for b in view.bodies
        }
        if self._anim is not None:
            states.update(self._anim.at(self._t))
        if not self._playing:
            states.update(self._focus_bodies)  # the selected node, until the plan plays
        with self._server.atomic():
            attached = []
            for name, state in states.items():
                handle = self._bodies.get(name)
                if handle is None:
                    continue
                if state.attached is not None:
                    attached.append((handle, state))
                else:
                    handle.set(state)
            for handle, state in attached:
                assert state.attached is not None
                parent_name, link, position, quat = state.attached
                parent = self._bodies.get(parent_name)
                if parent is None:
                    continue
                where = multiply(parent.link_pose(link), (position, quat))
                handle.set(BodyState(where[0], where[1], state.joints, state.visible))

    # --- drawing the search --------------------------------------------------------------------

    def _draw(self) -> None:
        fold = self._fold
        self._dirty = False
        start = time.perf_counter()
        if fold is not None:
            with self._server.atomic():
                for layer, ghosts in fold.ghosts.items():
                    self._shown[layer] = self._draw_layer(fold, layer, ghosts)
                # A layer drawn before that this state has no ghosts in at all (the page
                # stepped back to before its first) goes.
                for name in [n for n in self._layers if n.startswith("/search/")]:
                    layer = _layer_of(name)
                    if layer != "failed" and layer not in fold.ghosts:
                        self._drop(name)
                        self._shown.pop(layer, None)
                self._shown["failed_marked"] = self._draw_failures(fold)
                self._shown["tree_nodes"] = self._draw_tree(fold)
                self._draw_focus(fold)
                for layer in fold.ghosts:
                    self._toggle(layer, f"{layer} ghosts")
                self._apply_visibility()
            self._set_status(self._status_text(fold))
            _set_markdown(self._legend, _legend_text(fold))
            if fold.trace.solution is not None and self._anim is None:
                self._update_plan_gui()
        # A big tree takes a while to draw: live redraws then come less often.
        spent = time.perf_counter() - start
        self._drawn_at = start + max(0.0, REDRAW_LOAD * spent - REDRAW_S)

    @staticmethod
    def _drawn(ghosts: list[Ghost]) -> list[Ghost]:
        kind = ghosts[0].marker.kind if ghosts else "box"
        return ghosts[-(MAX_PATHS if kind == "path" else MAX_GHOSTS) :]

    def _draw_layer(self, fold: SearchFold, layer: str, all_ghosts: list[Ghost]) -> int:
        """Draw the latest ghosts of one layer, one batch per shape (a grasp's ghost is sized
        to its block), each clickable; returns how many."""
        ghosts = self._drawn(all_ghosts)
        groups: dict[tuple[str, tuple[Any, ...]], list[Ghost]] = {}
        for g in ghosts:
            groups.setdefault((g.marker.kind, g.marker.parts), []).append(g)
        names: list[str] = []
        for i, group in enumerate(groups.values()):
            name = f"/search/{layer}" if i == 0 else f"/search/{layer}~{i}"
            names.append(name)
            markers = [g.marker for g in group]
            opacity = GHOST_OPACITY if markers[0].translucent else None
            colors = fold.colors([g.node_id for g in group])
            handle = self._draw_markers(name, markers, colors, opacity)
            if isinstance(handle, viser.BatchedMeshHandle):  # viser picks meshes, not lines
                handle.on_click(functools.partial(self._on_pick, ghosts=group))
        for name in [n for n in self._layers if _layer_of(n) == layer and n.startswith("/search/")]:
            if name not in names:
                self._drop(name)
        return len(ghosts)

    # --- layers, the legend, the camera --------------------------------------------------------

    def _toggle(self, layer: str, label: str) -> None:
        """The checkbox that shows or hides ``layer`` (made once, the first time it is asked)."""
        if layer in self._toggles:
            return
        with self._layers_folder:
            box = self._server.gui.add_checkbox(label, initial_value=True)
        box.on_update(lambda _: self._on_toggle())
        self._toggles[layer] = box

    def _on_toggle(self) -> None:
        with self._lock:
            if not self._closed:
                self._apply_visibility()

    def _apply_visibility(self) -> None:
        for name, handle in self._layers.items():
            box = self._toggles.get(_layer_of(name))
            if box is not None:
                handle.visible = bool(box.value)

    @property
    def layers(self) -> dict[str, bool]:
        """Each layer a user can hide, and whether it is shown."""
        with self._lock:
            return {layer: bool(box.value) for layer, box in self._toggles.items()}

    def set_layer(self, layer: str, shown: bool) -> None:
        """Show or hide a layer, as its checkbox does (KeyError for an unknown one)."""
        with self._lock:
            self._toggles[layer].value = shown  # type: ignore[misc]  # hidden from mypy
            self._apply_visibility()

    def cameras(self) -> list[tuple[Vec3, Vec3]]:
        """Where each connected client's camera is and what it looks at."""
        out = []
        for client in self._server.get_clients().values():
            p, a = client.camera.position, client.camera.look_at
            out.append(
                ((float(p[0]), float(p[1]), float(p[2])), (float(a[0]), float(a[1]), float(a[2])))
            )
        return out

    def reset_camera(self) -> None:
        """Every client's camera where the scene starts (its view hook's camera)."""
        with self._lock:
            if self._home is not None:
                for client in self._server.get_clients().values():
                    _aim(client.camera, *self._home)

    def frame(self) -> None:
        """Every client's camera, from where it looks, pulled back to see the whole scene: the
        bodies, every ghost drawn and the tree's panel."""
        with self._lock:
            points = [c for b in self._bodies.values() for c in b.corners]
            if self._fold is not None:
                for ghosts in self._fold.ghosts.values():
                    points += [g.marker.position for g in self._drawn(ghosts)]
            panel = self._panel
            if panel is not None:
                points += [
                    (panel.x, panel.y_left, panel.top),
                    (panel.x, panel.y_left - panel.width, panel.top - panel.height),
                ]
            if not points:
                return
            lo, hi = np.min(points, axis=0), np.max(points, axis=0)
            centre = (lo + hi) / 2
            radius = max(float(np.linalg.norm(hi - lo)) / 2, 0.25)
            for client in self._server.get_clients().values():
                camera = client.camera
                direction = np.asarray(camera.position) - np.asarray(camera.look_at)
                norm = float(np.linalg.norm(direction)) or 1.0
                distance = FRAME_MARGIN * radius / math.sin(max(camera.fov, 0.1) / 2)
                eye = centre + direction / norm * distance
                _aim(camera, _vec(eye), _vec(centre))

    def _draw_markers(
        self,
        name: str,
        markers: Sequence[Marker],
        colors: npt.NDArray[np.uint8],
        opacity: float | None,
        *,
        thickness: float = 0.012,
        grow: float = 1.0,
    ) -> viser.BatchedMeshHandle | viser.LineSegmentsHandle:
        """Markers of one kind as one batch (line segments for paths), ``colors`` one row per
        marker, ``grow`` scaling each; kept under ``name``."""
        scene = self._server.scene
        kind = markers[0].kind
        if kind == "path":
            segments: list[tuple[Vec3, Vec3]] = []
            seg_colors: list[npt.NDArray[np.uint8]] = []
            for marker, color in zip(markers, colors, strict=True):
                pts = list(marker.points)
                if len(pts) == 1:
                    pts.append((pts[0][0] + 1e-3, pts[0][1], pts[0][2]))
                for a, b in itertools.pairwise(pts):
                    segments.append((a, b))
                    seg_colors.append(color)
            points = np.array(segments, dtype=np.float32)
            seg_rgb = np.repeat(np.array(seg_colors, dtype=np.uint8)[:, None, :], 2, axis=1)
            lines = scene.add_line_segments(name, points, seg_rgb, thickness=thickness)
            self._layers[name] = lines
            return lines
        positions = np.array([m.position for m in markers], dtype=np.float32)
        wxyzs = np.array([to_wxyz(m.quat) for m in markers], dtype=np.float32)
        scales = None
        if kind == "box":
            vertices, faces = _UNIT_BOX
            scales = np.array([m.size for m in markers], dtype=np.float32) * grow
        elif kind == "boxes":
            vertices, faces = _boxes(*markers[0].parts)
            scales = np.full((len(markers), 3), grow, dtype=np.float32) if grow != 1.0 else None
        else:
            vertices, faces = _ARROW
            scales = np.full((len(markers), 3), grow, dtype=np.float32) if grow != 1.0 else None
        handle = scene.add_batched_meshes_simple(
            name,
            vertices,
            faces,
            wxyzs,
            positions,
            batched_scales=scales,
            batched_colors=colors,
            opacity=opacity,
            side="double",
            cast_shadow=False,
            receive_shadow=False,
        )
        self._layers[name] = handle
        return handle

    # --- the selected node ---------------------------------------------------------------------

    def _draw_focus(self, fold: SearchFold) -> None:
        """Highlight the selected node: its ghosts, its ancestors' (another colour), a label,
        and the bodies where the domain's hook puts them."""
        for name in [n for n in self._layers if n.startswith("/focus/")]:
            self._drop(name)
        node = self._focus
        self._focus_bodies = {}
        self._focus_at = None
        if node is None or node not in fold.trace:
            self._shown["focus_markers"] = self._shown["branch_markers"] = 0
            _set_markdown(self._selection, self._selection_text(fold))
            self._pose_bodies()
            return
        hook = self._loaded.spec.view if self._loaded is not None else None
        own = fold.markers_of(node)
        branch = [m for n in fold.trace.branch(node)[:-1] for m in fold.markers_of(n)]
        if isinstance(hook, FocusView) and self._problem is not None:
            try:
                focus = hook.focus(fold.branch_queries(node), self._problem)
                self._focus_bodies = dict(focus.bodies)
                own += list(focus.markers)
            except (KeyError, TypeError, ValueError) as exc:
                log.warning("viewer: the domain cannot pose node %d: %s", node, exc)
        self._shown["focus_markers"] = self._draw_group("/focus/own", own, FOCUS_RGB, 1.08)
        self._shown["branch_markers"] = self._draw_group("/focus/branch", branch, BRANCH_RGB, 1.04)
        failure = next((f for f in fold.failures if f.node_id == node), None)
        where = own[0].position if own else (failure.where if failure else None)
        if own and own[0].kind == "path":
            where = own[0].points[len(own[0].points) // 2]
        self._focus_at = where
        if where is not None:
            self._layers["/focus/label"] = self._server.scene.add_label(
                "/focus/label",
                f"#{node} {fold.label(node)}",
                position=(where[0], where[1], where[2] + 0.12),
                anchor="bottom-center",
                font_screen_scale=0.8,
            )
        _set_markdown(self._selection, self._selection_text(fold))
        self._pose_bodies()
        if self._look.value:
            self._look_at_focus()

    def _draw_group(self, name: str, markers: Sequence[Marker], rgb: Rgb, grow: float) -> int:
        """Markers of any kinds, one batch per kind (and compound shape); returns how many."""
        groups: dict[tuple[str, tuple[Any, ...]], list[Marker]] = {}
        for m in markers:
            groups.setdefault((m.kind, m.parts), []).append(m)
        for i, group in enumerate(groups.values()):
            colors = np.tile(np.array(rgb, dtype=np.uint8), (len(group), 1))
            self._draw_markers(f"{name}{i}", group, colors, None, thickness=0.03, grow=grow)
        return len(markers)

    def _look_at_focus(self) -> None:
        """Turn every client's camera to the selected node's ghost (when asked to)."""
        with self._lock:
            where = self._focus_at
            if where is None or not self._look.value:
                return
            for client in self._server.get_clients().values():
                camera = client.camera
                direction = np.asarray(camera.position) - np.asarray(camera.look_at)
                norm = float(np.linalg.norm(direction)) or 1.0
                target = np.asarray(where, dtype=np.float64)
                eye = target + direction / norm * LOOK_DISTANCE
                _aim(camera, _vec(eye), _vec(target))

    def _on_pick(self, event: Any, *, ghosts: Sequence[Ghost]) -> None:
        """A click on a ghost of a layer: name its node (``event.instance_index``, else the
        ghost nearest the click's ray)."""
        with self._lock:
            fold = self._fold
            if fold is None or not ghosts:
                return
            index = getattr(event, "instance_index", None)
            if not isinstance(index, int) or not 0 <= index < len(ghosts):
                index = _nearest_to_ray(
                    [g.marker for g in ghosts], event.ray_origin, event.ray_direction
                )
            node = ghosts[index].node_id
            count = 1 if self._picked is None else self._picked.count + 1
            self._picked = Picked(node, fold.label(node), count, self._run)
            log.info("viewer: ghost of node %d clicked", node)
            _set_markdown(self._selection, self._selection_text(fold))

    def _selection_text(self, fold: SearchFold) -> str:
        lines = []
        if self._focus is not None:
            node = self._focus
            q = fold.trace[node].q if node in fold.trace else None
            lines.append(
                f"**node #{node}** · {fold.label(node, 'not in the tree at this step')}"
                + (f" · Q {q:.1f} s" if q is not None else "")
            )
            if self._focus_bodies:
                lines.append(
                    f"<small>bodies where it puts them: {', '.join(self._focus_bodies)}</small>"
                )
        else:
            lines.append("Select a node in the page's tree, or click a ghost.")
        if self._picked is not None:
            lines.append(
                f"clicked: ghost of **node #{self._picked.node_id}** · {self._picked.label}"
            )
        lines.append(
            "<small>magenta: the node's samples; cyan: its branch's; a click on a ghost names "
            "its node</small>"
        )
        return "\n\n".join(lines)

    def _draw_failures(self, fold: SearchFold) -> int:
        points = [f.where for f in fold.failures if f.where is not None][-MAX_GHOSTS:]
        name = "/search/failed"
        if not points:
            self._drop(name)
            return 0
        vertices, faces = _OCTAHEDRON
        n = len(points)
        self._layers[name] = self._server.scene.add_batched_meshes_simple(
            name,
            vertices,
            faces,
            np.tile(np.array([1.0, 0.0, 0.0, 0.0], dtype=np.float32), (n, 1)),
            np.array(points, dtype=np.float32),
            batched_colors=FAILED_RGB,
            cast_shadow=False,
            receive_shadow=False,
        )
        return n

    def _draw_tree(self, fold: SearchFold) -> int:
        """The tree's node-link drawing on its panel; returns the nodes drawn."""
        panel = self._panel
        layout = tree_layout(fold.trace)
        names = ("/tree/nodes", "/tree/edges", "/tree/solution", "/tree/title")
        if panel is None or not layout:
            for name in names:
                self._drop(name)
            return 0
        ids = list(layout)
        levels = max(level for _, level in layout.values())
        step = min(panel.height / max(levels, 1), MAX_LEVEL_STEP)
        where = {
            n: (panel.x, panel.y_left - a * panel.width, panel.top - level * step)
            for n, (a, level) in layout.items()
        }
        colors = fold.colors(ids)
        for i, n in enumerate(ids):
            node = fold.trace[n]
            if not node.success:
                colors[i] = FAILED_RGB
            elif node.parent is None:
                colors[i] = ROOT_RGB
        scene = self._server.scene
        self._layers["/tree/nodes"] = scene.add_point_cloud(
            "/tree/nodes",
            np.array([where[n] for n in ids], dtype=np.float32),
            colors,
            point_size=0.035,
            point_shape="circle",
            precision="float32",
        )
        color_of = dict(zip(ids, colors, strict=True))
        edges: list[tuple[tuple[float, float, float], tuple[float, float, float], int]] = []
        for n in ids:
            parent = fold.trace[n].parent
            if parent is not None and parent in where:
                edges.append((where[parent], where[n], n))
        if edges:
            self._layers["/tree/edges"] = scene.add_line_segments(
                "/tree/edges",
                np.array([(a, b) for a, b, _ in edges], dtype=np.float32),
                np.array([(color_of[n], color_of[n]) for _, _, n in edges], dtype=np.uint8),
                thickness=0.006,
            )
        else:
            self._drop("/tree/edges")
        path = [n for n in fold.trace.solution_path() if n in where]
        if len(path) > 1:
            self._layers["/tree/solution"] = scene.add_line_segments(
                "/tree/solution",
                np.array([(where[a], where[b]) for a, b in itertools.pairwise(path)]),
                SOLUTION_RGB,
                thickness=0.02,
            )
        else:
            self._drop("/tree/solution")
        self._layers["/tree/title"] = scene.add_label(
            "/tree/title",
            f"search tree: {fold.trace.shown} nodes, {fold.failed} failed",
            position=(panel.x, panel.y_left - panel.width / 2, panel.top + 0.15),
            anchor="bottom-center",
        )
        return len(ids)

    def _drop(self, name: str) -> None:
        handle = self._layers.pop(name, None)
        if handle is not None:
            handle.remove()

    # --- the GUI text --------------------------------------------------------------------------

    def _status_text(self, fold: SearchFold) -> str:
        counts = {layer: len(g) for layer, g in fold.ghosts.items()}
        drawn = {layer: len(self._drawn(g)) for layer, g in fold.ghosts.items()}
        key = self._key
        lines = [
            f"**{self._scene}** · seed {key[1] if key else 0} · "
            f"step {fold.events - 1} ({fold.events} events)",
            f"nodes {fold.trace.shown} · failed queries {fold.failed} · "
            f"predictions {len(fold.trace.predictions())}"
            + (" · **solved**" if fold.trace.solution is not None else ""),
        ]
        if counts:
            lines.append("ghosts: " + ", ".join(f"{n} {layer}" for layer, n in counts.items()))
        left_out = {k: counts[k] - drawn[k] for k in counts if counts[k] > drawn[k]}
        if left_out:
            lines.append(
                "showing the latest "
                + ", ".join(f"{drawn[k]} {k} ({n} older hidden)" for k, n in left_out.items())
            )
        q = fold.q_range()
        scale = (
            f"predicted cost Q from {q[0]:.1f} s (green) to {q[1]:.1f} s (red)"
            if q is not None
            else "grey: no model prediction (the learned planner colours by predicted cost Q)"
        )
        lines.append(f"<small>{scale}; red diamond: failed query; blue: solution branch</small>")
        if fold.skipped:
            lines.append(f"<small>{fold.skipped} malformed events skipped</small>")
        return "\n\n".join(lines)

    def _set_status(self, text: str) -> None:
        _set_markdown(self._status, text)


def _bounds(bodies: Sequence[Body], built: Mapping[str, _BodyView]) -> tuple[Vec3, Vec3]:
    """The scene's extent: the corners of what each body draws (a URDF by its position; a body
    that could not be built by its position)."""
    points: list[Vec3] = []
    for b in bodies:
        view = built.get(b.name)
        points += view.corners if view is not None else [b.position]
    if not points:
        return (0.0, 0.0, 0.0), (1.0, 1.0, 1.0)
    xs, ys, zs = zip(*points, strict=True)
    return (min(xs), min(ys), min(zs)), (max(xs), max(ys), max(zs))


def _layer_of(name: str) -> str:
    """The layer a scene node's name belongs to: ``/search/grasps~1`` -> ``grasps``,
    ``/tree/edges`` -> ``tree``; ``""`` for others (the selection's highlights)."""
    if name.startswith("/tree/"):
        return "tree"
    if name.startswith("/search/"):
        return name.removeprefix("/search/").split("~")[0]
    return ""


def _vec(v: Any) -> Vec3:
    return (float(v[0]), float(v[1]), float(v[2]))


def _aim(camera: viser.CameraHandle, position: Vec3, look_at: Vec3) -> None:
    """Put a camera at ``position`` looking at ``look_at`` (viser moves ``look_at`` with the
    position: the position first)."""
    camera.position = position
    camera.look_at = look_at


def _legend_text(fold: SearchFold | None) -> str:
    """What the colours of the scene mean (planner/figures.py's scale of Q)."""
    q = None if fold is None else fold.q_range()
    lo, hi = (f"{q[0]:.1f} s", f"{q[1]:.1f} s") if q is not None else ("low", "high")
    swatch = " → ".join(
        f"<span style='color:{_css(figures.q_rgb_at(f))}'>■</span>" for f in (0.0, 0.5, 1.0)
    )
    return "\n\n".join(
        [
            f"**Ghost colour**: predicted cost Q, {lo} {swatch} {hi} (green low, red high; "
            f"between percentiles {figures.Q_PERCENTILES[0]:g} and {figures.Q_PERCENTILES[1]:g} "
            "of the Q predicted); a node without a prediction of its own takes its nearest "
            "predicted ancestor's",
            f"<span style='color:{_css(figures.NO_PREDICTION_RGB)}'>■</span> grey: no "
            f"prediction · <span style='color:{_css(FAILED_RGB)}'>◆</span> failed query · "
            f"<span style='color:{_css(SOLUTION_RGB)}'>■</span> solution branch · "
            f"<span style='color:{_css(FOCUS_RGB)}'>■</span> selected node · "
            f"<span style='color:{_css(BRANCH_RGB)}'>■</span> its branch",
        ]
    )


def _css(rgb: Sequence[int]) -> str:
    return f"rgb({rgb[0]},{rgb[1]},{rgb[2]})"


def _nothing_shown() -> dict[str, int]:
    return {"failed_marked": 0, "tree_nodes": 0, "focus_markers": 0, "branch_markers": 0}


def _nearest_to_ray(
    markers: Sequence[Marker], origin: Sequence[float], direction: Sequence[float]
) -> int:
    """The index of the marker whose position (a path's nearest point) lies nearest the ray."""
    o = np.asarray(origin, dtype=np.float64)
    d = np.asarray(direction, dtype=np.float64)
    d = d / (float(np.linalg.norm(d)) or 1.0)
    best, best_distance = 0, math.inf
    for i, marker in enumerate(markers):
        for p in marker.points or (marker.position,):
            v = np.asarray(p, dtype=np.float64) - o
            distance = float(np.linalg.norm(v - max(float(v @ d), 0.0) * d))
            if distance < best_distance:
                best, best_distance = i, distance
    return best


# --- meshes of the ghosts (vertices, faces), side "double" so winding does not matter ------------

GhostMesh = tuple[npt.NDArray[np.float32], npt.NDArray[np.uint32]]

_BOX_FACES = np.array(
    [
        (0, 1, 3), (0, 3, 2), (4, 7, 5), (4, 6, 7), (0, 4, 5), (0, 5, 1),
        (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3),
    ],
    dtype=np.uint32,
)  # fmt: skip


def _boxes(*boxes: tuple[tuple[float, float, float], tuple[float, float, float]]) -> GhostMesh:
    """One mesh of axis-aligned boxes given as (centre, size)."""
    vertices: list[tuple[float, float, float]] = []
    faces: list[npt.NDArray[np.uint32]] = []
    for (cx, cy, cz), (sx, sy, sz) in boxes:
        faces.append(_BOX_FACES + len(vertices))
        vertices += [
            (cx + dx * sx / 2, cy + dy * sy / 2, cz + dz * sz / 2)
            for dx in (-1, 1)
            for dy in (-1, 1)
            for dz in (-1, 1)
        ]
    return np.array(vertices, dtype=np.float32), np.concatenate(faces).astype(np.uint32)


def _arrow() -> GhostMesh:
    """A flat arrow on the floor along +x from the base's centre: where the robot faces."""
    outline = [(-0.12, 0.05), (0.10, 0.05), (0.10, 0.10), (0.25, 0.0), (0.10, -0.10), (0.10, -0.05)]
    outline += [(-0.12, -0.05)]
    vertices = np.array([(0.0, 0.0, 0.0)] + [(x, y, 0.0) for x, y in outline], dtype=np.float32)
    n = len(outline)
    faces = np.array([(0, 1 + i, 1 + (i + 1) % n) for i in range(n)], dtype=np.uint32)
    return vertices, faces


_OCTAHEDRON: GhostMesh = (
    np.array(
        [(0.04, 0, 0), (-0.04, 0, 0), (0, 0.04, 0), (0, -0.04, 0), (0, 0, 0.05), (0, 0, -0.05)],
        dtype=np.float32,
    ),
    np.array(
        [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)],
        dtype=np.uint32,
    ),
)

_UNIT_BOX = _boxes(((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)))  # scaled by each marker's size
_ARROW = _arrow()


def _set_slider(slider: viser.GuiSliderHandle[float], value: float) -> None:
    slider.value = value  # type: ignore[misc]  # viser 1.1.1's value setter is hidden from mypy


def _set_markdown(handle: viser.GuiMarkdownHandle, text: str) -> None:
    if handle.content != text:
        handle.content = text


def _pose_from_matrix(m: npt.NDArray[np.float64]) -> Pose:
    """A 4x4 homogeneous transform as a (position, xyzw quaternion) pose."""
    r = m[:3, :3]
    trace = float(r[0, 0] + r[1, 1] + r[2, 2])
    if trace > 0:
        s = math.sqrt(trace + 1.0) * 2
        w, x, y, z = (
            0.25 * s,
            (r[2, 1] - r[1, 2]) / s,
            (r[0, 2] - r[2, 0]) / s,
            (r[1, 0] - r[0, 1]) / s,
        )
    elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = math.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2]) * 2
        w, x, y, z = (
            (r[2, 1] - r[1, 2]) / s,
            0.25 * s,
            (r[0, 1] + r[1, 0]) / s,
            (r[0, 2] + r[2, 0]) / s,
        )
    elif r[1, 1] > r[2, 2]:
        s = math.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2]) * 2
        w, x, y, z = (
            (r[0, 2] - r[2, 0]) / s,
            (r[0, 1] + r[1, 0]) / s,
            0.25 * s,
            (r[1, 2] + r[2, 1]) / s,
        )
    else:
        s = math.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1]) * 2
        w, x, y, z = (
            (r[1, 0] - r[0, 1]) / s,
            (r[0, 2] + r[2, 0]) / s,
            (r[1, 2] + r[2, 1]) / s,
            0.25 * s,
        )
    position = (float(m[0, 3]), float(m[1, 3]), float(m[2, 3]))
    return position, (float(x), float(y), float(z), float(w))
