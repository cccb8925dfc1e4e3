"""Top-k classical planners behind one interface: K* and SymK, selectable by name.

Both ship their binaries inside their wheels (``kstar-planner``, ``up-symk``). Each call runs in
its own temporary directory, since both write intermediate files into the working directory.
"""

from __future__ import annotations

import json
import logging
import subprocess
import sys
import tempfile
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

from planner import supervise
from planner.abstract.errors import PlannerTimeoutError, TopKPlannerError, UnreachableGoalError
from planner.abstract.skeleton import GroundAction

log = logging.getLogger(__name__)

# Fast Downward exit codes meaning "no plan exists" (translator or complete search).
_UNSOLVABLE_EXIT_CODES = frozenset({10, 11, 12})


@dataclass(frozen=True)
class TopKResult:
    """Plans in order of cost, and whether the planner had no more to give."""

    plans: tuple[tuple[GroundAction, ...], ...]
    costs: tuple[float, ...]
    seconds: float
    exhausted: bool  # fewer plans than asked for exist


class TopKPlanner(ABC):
    """A top-k planner: ``plan`` validates and times, ``_plan`` does the work."""

    name: ClassVar[str]

    def plan(self, domain_pddl: str, problem_pddl: str, k: int, *, timeout_s: float) -> TopKResult:
        if k < 1:
            raise ValueError(f"k must be at least 1, got {k}")
        if timeout_s <= 0:
            raise ValueError(f"timeout must be positive, got {timeout_s}")
        start = time.perf_counter()
        with tempfile.TemporaryDirectory(prefix=f"tamp-{self.name}-") as tmp:
            work = Path(tmp)
            (work / "domain.pddl").write_text(domain_pddl, encoding="utf-8")
            (work / "problem.pddl").write_text(problem_pddl, encoding="utf-8")
            plans, costs = self._plan(work, k, timeout_s)
        seconds = time.perf_counter() - start
        log.info("%s: %d plans (k=%d) in %.2f s", self.name, len(plans), k, seconds)
        return TopKResult(tuple(plans), tuple(costs), seconds, exhausted=len(plans) < k)

    @abstractmethod
    def _plan(
        self, work: Path, k: int, timeout_s: float
    ) -> tuple[list[tuple[GroundAction, ...]], list[float]]:
        """Plan on ``work/domain.pddl`` and ``work/problem.pddl``; return plans and costs."""

    def _run(
        self, cmd: list[str], work: Path, timeout_s: float
    ) -> subprocess.CompletedProcess[str]:
        """Run the planner in its own process group, so a timeout or Ctrl-C stops all of it."""
        try:
            return supervise.run_group(cmd, work, timeout_s)
        except subprocess.TimeoutExpired as exc:
            raise PlannerTimeoutError(
                f"timed out after {timeout_s:g} s", backend=self.name
            ) from exc

    def _fail(self, proc: subprocess.CompletedProcess[str], found: int) -> None:
        """Raise the right error when the planner found nothing."""
        if found:
            return
        if proc.returncode in _UNSOLVABLE_EXIT_CODES or "unsolvable" in proc.stdout.lower():
            raise UnreachableGoalError(
                "the goal is unreachable even if every stream succeeds "
                f"({self.name} proved the optimistic task unsolvable)"
            )
        tail = (proc.stdout[-1500:] + proc.stderr[-1500:]).strip()
        raise TopKPlannerError(
            f"exit code {proc.returncode} and no plan", backend=self.name, output=tail
        )


class KStarPlanner(TopKPlanner):
    """K* (Katz et al.) from ``kstar-planner``: top-k with the lmcut heuristic.

    lmcut supports neither axioms nor conditional effects. A task that declares ADL or
    derived predicates is therefore translated first; if its translation has axioms or
    conditional effects, the search runs with the blind heuristic (admissible, so the plans
    still come cheapest first), else with lmcut as usual. A STRIPS task runs in one call.
    """

    name = "kstar"
    SYMMETRIES = (
        "sym=structural_symmetries(time_bound=0,search_symmetries=oss,"
        "stabilize_initial_state=false,keep_operator_symmetries=true)"
    )

    def _plan(
        self, work: Path, k: int, timeout_s: float
    ) -> tuple[list[tuple[GroundAction, ...]], list[float]]:
        import kstar_planner

        build = Path(kstar_planner.__file__).parent / "builds" / "release" / "bin"
        out = work / "plans.json"
        driver = [sys.executable, "-B", "-m", "kstar_planner.driver.main", "--build", str(build)]
        inputs = ["domain.pddl", "problem.pddl"]
        heuristic = "lmcut"
        remaining = timeout_s
        if _declares_adl((work / "domain.pddl").read_text(encoding="utf-8")):
            started = time.perf_counter()
            translate = [
                sys.executable,
                "-B",
                str(build / "translate" / "translate.py"),
                "domain.pddl",
                "problem.pddl",
                "--sas-file",
                "output.sas",
            ]
            proc = self._run(translate, work, timeout_s)
            sas = work / "output.sas"
            if proc.returncode != 0 or not sas.is_file():
                self._fail(proc, 0)
            if not sas_supports_lmcut(sas.read_text(encoding="utf-8")):
                heuristic = "blind"
            inputs = ["output.sas"]
            remaining = max(timeout_s - (time.perf_counter() - started), 1e-3)
            log.info("kstar: the translated task needs %s", heuristic)
        search = (
            f"kstar({heuristic}(transform=undo_to_origin()), k={k}, find_unordered_plans=false, "
            f"dump_plan_files=false, json_file_to_dump={out}, symmetries=sym)"
        )
        cmd = [*driver, *inputs, "--symmetries", self.SYMMETRIES, "--search", search]
        proc = self._run(cmd, work, remaining)
        raw = json.loads(out.read_text()) if out.is_file() and out.stat().st_size else {}
        plans = [tuple(GroundAction.parse(a) for a in p["actions"]) for p in raw.get("plans", [])]
        costs = [float(p["cost"]) for p in raw.get("plans", [])]
        self._fail(proc, len(plans))
        return plans, costs


_ADL_REQUIREMENTS = frozenset({":adl", ":derived-predicates", ":conditional-effects"})


def _declares_adl(domain_pddl: str) -> bool:
    """Whether the domain's requirements ask for more than STRIPS with costs."""
    start = domain_pddl.find("(:requirements")
    if start < 0:
        return False
    end = domain_pddl.find(")", start)
    return bool(set(domain_pddl[start:end].lower().split()) & _ADL_REQUIREMENTS)


def sas_supports_lmcut(sas: str) -> bool:
    """Whether a Fast Downward translation has neither axioms nor conditional effects."""
    lines = sas.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i].strip()
        if line == "begin_rule":
            return False
        if line == "begin_operator":
            prevail = int(lines[i + 2])
            j = i + 3 + prevail
            for effect in lines[j + 1 : j + 1 + int(lines[j])]:
                if int(effect.split()[0]) > 0:
                    return False
            i = j + 1 + int(lines[j])
            continue
        i += 1
    return True


class SymKPlanner(TopKPlanner):
    """SymK (Speck et al.), the paper's planner, from ``up-symk``: symbolic top-k search."""

    name = "symk"

    def _plan(
        self, work: Path, k: int, timeout_s: float
    ) -> tuple[list[tuple[GroundAction, ...]], list[float]]:
        import up_symk

        driver = Path(up_symk.__file__).parent / "symk" / "fast-downward.py"
        cmd = [
            sys.executable,
            str(driver),
            "--plan-file",
            "sas_plan",
            "domain.pddl",
            "problem.pddl",
            "--search",
            f"symk_bd(plan_selection=top_k(num_plans={k},dump_plans=false))",
        ]
        proc = self._run(cmd, work, timeout_s)
        files = sorted(work.glob("sas_plan*"), key=_plan_number)
        plans: list[tuple[GroundAction, ...]] = []
        costs: list[float] = []
        for f in files:
            lines = [ln.strip() for ln in f.read_text().splitlines() if ln.strip()]
            plans.append(tuple(GroundAction.parse(ln) for ln in lines if not ln.startswith(";")))
            cost = [ln for ln in lines if ln.startswith("; cost =")]
            costs.append(float(cost[0].split("=")[1].split()[0]) if cost else float(len(plans[-1])))
        self._fail(proc, len(plans))
        return plans, costs


def _plan_number(path: Path) -> int:
    suffix = path.suffix.lstrip(".")
    return int(suffix) if suffix.isdigit() else 0


TOPK_PLANNERS: dict[str, type[TopKPlanner]] = {
    KStarPlanner.name: KStarPlanner,
    SymKPlanner.name: SymKPlanner,
}
DEFAULT_TOPK = KStarPlanner.name  # the faster on the kitchen, see docs/BENCHMARKS.md


def get_topk_planner(name: str) -> TopKPlanner:
    """The top-k backend called ``name``; an unknown name lists the known ones."""
    try:
        return TOPK_PLANNERS[name]()
    except KeyError:
        known = ", ".join(sorted(TOPK_PLANNERS))
        raise ValueError(f"unknown top-k planner {name!r} (known: {known})") from None
