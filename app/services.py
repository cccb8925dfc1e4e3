"""The dashboard's logic, behind thin routes: launching and reading runs, catalogs, the view."""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from app import catalog
from app.benchmarks import BenchService
from app.compare import Trees
from app.errors import RequestError
from app.horizon import Horizon
from app.hub import EventHub
from app.manager import RunManager
from app.reads import ReadGate
from app.settings import Settings
from app.training import TrainingService
from app.viewing import Viewer, ViewerService
from planner.planners import get_planner
from planner.runs import resolve_run
from planner.store import RunRecord, RunStore

if TYPE_CHECKING:
    from app.viewgate import ViewerGate

log = logging.getLogger(__name__)


class Dashboard:
    def __init__(
        self,
        settings: Settings,
        *,
        viewer: Viewer | None = None,
        viewer_gate: ViewerGate | None = None,
    ) -> None:
        self.settings = settings
        self.store = RunStore(settings.database_url)
        settled = self.store.mark_interrupted()
        if settled:
            log.warning("%d run(s) whose process had stopped are now finished", settled)
        self.hub = EventHub(client_limit=settings.ws_queue_events)
        self.reads = ReadGate()  # every read of events the server serves takes its turn here
        self.domains = catalog.Domains(settings.extra_domains)
        self.models = catalog.Models(settings.model_dir, self.domains)
        self.manager = RunManager(
            self.store,
            settings.database_url,
            self.hub,
            max_running=settings.max_running,
            max_queued=settings.max_queued,
            cancel_grace_s=settings.cancel_grace_s,
        )
        self.viewer = ViewerService(viewer, self.store, self.hub)
        self.viewer_gate = viewer_gate
        self.reports_dir = settings.reports_dir
        self.trees = Trees(self.store)
        self.benches = BenchService(
            self.store,
            settings.database_url,
            self.domains,
            self.models,
            max_running=settings.max_benchmarks,
        )
        self.horizon = Horizon(self.benches)  # the horizon curves of the store's benchmarks
        self.training = TrainingService(
            self.store, settings.database_url, self.domains, self.models
        )

    def warm_up(self) -> None:
        """Find the scenes and read the models, before the server takes requests. Every page
        asks for both; finding the scenes loads every domain (seconds, for one that imports a
        simulator) and reading the models imports torch. In the first page's requests they held
        up the rest (docs/BENCHMARKS.md, the dashboard's pages)."""
        start = time.perf_counter()
        try:
            scenes, models = self.domains.scenes(), self.models.list()
            log.info(
                "%d scenes and %d models found in %.1f s",
                len(scenes),
                len(models),
                time.perf_counter() - start,
            )
        except Exception:  # the request that asks again reports it
            log.exception("finding the scenes and models at start-up failed")

    def close(self) -> None:
        self.benches.close()
        self.training.close()
        self.manager.close()
        if self.viewer_gate is not None:
            self.viewer_gate.close()
        self.viewer.close()
        self.store.close()

    def viewer_url(self, host_header: str | None) -> str | None:
        """The 3D view's address for a page that reached the dashboard as ``host_header``
        (the same name, so the token cookie and the framing rule apply); None without one."""
        if self.viewer_gate is None:
            return None
        return self.viewer_gate.url(host_header)

    # --- runs ---------------------------------------------------------------------------------

    def launch(
        self, *, scene: str, planner: str, model: str | None = None, **options: Any
    ) -> RunRecord:
        """Queue a run; ``options`` are :class:`~planner.api.RunConfig` fields by name (seed,
        budget_s, k, max_queries, ...: a run option added there and to the request reaches the
        run with no change here). :class:`RequestError` names a field that is wrong."""
        try:
            scene_info = self.domains.scene(scene)
        except catalog.UnknownNameError as exc:
            raise RequestError("scene", str(exc)) from exc
        model_path: Path | None = None
        name = model
        learned = get_planner(planner).uses_model
        if learned:
            name = model or self.models.default_for(scene_info.domain)
        elif model is not None:
            raise RequestError("model", "a model is only used by the learned planners")
        if name is not None:
            try:
                model_path = self.models.path(name)
            except catalog.UnknownNameError as exc:
                raise RequestError("model", str(exc)) from exc
            fits = {m.name: m.domain for m in self.models.list()}
            if fits.get(name) != scene_info.domain:
                fitting = [n for n, d in fits.items() if d == scene_info.domain]
                raise RequestError(
                    "model",
                    f"model {name!r} is for domain {fits.get(name)!r}, scene {scene!r} is "
                    f"{scene_info.domain!r} (models for it: {', '.join(fitting) or 'none'})",
                )
        try:
            config = resolve_run(
                self.settings.database_url,  # a path or a URL (Path would mangle a URL's //)
                scene=scene,
                planner=planner,
                model=str(model_path) if model_path is not None else None,
                domain=scene_info.domain_ref,
                **options,
            )
        except ValueError as exc:  # the request's checks are RunConfig's; this is a backstop
            raise RequestError(_field_named(str(exc), list(options)), str(exc)) from exc
        run_id = self.manager.submit(config, {"model_name": name} if model_path else {})
        return self.store.get_run(run_id)

    def query_counts(self, run_id: str) -> dict[str, dict[str, int]]:
        return self.store.query_counts(run_id)

    def reports(self) -> list[dict[str, Any]]:
        if not self.reports_dir.is_dir():
            return []
        return [
            {"name": p.stem, "url": f"/reports/{p.name}"}
            for p in sorted(self.reports_dir.glob("*.html"))
            if catalog.safe_name(p.stem)
        ]


def _field_named(message: str, names: Any) -> str:
    """The request field a RunConfig error message is about: the first option it names."""
    found = next((n for n in names if n in message), None)
    return found or ("budget_s" if message.startswith("budget") else "planner")
