"""What a search's queries prove about the optimistic task, for the skeleton source.

Every query answers for one stream instance of the optimistic task: its stream and inputs,
optimistic objects included (``inverse-kinematics(b1 opt-p3 opt-g1)`` stands for every value
the search draws for ``opt-p3``). :class:`InstanceRecords` counts, per instance and over every
plan and node that asked it, the queries a sampler answered and their successes, and turns them
into a :class:`~planner.abstract.source.Feedback`:

- **false**: an instance whose inputs are all real objects (no optimistic one) that failed with
  no success, when that proves it: a test's answer on fixed inputs (unless its stream reads
  fluents, whose answer depends on the state), or a stream that said it has nothing more before
  giving anything;
- **doubted**: any other instance asked ``doubt_after`` times with no success.

An answer taken from an identical earlier query is no new evidence and is not counted.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from planner.abstract.instantiate import OPTIMISTIC_PREFIX, StreamInstance
from planner.abstract.source import Feedback
from planner.pddl.structs import Atom
from planner.streams.runtime import QueryResult

InstanceKey = tuple[str, tuple[str, ...]]  # a stream instance of the task: stream, inputs

DOUBT_AFTER = 8  # queries with no success before an instance is doubted (0: never)


@dataclass
class InstanceRecord:
    """What the queries of one stream instance of the optimistic task have shown."""

    instance: StreamInstance
    queries: int = 0
    successes: int = 0
    empty: bool = False  # its stream said "nothing more" before it gave anything


class InstanceRecords:
    """The records of one search (see the module); ``on_doubts`` hears the set of doubted
    (or false) instances each time it changes."""

    def __init__(
        self,
        *,
        doubt_after: int = DOUBT_AFTER,
        fluent_streams: frozenset[str] = frozenset(),
        on_doubts: Callable[[frozenset[InstanceKey]], None] | None = None,
    ) -> None:
        if doubt_after < 0:
            raise ValueError(f"doubt_after must be 0 (never) or positive, got {doubt_after}")
        self.doubt_after = doubt_after
        self.fluent_streams = fluent_streams
        self.on_doubts = on_doubts
        self.records: dict[InstanceKey, InstanceRecord] = {}
        self.doubted: frozenset[InstanceKey] = frozenset()  # false ones too
        self._feedback: Feedback | None = None  # as of the last change

    def __len__(self) -> int:
        return len(self.records)

    def record(self, inst: StreamInstance, result: QueryResult) -> None:
        """One query a sampler answered for ``inst``."""
        key = (inst.stream, inst.inputs)
        record = self.records.get(key)
        if record is None:
            record = self.records[key] = InstanceRecord(inst)
        record.queries += 1
        if result.success:
            record.successes += 1
        elif result.exhausted and record.successes == 0:
            record.empty = True
        self._feedback = None
        before = self.doubted
        if key not in before and self._proves(record) is not None:
            self.doubted = before | {key}
        elif key in before and record.successes:
            self.doubted = before - {key}  # possible after all
        if self.doubted is not before and self.on_doubts is not None:
            self.on_doubts(self.doubted)

    def _proves(self, record: InstanceRecord) -> str | None:
        """ "false", "doubted" or None: what the record says of its instance's facts."""
        if record.successes or record.instance.kind != "stream" or not record.queries:
            return None
        inst = record.instance
        real = not any(name.startswith(OPTIMISTIC_PREFIX) for name in inst.inputs)
        test = not inst.outputs and inst.stream not in self.fluent_streams
        if real and (record.empty or test):
            return "false"
        if self.doubt_after and record.queries >= self.doubt_after:
            return "doubted"
        return None

    def feedback(self) -> Feedback:
        """The facts proved false and the facts doubted (see the module)."""
        if self._feedback is not None:
            return self._feedback
        false: set[Atom] = set()
        doubted: set[Atom] = set()
        for record in self.records.values():
            verdict = self._proves(record)
            if verdict == "false":
                false.update(record.instance.certified)
            elif verdict == "doubted":
                doubted.update(record.instance.certified)
        self._feedback = Feedback(frozenset(false), frozenset(doubted - false))
        return self._feedback
