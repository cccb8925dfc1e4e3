"""The public domain interface: :class:`DomainSpec` (what a domain's module exports),
:class:`LoadedDomain` (a spec with its parsed PDDL, as every generic layer uses it) and the types
of the hooks, :class:`StateFeatures` among them (the learned models' features of the state;
``planner.learning.features`` re-exports it).

docs/domains.md walks through writing one; ``examples/tabletop2d/`` is a complete example.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from planner.abstract.skeleton import GroundAction
from planner.pddl.parser import load_problem
from planner.pddl.structs import Domain, Problem, StreamSet
from planner.scene import Scene
from planner.streams.adapters import StreamAdapter
from planner.streams.runtime import StreamRuntime, bind_streams
from planner.values import JSON, ValueCodec, ValueType

if TYPE_CHECKING:  # numpy only in annotations: the domain interface loads without it
    import numpy as np
    import numpy.typing as npt

    from planner.view import DomainView

ProblemBuilder = Callable[[Scene, Domain, int], Problem]  # scene, parsed domain, seed
# stream name -> adapter (or, for a (:function ...) or (:predicate ...), a plain function)
BindingFactory = Callable[
    [Problem, random.Random], Mapping[str, StreamAdapter | Callable[..., Any]]
]
StaticContext = Callable[[Problem], Mapping[str, Any]]  # JSON facts of the scene, per problem


@dataclass(frozen=True)
class PlanCheck:
    """What a plan validator says of a bound plan."""

    ok: bool
    message: str  # "valid ..." or where and why it fails
    execution_s: float | None = None  # seconds to execute the plan, when the validator knows


# The bound plan's actions, the values of its objects (optimistic ones bound), the problem.
PlanValidator = Callable[[Sequence[GroundAction], Mapping[str, Any], Problem], PlanCheck]
# Seconds to execute what a stream produced: (stream name, its output values, the problem).
ExecutionSeconds = Callable[[str, tuple[Any, ...], Problem], float]


# --- the feature hook: what planner.learning.features asks of a domain ----------------------------

Context = Mapping[str, Any]  # {"facts": [[pred, *args], ...], "values": {name: JSON}, ...}


class QueryLike(Protocol):
    """What fitting reads of a recorded query (:class:`planner.store.QueryRecord` is one)."""

    @property
    def stream(self) -> str: ...

    @property
    def inputs(self) -> list[Any]: ...

    @property
    def context(self) -> dict[str, Any]: ...


class StateEncoder(Protocol):
    """A fitted encoding of the state (and of anything else per stream): saved in the model."""

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON data, with ``"kind"`` (the :class:`StateFeatures` that reloads it)."""
        ...

    @property
    def scene_width(self) -> int:
        """Numbers of the state part (the same for every stream)."""
        ...

    def stream_width(self, stream: str) -> int:
        """Numbers of the stream part after the input slots (0 for most streams)."""
        ...

    def stream_features(
        self, stream: str, inputs: Sequence[JSON | None], context: Context
    ) -> Sequence[float]:
        """The stream part of a row (``stream_width`` numbers)."""
        ...

    def scene_features(self, context: Context, out: npt.NDArray[np.float32], offset: int) -> None:
        """Write the state part into ``out[offset : offset + scene_width]`` (zeroed before)."""
        ...

    def feature_names(self, stream: str) -> tuple[list[str], list[str]]:
        """Column names of the stream part and of the state part."""
        ...

    def finish_row(
        self,
        stream: str,
        inputs: Sequence[JSON | None],
        row: npt.NDArray[np.float32],
        slots: Sequence[tuple[str, int, int]],
    ) -> None:
        """Adjust a finished row in place (``slots``: kind, offset and width of each input
        slot); most encoders do nothing here."""
        ...


class StateFeatures(Protocol):
    """A domain's feature hook: fits a :class:`StateEncoder` on recorded queries and reloads one
    from a model file."""

    @property
    def kind(self) -> str:
        """The name saved in model files (``"facts"``, ``"kitchen"``)."""
        ...

    def fit(self, records: Sequence[QueryLike], codec: ValueCodec) -> StateEncoder: ...

    def load(self, data: Mapping[str, Any], codec: ValueCodec) -> StateEncoder: ...


@dataclass(frozen=True)
class DomainSpec:
    """One domain, as its module exports it (``DOMAIN = DomainSpec(...)``).

    The folder holding the module also holds ``domain.pddl`` and ``stream.pddl`` (and usually a
    ``scenes/`` folder of scene files). Only ``name``, ``problem_from_scene`` and ``bindings``
    are required; every hook has a default (see each field).
    """

    name: str  # what scene files and models call the domain
    problem_from_scene: ProblemBuilder  # objects, init, goal and values from a scene file
    bindings: BindingFactory | None  # stream name -> sampler; None: no samplers yet
    # Kinds of values the samplers produce, each with a JSON codec and a feature encoder.
    # Strings, numbers and number sequences need none (built in).
    value_types: tuple[ValueType, ...] = ()
    validate: PlanValidator | None = None  # None: the plan is replayed symbolically
    # How long the robot takes to execute what a stream produced (a PDDLStream trajectory that
    # is a plain list of configurations); None: the outputs' own ``seconds`` properties.
    execution_s: ExecutionSeconds | None = None
    # What every query's context carries besides its state (JSON, e.g. the sizes of the
    # scene's tables); recorded with each query and given to the learned models.
    static_context: StaticContext | None = None
    view: DomainView | None = None  # the 3D view's hook; None: "no 3D view for this domain"
    # Feature encoding of the state where a stream's output is needed, for the learned models.
    # None: the generic encoding of the fluent facts and their values (planner/learning).
    features: StateFeatures | None = None
    # Per stream, the value kind of each input (e.g. ("name", "pose")); None: learned from the
    # recorded queries when a model is fit. Needed only for streams that may go unrecorded.
    input_kinds: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    model: Path | None = None  # a model file shipped with the domain (learned's default)
    description: str = ""  # one line for listings
    # Search hints (docs/search.md): actions that only reorder (see AbstractConfig) ...
    diversity_ignore: tuple[str, ...] = ()
    # ... fluents that do not change a stream's outcome (a dead end is not blamed on them) ...
    evidence_ignore: tuple[str, ...] = ()
    # ... and per stream, fluents of its context its sampler never reads (the model's stream
    # order, planner/search/order.py, need not bind the objects they name first).
    unread: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    # Where its domain.pddl and stream.pddl are (a PDDLStream example's own folder, say); None:
    # the module's folder. A folder domain keeps its module and scenes in its folder either way.
    directory: Path | None = None
    # Refuse what PDDLStream's leniency accepts (undeclared predicates and functions, repeated
    # declarations; `tamp check` lists them); False: accept them with a warning
    strict: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.replace("-", "_").isidentifier():
            raise ValueError(f"domain name {self.name!r}: letters, digits, '-' and '_' only")
        if not callable(self.problem_from_scene):
            raise ValueError(f"domain {self.name!r}: problem_from_scene must be a function")
        if self.bindings is not None and not callable(self.bindings):
            raise ValueError(f"domain {self.name!r}: bindings must be a function or None")
        if self.execution_s is not None and not callable(self.execution_s):
            raise ValueError(f"domain {self.name!r}: execution_s must be a function or None")


def _problem_durations(
    hook: ExecutionSeconds, problem: Problem
) -> Callable[[str, tuple[Any, ...]], float]:
    def durations(stream: str, outputs: tuple[Any, ...]) -> float:
        return hook(stream, outputs, problem)

    return durations


@dataclass(frozen=True)
class LoadedDomain:
    """A domain ready to use: its spec, parsed PDDL, where it came from and its value codec."""

    spec: DomainSpec
    domain: Domain
    streams: StreamSet
    directory: Path  # the folder of domain.pddl and stream.pddl
    source: str  # how it was found: "folder PATH" or "entry point NAME = MODULE:ATTR"
    codec: ValueCodec = field(repr=False)
    # The folder it was loaded from (a domain found by path): its module and its scenes. Its
    # PDDL files are there too unless DomainSpec.directory names another folder. None for an
    # installed domain (an entry point).
    folder: Path | None = None

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def home(self) -> Path:
        """The domain's own folder: the one it was loaded from, else that of its PDDL files."""
        return self.folder if self.folder is not None else self.directory

    @property
    def scenes_dir(self) -> Path:
        """Where the domain keeps its scene files (may not exist)."""
        return self.home / "scenes"

    @property
    def reference(self) -> str | None:
        """What a run records to load this domain again in another process: the folder of a
        domain loaded by path; None for an installed one (its name says it)."""
        return None if self.folder is None else str(self.folder)

    def problem_from_scene(self, scene: Scene, *, seed: int = 0) -> Problem:
        """The scene's problem; ``seed`` draws its randomised parts."""
        return self.spec.problem_from_scene(scene, self.domain, seed)

    def problem_from_file(self, path: str | Path) -> Problem:
        return load_problem(path, self.domain)

    def static_context(self, problem: Problem) -> dict[str, Any]:
        """The scene facts every query's context carries (empty for most domains)."""
        if self.spec.static_context is None:
            return {}
        return dict(self.spec.static_context(problem))

    def runtime(self, problem: Problem, *, seed: int) -> StreamRuntime:
        """Samplers bound to the declared streams, seeded."""
        if self.spec.bindings is None:
            raise NotImplementedError(f"domain {self.name!r} has no stream samplers yet")
        hook = self.spec.execution_s
        durations = None if hook is None else _problem_durations(hook, problem)
        return bind_streams(
            self.streams,
            self.spec.bindings(problem, random.Random(seed)),
            strict=self.spec.strict,
            durations=durations,
        )

    def encode(self, value: Any) -> JSON:
        """A value as JSON, by the domain's value types."""
        return self.codec.encode(value)

    def decode(self, data: JSON, where: str) -> Any:
        """The value of ``data``; ValueDecodeError names ``where`` and what is wrong."""
        return self.codec.decode(data, where)

    @property
    def fluents(self) -> frozenset[str]:
        """The predicates some action adds or deletes (conditional effects included)."""
        return self.domain.fluent_predicates
