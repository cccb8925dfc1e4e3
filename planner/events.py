"""The event protocol: one frozen dataclass per thing that happens during a run.

The planner emits events to an :class:`EventSink` and never knows who listens: the run store
(:mod:`planner.store`), the websocket, the 3D viewer and the CLI progress line all receive the
same objects, and the JSON of :func:`event_to_json` is what goes over the wire and into the
database. Every event carries ``run_id``, ``seq`` (0, 1, 2, ... per run, no gaps when emitted
through an :class:`Emitter`) and ``t`` (seconds since the run started).

Tree conventions for :class:`NodeAdded` (as in :mod:`planner.search.tree`): the root has
``parent_id=None``, ``stream=None``, ``plan_index=-1`` and ``depth=0``; its children are the
stream plans (``depth=0``, ``stream=None``, ``plan_index`` = the plan's index in
:class:`AbstractPlansFound`); a node at depth ``d >= 1`` is one result of querying the ``d``-th
stream of its plan.

Every payload is JSON-friendly (str, int, finite float, bool, None, lists, dicts with str keys),
checked when the event is built, so a bad value fails where it is made, not in a listener.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import numbers
import threading
import time
import types
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import (
    Any,
    ClassVar,
    NoReturn,
    Protocol,
    TypeAlias,
    TypeVar,
    Union,
    get_args,
    get_origin,
    get_type_hints,
)

from planner.status import FINISH_STATUSES

log = logging.getLogger(__name__)


_BASE_FIELDS = ("run_id", "seq", "t")
_PLAN_KEYS = (("index", int), ("cost", float), ("actions", list[str]), ("streams", list[str]))


@dataclass(frozen=True)
class _EventBase:
    """Fields every event has; not an event itself (it has no ``type``)."""

    type: ClassVar[str]

    run_id: str
    seq: int  # position in the run's event stream, from 0
    t: float  # seconds since the run started

    def __post_init__(self) -> None:
        for name, check, is_float in _field_checks(type(self)):
            value = getattr(self, name)
            error = check(value)
            if error is not None:
                raise ValueError(f"{self.type}.{name}{error}")
            if is_float and value is not None and type(value) is not float:
                object.__setattr__(self, name, float(value))  # 1 and 1.0 must round-trip alike
        if not self.run_id:
            self._fail("run_id", "must not be empty")
        if self.seq < 0:
            self._fail("seq", f"must be >= 0, got {self.seq}")
        if self.t < 0:
            self._fail("t", f"must be >= 0, got {self.t}")
        self._validate()

    def _validate(self) -> None:
        """Invariants of one event class beyond the field types."""

    def _fail(self, field: str, message: str) -> NoReturn:
        raise ValueError(f"{self.type}.{field}: {message}")

    def _non_negative(self, *names: str) -> None:
        for name in names:
            value = getattr(self, name)
            if value is not None and value < 0:
                self._fail(name, f"must be >= 0, got {value}")


@dataclass(frozen=True)
class RunStarted(_EventBase):
    type: ClassVar[str] = "run_started"

    scene: str
    seed: int
    planner: str
    config: dict[str, Any]  # the run's full configuration, enough to reproduce it


@dataclass(frozen=True)
class AbstractPlansFound(_EventBase):
    type: ClassVar[str] = "abstract_plans_found"

    plans: list[dict[str, Any]]  # {"index": int, "cost": float, "actions": [str], "streams": [str]}
    seconds: float  # wall seconds of abstract planning, top-k included

    def _validate(self) -> None:
        self._non_negative("seconds")
        for i, plan in enumerate(self.plans):
            for key, hint in _PLAN_KEYS:
                if key not in plan:
                    self._fail(f"plans[{i}]", f"missing key {key!r}")
                _check_value(plan[key], hint, f"{self.type}.plans[{i}].{key}")


@dataclass(frozen=True)
class SkeletonProgress(_EventBase):
    """Word from the skeleton source while it works (before the first skeleton and whenever the
    search asks it for more): which phase it is in and what it has done so far."""

    type: ClassVar[str] = "skeleton_progress"

    phase: str  # instantiate | translate | search | replan
    message: str  # one line for people: "translating 2,497 stream instances"
    seconds: float  # seconds the source has worked on this request so far

    def _validate(self) -> None:
        self._non_negative("seconds")


@dataclass(frozen=True)
class SkeletonsAdded(_EventBase):
    """More skeletons during the search: the source produced them when the search asked for
    another (their indices follow the earlier plans'), after what the search proved false."""

    type: ClassVar[str] = "skeletons_added"

    plans: list[dict[str, Any]]  # as AbstractPlansFound's, indices continuing
    seconds: float  # wall seconds the source took for this batch
    reason: str  # why the search asked: "more" (its widening rule or estimate), "all dead"
    # What the search had proved false and the source now plans without: one line per fact
    # or stream instance ("(cfree a p3 b p0) false", "ik(a p0 g1) exhausted").
    learned: list[str] = field(default_factory=list)

    def _validate(self) -> None:
        self._non_negative("seconds")
        for i, plan in enumerate(self.plans):
            for key, hint in _PLAN_KEYS:
                if key not in plan:
                    self._fail(f"plans[{i}]", f"missing key {key!r}")
                _check_value(plan[key], hint, f"{self.type}.plans[{i}].{key}")


@dataclass(frozen=True)
class NodeAdded(_EventBase):
    type: ClassVar[str] = "node_added"

    node_id: int
    parent_id: int | None  # None for the root only
    plan_index: int  # which abstract plan the node belongs to; -1 for the root
    depth: int  # 0 root and stream plans, d >= 1 a result of the plan's d-th stream
    stream: str | None  # the stream queried to make this node; None for the root and plan nodes
    success: bool
    outputs: list[Any]  # JSON-encoded values the query bound, one per output name
    label: str  # short text for the dashboard
    output_names: list[str] = field(default_factory=list)  # the optimistic objects bound
    # One line per output for people, from the domain's value types (empty: none given).
    output_labels: list[str] = field(default_factory=list)

    def _validate(self) -> None:
        self._non_negative("node_id", "parent_id")
        if self.depth < 0:
            self._fail("depth", f"must be >= 0, got {self.depth}")
        if self.plan_index < -1:
            self._fail("plan_index", f"must be >= -1, got {self.plan_index}")
        if self.parent_id is None and self.stream is not None:
            self._fail("stream", "the root (parent_id None) has no stream")
        if self.depth == 0 and self.stream is not None:
            self._fail("stream", f"a node at depth {self.depth} has no stream")
        if self.depth >= 1 and self.stream is None:
            self._fail("stream", f"a node at depth {self.depth} must name its stream")
        if self.output_names and len(self.output_names) != len(self.outputs):
            self._fail(
                "outputs", f"{len(self.outputs)} values for {len(self.output_names)} output names"
            )
        if self.output_labels and len(self.output_labels) != len(self.outputs):
            self._fail(
                "output_labels", f"{len(self.output_labels)} labels, {len(self.outputs)} values"
            )


@dataclass(frozen=True)
class NodeVisited(_EventBase):
    type: ClassVar[str] = "node_visited"

    node_id: int
    visits: int  # visit count after this back-up
    value: float  # node value after this back-up

    def _validate(self) -> None:
        self._non_negative("node_id", "visits")


@dataclass(frozen=True)
class StreamQueried(_EventBase):
    type: ClassVar[str] = "stream_queried"

    node_id: int  # the node the query made (its node_added comes right after this event)
    stream: str
    input_names: list[str]
    inputs: list[Any]  # JSON-encoded input values, one per input name
    success: bool
    wall_s: float
    cpu_s: float  # CPU seconds of the thread that ran the sampler
    execution_s: float  # seconds to execute what the query produced; 0 if nothing moves
    error: str | None  # why the sampler failed (raised, malformed output); None otherwise
    # The world the sampler saw: fluent facts of the plan's state where its output is first
    # needed, and the encoded values of their objects (what learned models read as global
    # features): {"facts": [[predicate, arg, ...], ...], "values": {name: value}}, plus the
    # domain's static context (the kitchen: {"geometry": {"platforms": ..., "blocks": ...}}).
    context: dict[str, Any] = field(default_factory=dict)
    # The node whose identical query gave this answer: no sampler ran, so the store keeps no
    # training row for it. A success with the same stream, inputs and context, a test asked
    # with the same inputs (its answer, failure too, is a function of them), or a known failure
    # (the stream found nothing for these inputs and said it will not). None: a real query.
    reused_from: int | None = None
    # Why a sampler that ran cleanly found nothing, when it said (the kitchen's: "base motion:
    # no path in 150 iterations", "no IK solution ..."); None for a success or an error.
    reason: str | None = None
    # One line per input for people, from the domain's value types (empty: none given).
    input_labels: list[str] = field(default_factory=list)

    def _validate(self) -> None:
        self._non_negative("node_id", "wall_s", "cpu_s", "execution_s")
        if self.reused_from is not None and not self.success and self.error is not None:
            self._fail("reused_from", "an error is never reused")
        if not self.stream:
            self._fail("stream", "must not be empty")
        if len(self.inputs) != len(self.input_names):
            self._fail(
                "inputs", f"{len(self.inputs)} values for {len(self.input_names)} input names"
            )
        if self.success and self.error is not None:
            self._fail("error", "a successful query has no error")
        if self.success and self.reason is not None:
            self._fail("reason", "a successful query has no failure reason")


@dataclass(frozen=True)
class ModelPrediction(_EventBase):
    """The learned models' view of a node: Eq. 1-3 per stream and the Eq. 4 cost to go."""

    type: ClassVar[str] = "model_prediction"

    node_id: int
    p_s: float  # probability that the node's next query succeeds
    r_s: float  # seconds of a successful query
    r_f: float  # seconds of a failed query
    r_m: float  # seconds to execute the produced trajectory
    q: float  # expected seconds still to spend: bound execution + Eq. 4 of the rest; finite

    def _validate(self) -> None:
        self._non_negative("node_id", "r_s", "r_f", "r_m")
        if not 0.0 <= self.p_s <= 1.0:
            self._fail("p_s", f"must be a probability, got {self.p_s}")


@dataclass(frozen=True)
class SolutionFound(_EventBase):
    type: ClassVar[str] = "solution_found"

    node_id: int  # the leaf that binds the whole plan
    plan_index: int
    planning_s: float
    execution_s: float
    oracle_s: float

    def _validate(self) -> None:
        self._non_negative("node_id", "plan_index", "planning_s", "execution_s", "oracle_s")


@dataclass(frozen=True)
class RunFinished(_EventBase):
    type: ClassVar[str] = "run_finished"

    status: str  # one of FINISH_STATUSES: the search's, or failed when its plan does not validate
    planning_s: float
    execution_s: float | None  # None unless solved
    oracle_s: float | None
    queries: int  # stream queries made
    message: str
    valid: bool | None = None  # whether the plan validated; None without a plan
    plan: dict[str, Any] | None = None  # the bound plan file (planner/plans.py), when solved
    # CPU seconds of the search's thread outside the stream queries (selection, a learned
    # planner's features and predictions, events); None for planners without a tree search.
    search_cpu_s: float | None = None
    # Wall seconds the skeleton source worked (the first skeletons and every later batch):
    # planning_s - skeleton_s is the search's. None for runs recorded before it was counted.
    skeleton_s: float | None = None

    def _validate(self) -> None:
        if self.status not in FINISH_STATUSES:
            self._fail(
                "status", f"unknown status {self.status!r} (known: {', '.join(FINISH_STATUSES)})"
            )
        self._non_negative(
            "planning_s", "execution_s", "oracle_s", "queries", "search_cpu_s", "skeleton_s"
        )


@dataclass(frozen=True)
class RunFailed(_EventBase):
    """The run stopped on an error (an exception in the planner, not a failed search)."""

    type: ClassVar[str] = "run_failed"

    error: str


@dataclass(frozen=True)
class RunCancelled(_EventBase):
    type: ClassVar[str] = "run_cancelled"

    reason: str


Event: TypeAlias = (
    RunStarted
    | SkeletonProgress
    | AbstractPlansFound
    | SkeletonsAdded
    | NodeAdded
    | NodeVisited
    | StreamQueried
    | ModelPrediction
    | SolutionFound
    | RunFinished
    | RunFailed
    | RunCancelled
)

EVENT_TYPES: dict[str, type[Event]] = {cls.type: cls for cls in get_args(Event)}

TERMINAL_TYPES = frozenset(c.type for c in (RunFinished, RunFailed, RunCancelled))  # run's last

EventT = TypeVar(
    "EventT",
    RunStarted,
    SkeletonProgress,
    AbstractPlansFound,
    SkeletonsAdded,
    NodeAdded,
    NodeVisited,
    StreamQueried,
    ModelPrediction,
    SolutionFound,
    RunFinished,
    RunFailed,
    RunCancelled,
)


# --- field checks --------------------------------------------------------------------------


# A check returns None when the value fits, else where it went wrong and why ("[0]: ...").
_Check = Callable[[Any], str | None]

_CHECKS: dict[type[_EventBase], tuple[tuple[str, _Check, bool], ...]] = {}


def _field_checks(cls: type[_EventBase]) -> tuple[tuple[str, _Check, bool], ...]:
    """(field name, check, is a float field) of an event class, compiled once."""
    checks = _CHECKS.get(cls)
    if checks is None:
        hints = get_type_hints(cls)
        checks = _CHECKS[cls] = tuple(
            (f.name, _compile(hints[f.name]), _is_float_hint(hints[f.name]))
            for f in dataclasses.fields(cls)
        )
    return checks


def _check_value(value: Any, hint: Any, where: str) -> None:
    """Raise ValueError unless ``value`` fits the annotation ``hint`` and is JSON-friendly."""
    error = _compile(hint)(value)
    if error is not None:
        raise ValueError(f"{where}{error}")


def _is_float_hint(hint: Any) -> bool:
    return hint is float or (_is_union(hint) and float in get_args(hint))


def _is_union(hint: Any) -> bool:
    return get_origin(hint) in (Union, types.UnionType)


def _compile(hint: Any) -> _Check:
    """The check for values annotated ``hint`` (the annotations events use)."""
    if hint is Any:
        return _check_json
    if _is_union(hint):
        (inner,) = [a for a in get_args(hint) if a is not type(None)]
        check_inner = _compile(inner)
        return lambda v: None if v is None else check_inner(v)
    if get_origin(hint) is list:
        check_item = _compile(get_args(hint)[0])

        def check_list(v: Any) -> str | None:
            if type(v) is not list:
                return f": expected a list, got {type(v).__name__}"
            for i, x in enumerate(v):
                error = check_item(x)
                if error is not None:
                    return f"[{i}]{error}"
            return None

        return check_list
    if get_origin(hint) is dict:
        check_value = _compile(get_args(hint)[1])

        def check_dict(v: Any) -> str | None:
            if type(v) is not dict:
                return f": expected a dict, got {type(v).__name__}"
            return _check_items(v, check_value)

        return check_dict
    if hint is float:
        return _check_number
    if hint in (int, str, bool):
        return lambda v: (
            None if type(v) is hint else f": expected {hint.__name__}, got {type(v).__name__}"
        )
    raise TypeError(f"unsupported event field annotation {hint!r}")


def _check_number(v: Any) -> str | None:
    """A float field takes any real number but bool (numpy's included; stored as a float)."""
    if type(v) is float or type(v) is int:
        return None if math.isfinite(v) else f": must be finite, got {v}"
    if isinstance(v, numbers.Real) and not isinstance(v, bool):
        return None if math.isfinite(v) else f": must be finite, got {v}"
    return f": expected a number, got {type(v).__name__}"


def _check_items(v: dict[Any, Any], check_value: _Check) -> str | None:
    for k, x in v.items():
        if type(k) is not str:
            return f": keys must be str, got {k!r}"
        error = check_value(x)
        if error is not None:
            return f"[{k!r}]{error}"
    return None


_PLAIN = frozenset({str, int, bool, type(None)})  # JSON leaves with nothing more to check
CHECKED_MIN = 8  # lists and dicts this long are remembered once found JSON-friendly
CHECKED_MAX = 65_536  # containers remembered at most (forgotten all at once beyond)
# Containers found JSON-friendly, by identity (kept, so their ids are not reused): a search's
# events share them (a state's facts list, the domain's static context), and a payload is
# never changed once emitted, so one check holds for every event that carries them.
_checked: dict[int, Any] = {}


def _check_json(v: Any) -> str | None:
    """Any JSON-friendly value: str, int, finite float, bool, None, lists and str-keyed dicts.
    The leaves of a list or dict are checked in its loop, without a call each (a query's
    context holds hundreds of them), and a long container already checked is not again."""
    kind = type(v)
    if kind in _PLAIN:
        return None
    if kind is float:
        return None if math.isfinite(v) else f": must be finite, got {v}"
    if kind is not list and kind is not dict:
        if isinstance(v, float):
            return None if math.isfinite(v) else f": must be finite, got {v}"
        return f": {kind.__name__} is not JSON-friendly"
    if _checked.get(id(v)) is v:
        return None
    if kind is list:
        for i, x in enumerate(v):
            t = type(x)
            if t in _PLAIN or (t is float and math.isfinite(x)):
                continue
            error = _check_json(x)
            if error is not None:
                return f"[{i}]{error}"
    else:
        for k, x in v.items():
            if type(k) is not str:
                return f": keys must be str, got {k!r}"
            t = type(x)
            if t in _PLAIN or (t is float and math.isfinite(x)):
                continue
            error = _check_json(x)
            if error is not None:
                return f"[{k!r}]{error}"
    if len(v) >= CHECKED_MIN:
        if len(_checked) >= CHECKED_MAX:
            _checked.clear()
        _checked[id(v)] = v
    return None


# --- (de)serialisation ---------------------------------------------------------------------


_NAMES: dict[type[_EventBase], tuple[str, ...]] = {}

_encode = json.JSONEncoder(separators=(",", ":"), allow_nan=False).encode


def _names(cls: type[_EventBase]) -> tuple[str, ...]:
    names = _NAMES.get(cls)
    if names is None:
        names = _NAMES[cls] = tuple(f.name for f in dataclasses.fields(cls))
    return names


def event_payload(event: Event) -> dict[str, Any]:
    """The fields of ``event`` other than run_id, seq and t (shares values with the event)."""
    return {n: getattr(event, n) for n in _names(type(event))[len(_BASE_FIELDS) :]}


def event_to_dict(event: Event) -> dict[str, Any]:
    """All fields plus ``"type"``; a deep copy, safe to change."""
    return {"type": event.type, **dataclasses.asdict(event)}


def event_to_json(event: Event) -> str:
    """Compact JSON of :func:`event_to_dict` (what the websocket sends)."""
    data: dict[str, Any] = {"type": event.type}
    for n in _names(type(event)):
        data[n] = getattr(event, n)
    return _encode(data)


def event_from_dict(data: dict[str, Any]) -> Event:
    """Inverse of :func:`event_to_dict`; ValueError names the unknown type or the bad field."""
    if not isinstance(data, dict):
        raise ValueError(f"an event is a JSON object, got {type(data).__name__}")
    name = data.get("type")
    cls = EVENT_TYPES.get(name) if isinstance(name, str) else None
    if cls is None:
        raise ValueError(f"unknown event type {name!r} (known: {', '.join(EVENT_TYPES)})")
    names = _names(cls)
    # A field with a default may be absent: events stored before it was added still load.
    missing = [
        f.name
        for f in dataclasses.fields(cls)
        if f.name in names
        and f.name not in data
        and f.default is dataclasses.MISSING
        and f.default_factory is dataclasses.MISSING
    ]
    if missing:
        raise ValueError(f"event {name!r} is missing field(s): {', '.join(missing)}")
    extra = sorted(set(data) - set(names) - {"type"})
    if extra:
        raise ValueError(f"event {name!r} has unknown field(s): {', '.join(extra)}")
    return cls(**{n: data[n] for n in names if n in data})


_DEFAULTS: dict[type[_EventBase], tuple[tuple[str, Callable[[], Any] | None], ...]] = {}


def _defaults(cls: type[_EventBase]) -> tuple[tuple[str, Callable[[], Any] | None], ...]:
    """(field name, what makes its default; None: no default) of an event class."""
    out = _DEFAULTS.get(cls)
    if out is None:
        made: list[tuple[str, Callable[[], Any] | None]] = []
        for f in dataclasses.fields(cls):
            if f.default is not dataclasses.MISSING:
                made.append((f.name, _constant(f.default)))
            elif f.default_factory is not dataclasses.MISSING:
                made.append((f.name, f.default_factory))
            else:
                made.append((f.name, None))
        out = _DEFAULTS[cls] = tuple(made)
    return out


def _constant(value: Any) -> Callable[[], Any]:
    return lambda: value


def event_from_stored(data: dict[str, Any]) -> Event:
    """An event from the dict of one the store wrote, without checking its fields again (each
    was checked when the event was made, before it was stored): a few times cheaper than
    :func:`event_from_dict` for a whole tree. A field added since the event was stored takes
    its default. ValueError for an unknown type or a field without a value."""
    name = data.get("type")
    cls = EVENT_TYPES.get(name) if isinstance(name, str) else None
    if cls is None:
        raise ValueError(f"unknown event type {name!r} (known: {', '.join(EVENT_TYPES)})")
    event = object.__new__(cls)
    for field_name, default in _defaults(cls):
        if field_name in data:
            value = data[field_name]
        elif default is not None:
            value = default()
        else:
            raise ValueError(f"event {name!r} is missing field {field_name!r}")
        object.__setattr__(event, field_name, value)
    return event


def event_from_json(text: str | bytes) -> Event:
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"an event is not valid JSON: {exc}") from exc
    return event_from_dict(data)


# --- sinks ---------------------------------------------------------------------------------


class EventSink(Protocol):
    """Receives a run's events in ``seq`` order; ``close`` when the run is over."""

    def emit(self, event: Event) -> None: ...

    def close(self) -> None: ...


class ListSink:
    """Keeps every event in :attr:`events` (tests, small tools)."""

    def __init__(self) -> None:
        self.events: list[Event] = []
        self.closed = False

    def emit(self, event: Event) -> None:
        self.events.append(event)

    def close(self) -> None:
        self.closed = True


class FanOutSink:
    """Forwards each event to several sinks. A sink that raises is logged, closed and dropped:
    a broken listener never stops the planner."""

    def __init__(self, *sinks: EventSink) -> None:
        self._sinks: list[EventSink] = list(sinks)

    @property
    def sinks(self) -> tuple[EventSink, ...]:
        """The sinks still receiving events."""
        return tuple(self._sinks)

    def emit(self, event: Event) -> None:
        broken: list[EventSink] = []
        for sink in self._sinks:
            try:
                sink.emit(event)
            except Exception:
                log.exception(
                    "event sink %r failed on %s #%d; dropping it", sink, event.type, event.seq
                )
                broken.append(sink)
        for sink in broken:
            self._sinks.remove(sink)
            self._close(sink)

    def close(self) -> None:
        sinks, self._sinks = self._sinks, []
        for sink in sinks:
            self._close(sink)

    @staticmethod
    def _close(sink: EventSink) -> None:
        try:
            sink.close()
        except Exception:
            log.exception("event sink %r failed to close", sink)


class BatchingSink:
    """Hands events to ``write`` in batches, one call per batch, in ``seq`` order.

    ``emit`` only appends to a buffer; the buffer is written when it holds ``batch_size``
    events, when the run's last event (finished / failed / cancelled) arrives, when its oldest
    event is ``flush_interval_s`` old, and on ``close``. With a ``flush_interval_s`` a
    background writer thread writes full and stale batches (woken by ``emit``, and every half
    interval, so a long stream query does not hold events back): the planner's thread never
    waits for a database's commit, only for the run's last event, at ``close``, and when the
    writer falls behind by ``BACKLOG`` batches (then ``emit`` writes, so the buffer stays
    bounded). Without one, ``emit`` writes them itself. A failed write keeps the batch for the
    next attempt: events are never dropped silently. Subclasses check each event in
    :meth:`_accept` (called under the buffer lock).
    """

    BACKLOG = 4  # batches buffered before emit writes itself

    def __init__(
        self,
        write: Callable[[list[Event]], None],
        *,
        name: str = "batching-sink",
        batch_size: int = 200,
        flush_interval_s: float | None = 0.5,
    ) -> None:
        if batch_size < 1:
            raise ValueError(f"batch_size must be >= 1, got {batch_size}")
        if flush_interval_s is not None and flush_interval_s <= 0:
            raise ValueError(f"flush_interval_s must be positive, got {flush_interval_s}")
        self._write = write
        self.batch_size = batch_size
        self.flush_interval_s = flush_interval_s
        self._buffer: list[Event] = []
        self._oldest: float | None = None  # perf_counter when the oldest buffered event came
        self._lock = threading.Lock()  # guards the buffer
        self._write_lock = threading.Lock()  # one batch at a time, in seq order
        self._closed = False
        self._stop = threading.Event()
        self._wake = threading.Event()  # a full or stale batch for the writer thread
        self._timer: threading.Thread | None = None
        self.writer_cpu_s = 0.0  # CPU seconds the writer thread spent writing batches
        if flush_interval_s is not None:
            self._timer = threading.Thread(target=self._flush_periodically, name=name, daemon=True)
            self._timer.start()

    def _accept(self, event: Event) -> None:
        """Raise if ``event`` does not belong here (called under the buffer lock)."""

    def emit(self, event: Event) -> None:
        with self._lock:
            if self._closed:
                raise RuntimeError(f"{self!r} is closed; event {event.type} #{event.seq} lost")
            self._accept(event)
            self._buffer.append(event)
            now = time.perf_counter()
            if self._oldest is None:
                self._oldest = now
            ready = len(self._buffer) >= self.batch_size or self._stale(now)
            due = (
                event.type in TERMINAL_TYPES
                or len(self._buffer) >= self.BACKLOG * self.batch_size
                or (ready and self._timer is None)
            )
        if due:
            self.flush()
        elif ready:
            self._wake.set()

    def flush(self) -> None:
        """Write everything buffered now."""
        with self._write_lock:
            with self._lock:
                batch, self._buffer = self._buffer, []
                oldest, self._oldest = self._oldest, None
            if not batch:
                return
            try:
                self._write(batch)
            except Exception:
                with self._lock:  # put the batch back in front, in order, for the next attempt
                    self._buffer[:0] = batch
                    self._oldest = oldest
                raise

    def close(self) -> None:
        """Stop the timer and write what is left; safe to call twice."""
        with self._lock:
            self._closed = True
        self._stop.set()
        self._wake.set()
        if self._timer is not None and self._timer is not threading.current_thread():
            self._timer.join()
        self.flush()

    def _stale(self, now: float) -> bool:
        return (
            self.flush_interval_s is not None
            and self._oldest is not None
            and now - self._oldest >= self.flush_interval_s
        )

    def _flush_periodically(self) -> None:
        """The writer thread: full batches when emit wakes it, stale ones every half interval."""
        assert self.flush_interval_s is not None
        while not self._stop.is_set():
            self._wake.wait(self.flush_interval_s / 2)
            self._wake.clear()
            if self._stop.is_set():
                return  # close writes what is left
            with self._lock:
                ready = len(self._buffer) >= self.batch_size or self._stale(time.perf_counter())
            if ready:
                cpu = time.thread_time()
                try:
                    self.flush()
                except Exception:
                    log.exception("%r: writing events failed; will retry", self)
                    self._stop.wait(self.flush_interval_s / 2)  # not at once: it just failed
                finally:
                    self.writer_cpu_s += time.thread_time() - cpu


class Emitter:
    """Stamps events of one run with ``run_id``, the next ``seq`` and ``t``, then emits them.

    ``t`` is seconds since the emitter was made, read from ``clock`` (default
    :func:`time.perf_counter`) and never decreasing. Thread-safe: events reach the sink in
    ``seq`` order. Sink errors propagate; wrap sinks in :class:`FanOutSink` to isolate them.
    """

    def __init__(
        self, run_id: str, sink: EventSink, clock: Callable[[], float] | None = None
    ) -> None:
        if not run_id:
            raise ValueError("run_id must not be empty")
        self.run_id = run_id
        self.sink = sink
        self._clock = clock or time.perf_counter
        self._start = self._clock()
        self._seq = 0
        self._t = 0.0
        self._lock = threading.Lock()

    @property
    def next_seq(self) -> int:
        return self._seq

    def elapsed(self) -> float:
        """Seconds since the emitter was made (the ``t`` an event made now would get)."""
        return max(self._clock() - self._start, self._t)

    def emit(self, cls: type[EventT], **fields: Any) -> EventT:
        with self._lock:
            self._t = self.elapsed()
            event = cls(run_id=self.run_id, seq=self._seq, t=self._t, **fields)
            self._seq += 1
            self.sink.emit(event)
        return event
