"""Bound plans as files (``tamp plan --out``, ``tamp validate``, the dashboard's plan), and their
validation, for any domain.

A plan file is JSON: ``format`` (:data:`FORMAT`), ``domain`` (its name) and ``domain_path`` (the
folder it was loaded from, so ``tamp validate`` finds a domain that is not installed), ``scene``,
``seed``, ``actions`` (``"(move q0 opt-q1 opt-t2)"``), ``streams`` (the stream plan: stream,
inputs, outputs and the facts each needs and certifies), ``values`` (each object an action
uses that has a value, as JSON by the domain's value types) and ``python`` (for a value that
was a numpy array or a list, what it was: :func:`planner.values.python_shape`, so it is read
back as one).

Validation: the domain's validator when it has one (the kitchen replays the plan in simulation);
otherwise the plan is replayed fact by fact (every stream's inputs produced earlier and domain
facts holding, every action's preconditions, the goal) and every test stream of the plan (a
stream with no outputs) is asked again on the bound values.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from planner.abstract.instantiate import StreamInstance
from planner.abstract.skeleton import AbstractPlan, GroundAction, PlanReplayError, replay
from planner.domains.spec import LoadedDomain, PlanCheck
from planner.pddl.structs import Atom, Problem
from planner.streams.runtime import StreamRuntime
from planner.values import ValueDecodeError, python_shape, restore

FORMAT = "guided-tamp/plan-v1"


class PlanFileError(ValueError):
    """A plan file is missing, malformed or for something else; the message names the field."""


@dataclass(frozen=True)
class PlanFile:
    """A plan file as read: still JSON values (decode them with the plan's domain)."""

    domain: str
    domain_path: str | None
    scene: str
    seed: int
    actions: tuple[GroundAction, ...]
    streams: tuple[StreamInstance, ...] | None  # None: a file written without its stream plan
    values: Mapping[str, Any]  # JSON
    source: str
    python: Mapping[str, Any] = field(default_factory=dict)  # value name -> its Python shape

    def decoded_values(self, loaded: LoadedDomain) -> dict[str, Any]:
        """The values as the samplers made them (numpy arrays and lists as such)."""
        out = {}
        try:
            for k, v in self.values.items():
                where = f"{self.source}: values.{k}"
                out[k] = restore(loaded.decode(v, where), self.python.get(k), where)
        except ValueDecodeError as exc:
            raise PlanFileError(str(exc)) from exc
        return out


def _fact(atom: Atom) -> list[str]:
    return [atom.predicate, *atom.args]


def plan_to_dict(
    *,
    loaded: LoadedDomain,
    scene: str,
    seed: int,
    plan: AbstractPlan,
    values: Mapping[str, Any],
    domain_path: str | None = None,
) -> dict[str, Any]:
    """The plan file's contents: actions, stream plan and the values of the objects they use."""
    used = {a for act in plan.actions for a in act.args}
    used |= {n for inst in plan.stream_plan for n in (*inst.inputs, *inst.outputs)}
    return {
        "format": FORMAT,
        "domain": loaded.name,
        "domain_path": domain_path,
        "scene": scene,
        "seed": seed,
        "actions": [str(a) for a in plan.actions],
        "streams": [
            {
                "stream": inst.stream,
                "inputs": list(inst.inputs),
                "outputs": list(inst.outputs),
                "domain": [_fact(a) for a in inst.domain],
                "certified": [_fact(a) for a in inst.certified],
                "level": inst.level,
            }
            for inst in plan.stream_plan
        ],
        "values": {
            n: loaded.encode(values[n])
            for n in sorted(used)
            if n in values and not isinstance(values[n], str)
        },
        "python": {
            n: shape
            for n in sorted(used)
            if n in values
            and not isinstance(values[n], str)
            and (shape := python_shape(values[n])) is not None
        },
    }


def _strings(data: Any, where: str) -> tuple[str, ...]:
    if not isinstance(data, list) or not all(isinstance(a, str) for a in data):
        raise PlanFileError(f"{where}: expected a list of names")
    return tuple(data)


def _facts(data: Any, where: str) -> tuple[Atom, ...]:
    if not isinstance(data, list):
        raise PlanFileError(f"{where}: expected a list of facts such as ['on', 'b1', 'table']")
    out = []
    for i, f in enumerate(data):
        names = _strings(f, f"{where}[{i}]")
        if not names:
            raise PlanFileError(f"{where}[{i}]: empty fact")
        out.append(Atom(names[0], names[1:]))
    return tuple(out)


def _streams(data: Any, where: str) -> tuple[StreamInstance, ...]:
    if not isinstance(data, list):
        raise PlanFileError(f"{where}: expected a list of stream instances")
    out = []
    for i, s in enumerate(data):
        w = f"{where}[{i}]"
        if not isinstance(s, dict) or not isinstance(s.get("stream"), str):
            raise PlanFileError(f"{w}: expected an object with stream, inputs, outputs")
        level = s.get("level", 1)
        out.append(
            StreamInstance(
                s["stream"],
                _strings(s.get("inputs"), f"{w}.inputs"),
                _strings(s.get("outputs"), f"{w}.outputs"),
                _facts(s.get("domain", []), f"{w}.domain"),
                _facts(s.get("certified", []), f"{w}.certified"),
                level if isinstance(level, int) and not isinstance(level, bool) else 1,
            )
        )
    return tuple(out)


def parse_plan(data: Any, source: str) -> PlanFile:
    """A plan file's JSON; :class:`PlanFileError` names the field that is wrong."""
    if not isinstance(data, dict):
        raise PlanFileError(f"{source}: expected a JSON object")
    fmt = data.get("format")
    if fmt != FORMAT:
        raise PlanFileError(f"{source}: format: expected {FORMAT!r}, got {fmt!r}")
    domain = data.get("domain")
    if not isinstance(domain, str):
        raise PlanFileError(f"{source}: domain: expected the domain's name")
    path = data.get("domain_path")
    scene, seed = data.get("scene"), data.get("seed")
    if not isinstance(scene, str):
        raise PlanFileError(f"{source}: scene: expected a scene name")
    if not isinstance(seed, int) or isinstance(seed, bool):
        raise PlanFileError(f"{source}: seed: expected an integer")
    raw_actions = data.get("actions")
    if not isinstance(raw_actions, list) or not all(isinstance(a, str) for a in raw_actions):
        raise PlanFileError(f"{source}: actions: expected a list of strings such as '(move ...)'")
    try:
        actions = tuple(GroundAction.parse(a) for a in raw_actions)
    except ValueError as exc:
        raise PlanFileError(f"{source}: actions: {exc}") from exc
    raw_values = data.get("values", {})
    if not isinstance(raw_values, dict):
        raise PlanFileError(f"{source}: values: expected an object")
    streams = _streams(data["streams"], f"{source}: streams") if "streams" in data else None
    python = data.get("python", {})
    if not isinstance(python, dict):
        raise PlanFileError(f"{source}: python: expected an object (value name -> its shape)")
    return PlanFile(
        domain,
        path if isinstance(path, str) else None,
        scene,
        seed,
        actions,
        streams,
        raw_values,
        source,
        python,
    )


def read_plan(path: Path) -> PlanFile:
    if not path.is_file():
        raise PlanFileError(f"{path}: no such plan file")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise PlanFileError(f"{path}:{exc.lineno}:{exc.colno}: invalid JSON: {exc.msg}") from exc
    except UnicodeDecodeError as exc:
        raise PlanFileError(f"{path}: byte {exc.start} is not UTF-8") from exc
    return parse_plan(data, str(path))


def write_plan(path: Path, data: Mapping[str, Any]) -> None:
    path.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")


def validate(
    loaded: LoadedDomain,
    problem: Problem,
    actions: Sequence[GroundAction],
    values: Mapping[str, Any],
    *,
    streams: Sequence[StreamInstance] | None,
    runtime: StreamRuntime | None = None,
) -> PlanCheck:
    """Validate a bound plan: the domain's validator, else a replay (see the module docstring;
    ``runtime`` re-asks the test streams, none are asked without it)."""
    if loaded.spec.validate is not None:
        return loaded.spec.validate(actions, values, problem)
    if streams is None:
        return PlanCheck(False, "cannot validate: the plan file has no stream plan to replay")
    try:
        replay(
            AbstractPlan(tuple(actions), tuple(streams), 0.0),
            loaded.domain,
            problem,
            loaded.streams,
        )
    except PlanReplayError as exc:
        return PlanCheck(False, f"invalid: {exc}")
    missing = sorted(
        {n for act in actions for n in act.args if n.startswith("opt-") and n not in values}
    )
    if missing:
        return PlanCheck(False, f"invalid: no value for {', '.join(missing)}")
    tests = [inst for inst in streams if not inst.outputs]
    if runtime is None:
        return PlanCheck(True, "valid (replayed fact by fact; the domain has no validator)")
    for inst in tests:
        # A fresh key: the test is asked anew, whatever the search asked it before (a
        # PDDLStream test answers once per input binding).
        inputs = tuple(values.get(n, n) for n in inst.inputs)
        result = runtime.query(inst.stream, inputs, key=object())
        if result.error is not None:
            return PlanCheck(
                False, f"invalid: test {inst} raised on the bound values: {result.error}"
            )
        if not result.success:
            why = f" ({result.reason})" if result.reason else ""
            return PlanCheck(False, f"invalid: test {inst} says false on the bound values{why}")
    try:
        seconds = execution_seconds(runtime, actions, streams, values)
    except ValueError as exc:
        return PlanCheck(False, f"invalid: {exc}")
    how = "replayed fact by fact"
    if tests:
        how += f", {len(tests)} tests asked again"
    message = f"valid ({how}; the domain has no validator)"
    return PlanCheck(True, message + execution_note(loaded, seconds), seconds)


def execution_seconds(
    runtime: StreamRuntime,
    actions: Sequence[GroundAction],
    streams: Sequence[StreamInstance],
    values: Mapping[str, Any],
) -> float:
    """Seconds to execute a bound plan: of each stream in its stream plan whose outputs an
    action uses, what the runtime says those outputs take (``DomainSpec.execution_s``, else
    their ``seconds``)."""
    used = {a for act in actions for a in act.args}
    total = 0.0
    for inst in streams:
        if inst.outputs and any(o in used for o in inst.outputs):
            outputs = tuple(values[o] for o in inst.outputs)
            total += runtime.execution_seconds(inst.stream, outputs)
    return total


EXECUTION_UNKNOWN = (
    "; execution 0 s: no value of the plan says how long it takes to execute (a trajectory "
    "that is a plain list); give its class a `seconds` property or the domain "
    "DomainSpec.execution_s (docs/domains.md, From PDDLStream)"
)


def execution_note(loaded: LoadedDomain, seconds: float | None) -> str:
    """What to add to a plan's message when its execution takes 0 s only because nothing
    says how long its values take (:data:`EXECUTION_UNKNOWN`); empty otherwise."""
    if seconds is None or seconds > 0 or loaded.spec.execution_s is not None:
        return ""
    return EXECUTION_UNKNOWN
