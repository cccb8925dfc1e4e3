"""Fast Downward, as the wheel of ``kstar-planner`` ships it: its translator and its search.

Both run in a fresh temporary directory, in their own process group, so a timeout or Ctrl-C
stops all of them (:func:`run_group`). The skeleton source (:mod:`planner.abstract.source`)
translates a task once (:func:`translate`, or :mod:`planner.abstract.ground` for STRIPS) and
then runs satisficing searches on the SAS task as often as it wants more plans
(:func:`search_plan`).
"""

from __future__ import annotations

import contextlib
import hashlib
import logging
import math
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from planner import supervise
from planner.abstract.errors import PlannerTimeoutError, TopKPlannerError, UnreachableGoalError

log = logging.getLogger(__name__)

# Fast Downward's exit codes for "no plan exists" (translator or complete search).
UNSOLVABLE_EXIT_CODES = frozenset({10, 11, 12})
# ... and for a search that gave up without proving anything (incomplete search, bound).
_GAVE_UP_EXIT_CODES = frozenset({12})


def build_dir() -> Path:
    """The folder of the Fast Downward binaries inside ``kstar-planner``'s wheel."""
    import kstar_planner

    return Path(kstar_planner.__file__).parent / "builds" / "release" / "bin"


def run_group(
    cmd: list[str],
    work: Path,
    timeout_s: float,
    *,
    stdin: str | None = None,
    who: str = "fast-downward",
    timeout_ok: bool = False,
) -> subprocess.CompletedProcess[str]:
    """Run ``cmd`` in ``work`` in its own process group; a timeout kills the whole group and
    raises :class:`TopKPlannerError` (or, with ``timeout_ok``, returns exit code -9)."""
    try:
        return supervise.run_group(cmd, work, timeout_s, stdin=stdin)
    except subprocess.TimeoutExpired as exc:
        if timeout_ok:
            return subprocess.CompletedProcess(cmd, -9, "", "")
        raise PlannerTimeoutError(f"timed out after {timeout_s:g} s", backend=who) from exc


@dataclass(frozen=True)
class SasTask:
    """A task in Fast Downward's SAS format, and how it was made."""

    text: str
    grounded_by: str  # "direct" (planner.abstract.ground) or "translator"
    seconds: float  # wall seconds it took to make
    operators: int

    @property
    def key(self) -> str:
        return hashlib.sha1(self.text.encode("utf-8")).hexdigest()[:16]


def translate(domain_pddl: str, problem_pddl: str, *, timeout_s: float) -> SasTask:
    """Fast Downward's translator on the task (the whole language: axioms, conditional
    effects, quantifiers, costs). A task it proves unsolvable raises
    :class:`UnreachableGoalError`."""
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="tamp-translate-") as tmp:
        work = Path(tmp)
        (work / "domain.pddl").write_text(domain_pddl, encoding="utf-8")
        (work / "problem.pddl").write_text(problem_pddl, encoding="utf-8")
        cmd = [
            sys.executable,
            "-B",
            str(build_dir() / "translate" / "translate.py"),
            "domain.pddl",
            "problem.pddl",
            "--sas-file",
            "output.sas",
        ]
        proc = run_group(cmd, work, timeout_s, who="translator")
        sas = work / "output.sas"
        if proc.returncode in UNSOLVABLE_EXIT_CODES or "unsolvable" in proc.stdout.lower():
            raise UnreachableGoalError(
                "the goal is unreachable even if every stream succeeds (Fast Downward's "
                "translator proved the optimistic task unsolvable)"
            )
        if proc.returncode != 0 or not sas.is_file():
            tail = (proc.stdout[-1500:] + proc.stderr[-1500:]).strip()
            raise TopKPlannerError(
                f"exit code {proc.returncode} and no task", backend="translator", output=tail
            )
        text = sas.read_text(encoding="utf-8")
    operators = _count_operators(text)
    return SasTask(text, "translator", time.perf_counter() - start, operators)


def _count_operators(sas: str) -> int:
    return sas.count("\nbegin_operator\n")


@dataclass(frozen=True)
class FoundPlan:
    """A plan of a search: its actions as the plan file prints them, and its cost."""

    actions: tuple[str, ...]  # "move q0 opt-q1 opt-t2"
    cost: float


def search_plan(
    sas: SasTask, search: str, *, timeout_s: float, bounded: bool = False, work: Path | None = None
) -> FoundPlan | None:
    """One search of Fast Downward's ``downward`` binary on ``sas`` (``search``: its option
    string, e.g. ``lazy_greedy([ff()], preferred=[ff()])``). None when the search ends without
    a plan; :class:`UnreachableGoalError` when it explored every reachable state and ``bounded``
    is false (a bound on the cost proves nothing)."""
    binary = build_dir() / "downward"
    with contextlib.ExitStack() as stack:
        if work is None:
            work = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="tamp-fd-")))
        plans = work / "found_plans"
        plans.mkdir(exist_ok=True)
        plan_file = plans / "sas_plan"
        plan_file.unlink(missing_ok=True)
        proc = run_group(
            [str(binary), "--search", search],  # it writes found_plans/sas_plan
            work,
            timeout_s,
            stdin=sas.text,
            who="fast-downward",
        )
        if plan_file.is_file():
            return _read_plan(plan_file.read_text(encoding="utf-8"))
        explored = "completely explored state space" in proc.stdout.lower()
        if proc.returncode in UNSOLVABLE_EXIT_CODES - _GAVE_UP_EXIT_CODES or (
            explored and not bounded
        ):
            raise UnreachableGoalError(
                "the goal is unreachable even if every stream succeeds (Fast Downward's "
                "search proved the optimistic task unsolvable)"
            )
        if proc.returncode not in UNSOLVABLE_EXIT_CODES and proc.returncode != 0:
            tail = (proc.stdout[-1500:] + proc.stderr[-1500:]).strip()
            raise TopKPlannerError(
                f"exit code {proc.returncode} and no plan", backend="fast-downward", output=tail
            )
        return None


def _read_plan(text: str) -> FoundPlan:
    actions: list[str] = []
    cost: float | None = None
    for line in text.splitlines():
        line = line.strip()
        if not line:
            continue
        if line.startswith(";"):
            if "cost =" in line:
                cost = float(line.split("=", 1)[1].split()[0])
            continue
        action = line.strip("()").strip()
        if not action.startswith("__"):  # the goal operator kstar's build adds (cost 0)
            actions.append(action)
    return FoundPlan(tuple(actions), float(len(actions)) if cost is None else cost)


def improve_plan(sas: SasTask, bound: float, *, seconds: float) -> FoundPlan | None:
    """A plan cheaper than ``bound`` by Fast Downward's anytime search, within ``seconds``:
    weighted A* with FF at weights 5, 3, 2 and 1, then A* with an admissible heuristic (lmcut,
    or blind where the task has axioms or conditional effects), each bounded by the best plan
    so far (as LAMA improves its first plan). None when nothing cheaper came in time; the plan
    is optimal when the last search finished."""
    from planner.abstract.topk import sas_supports_lmcut

    optimal = "astar(lmcut())" if sas_supports_lmcut(sas.text) else "astar(blind())"
    phases = [f"lazy_wastar([ff()], preferred=[ff()], w={w})" for w in (5, 3, 2, 1)]
    search = (
        f"iterated([{', '.join([*phases, optimal])}], pass_bound=true, continue_on_fail=true, "
        f"bound={math.ceil(bound)})"
    )
    with tempfile.TemporaryDirectory(prefix="tamp-fd-") as tmp:
        work = Path(tmp)
        plans = work / "found_plans"
        plans.mkdir()
        run_group(
            [str(build_dir() / "downward"), "--search", search],
            work,
            max(seconds, 1e-3),
            stdin=sas.text,
            timeout_ok=True,
        )
        found = [_read_plan(f.read_text(encoding="utf-8")) for f in plans.glob("sas_plan*")]
    found = [f for f in found if f.cost < bound]
    return min(found, key=lambda f: f.cost) if found else None
