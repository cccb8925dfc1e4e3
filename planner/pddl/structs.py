"""Core types of the problem language: frozen dataclasses with checked invariants.

Terms are plain strings: a variable starts with ``?``, anything else is an object name.
Formulas are trees of :class:`Literal` (an atom or its negation), :class:`And`, :class:`Or`,
:class:`Not`, :class:`Imply`, :class:`Exists` and :class:`ForAll`; an action keeps the
literal conjuncts of its precondition apart (``preconditions``) from the others
(``conditions``), and its plain effects apart from conditional or quantified ones.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from typing import Literal as TypingLiteral

OBJECT_TYPE = "object"  # the root of every type hierarchy
EQUALITY = "="  # the built-in equality predicate
TOTAL_COST = "total-cost"  # the action-cost function of :action-costs


def is_variable(term: str) -> bool:
    """True for ``?x``-style variables."""
    return term.startswith("?")


def _repeated(names: Iterable[str]) -> list[str]:
    """Names that occur more than once, in order of their second occurrence (linear time)."""
    seen: set[str] = set()
    dupes: dict[str, None] = {}
    for n in names:
        if n in seen:
            dupes[n] = None
        seen.add(n)
    return list(dupes)


def _check_unique(names: Iterable[str], message: str) -> None:
    dupes = _repeated(names)
    if dupes:
        raise ValueError(f"{message} {sorted(dupes)}")


@dataclass(frozen=True, order=True)
class Atom:
    """A predicate applied to terms, e.g. ``(on ?b table)``."""

    predicate: str
    args: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.predicate:
            raise ValueError("an atom needs a predicate name")

    def substitute(self, mapping: Mapping[str, str]) -> Atom:
        """Replace every term found in ``mapping``; others stay."""
        get = mapping.get
        return Atom(self.predicate, tuple([get(a, a) for a in self.args]))

    @property
    def variables(self) -> tuple[str, ...]:
        return tuple([a for a in self.args if a[:1] == "?"])

    def __str__(self) -> str:
        return f"({' '.join((self.predicate, *self.args))})"


@dataclass(frozen=True, order=True)
class Literal:
    """An atom or its negation; ``(= ?a ?b)`` is an atom with predicate ``=``."""

    atom: Atom
    positive: bool = True

    @property
    def is_equality(self) -> bool:
        return self.atom.predicate == EQUALITY

    def substitute(self, mapping: Mapping[str, str]) -> Literal:
        return Literal(self.atom.substitute(mapping), self.positive)

    def __str__(self) -> str:
        return str(self.atom) if self.positive else f"(not {self.atom})"


@dataclass(frozen=True)
class TypedName:
    """A parameter, object or type name with its (parent) type.

    ``either`` holds the alternatives of an ``(either t1 t2)`` type (``type`` is then
    ``object``): the name stands for an object of any of them.
    """

    name: str
    type: str = OBJECT_TYPE
    either: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.name:
            raise ValueError("empty name")
        if self.either and self.type != OBJECT_TYPE:
            raise ValueError(f"{self.name}: an (either ...) type has no single type")

    @property
    def types(self) -> tuple[str, ...]:
        """The types an object for this name may have (one, or the ``either`` alternatives)."""
        return self.either or (self.type,)

    def type_text(self) -> str:
        return f"(either {' '.join(self.either)})" if self.either else self.type


def _check_quantified(kind: str, variables: tuple[TypedName, ...]) -> None:
    if not variables:
        raise ValueError(f"({kind} () ...) quantifies no variable")
    for v in variables:
        if not is_variable(v.name):
            raise ValueError(f"({kind} ...): {v.name!r} must start with '?'")
    _check_unique((v.name for v in variables), f"({kind} ...) repeats a variable:")


def _typed_text(names: Iterable[TypedName]) -> str:
    return " ".join(f"{n.name} - {n.type_text()}" for n in names)


@dataclass(frozen=True)
class And:
    """A conjunction; ``(and)`` is true."""

    parts: tuple[Formula, ...]

    def substitute(self, mapping: Mapping[str, str]) -> And:
        return And(tuple(p.substitute(mapping) for p in self.parts))

    def __str__(self) -> str:
        return "(and " + " ".join(map(str, self.parts)) + ")" if self.parts else "(and)"


@dataclass(frozen=True)
class Or:
    """A disjunction; ``(or)`` is false."""

    parts: tuple[Formula, ...]

    def substitute(self, mapping: Mapping[str, str]) -> Or:
        return Or(tuple(p.substitute(mapping) for p in self.parts))

    def __str__(self) -> str:
        return "(or " + " ".join(map(str, self.parts)) + ")" if self.parts else "(or)"


@dataclass(frozen=True)
class Not:
    """The negation of a compound formula (a negated atom is a :class:`Literal`)."""

    part: Formula

    def __post_init__(self) -> None:
        if isinstance(self.part, Literal):
            raise ValueError("a negated atom is a Literal with positive=False, not Not(...)")

    def substitute(self, mapping: Mapping[str, str]) -> Not:
        return Not(self.part.substitute(mapping))

    def __str__(self) -> str:
        return f"(not {self.part})"


@dataclass(frozen=True)
class Imply:
    """``(imply condition consequence)``: the consequence holds wherever the condition does."""

    condition: Formula
    consequence: Formula

    def substitute(self, mapping: Mapping[str, str]) -> Imply:
        return Imply(self.condition.substitute(mapping), self.consequence.substitute(mapping))

    def __str__(self) -> str:
        return f"(imply {self.condition} {self.consequence})"


def _bound_mapping(mapping: Mapping[str, str], variables: tuple[TypedName, ...]) -> dict[str, str]:
    """``mapping`` without the quantified variables (they shadow outer names)."""
    names = {v.name for v in variables}
    return {k: v for k, v in mapping.items() if k not in names}


@dataclass(frozen=True)
class Exists:
    """``(exists (?x - t ...) body)``."""

    variables: tuple[TypedName, ...]
    body: Formula

    def __post_init__(self) -> None:
        _check_quantified("exists", self.variables)

    def substitute(self, mapping: Mapping[str, str]) -> Exists:
        return Exists(self.variables, self.body.substitute(_bound_mapping(mapping, self.variables)))

    def __str__(self) -> str:
        return f"(exists ({_typed_text(self.variables)}) {self.body})"


@dataclass(frozen=True)
class ForAll:
    """``(forall (?x - t ...) body)``."""

    variables: tuple[TypedName, ...]
    body: Formula

    def __post_init__(self) -> None:
        _check_quantified("forall", self.variables)

    def substitute(self, mapping: Mapping[str, str]) -> ForAll:
        return ForAll(self.variables, self.body.substitute(_bound_mapping(mapping, self.variables)))

    def __str__(self) -> str:
        return f"(forall ({_typed_text(self.variables)}) {self.body})"


Formula = Literal | And | Or | Not | Imply | Exists | ForAll


def conjunction(parts: Iterable[Formula]) -> Formula:
    """One formula for ``parts`` (the part itself when there is one)."""
    items = tuple(parts)
    return items[0] if len(items) == 1 else And(items)


def free_variables(formula: Formula) -> frozenset[str]:
    """Variables of ``formula`` that no quantifier inside it binds."""
    if isinstance(formula, Literal):
        return frozenset(formula.atom.variables)
    if isinstance(formula, And | Or):
        return frozenset().union(*(free_variables(p) for p in formula.parts))
    if isinstance(formula, Not):
        return free_variables(formula.part)
    if isinstance(formula, Imply):
        return free_variables(formula.condition) | free_variables(formula.consequence)
    return free_variables(formula.body) - {v.name for v in formula.variables}


def literals(formula: Formula, positive: bool = True) -> Iterator[tuple[Literal, bool]]:
    """Every literal of ``formula`` with whether it occurs positively (an even number of
    negations, counting an implication's condition as one) once the literal's own sign is
    taken into account: ``(not (p))`` inside ``(not ...)`` occurs positively."""
    if isinstance(formula, Literal):
        yield formula, formula.positive == positive
    elif isinstance(formula, And | Or):
        for p in formula.parts:
            yield from literals(p, positive)
    elif isinstance(formula, Not):
        yield from literals(formula.part, not positive)
    elif isinstance(formula, Imply):
        yield from literals(formula.condition, not positive)
        yield from literals(formula.consequence, positive)
    else:
        yield from literals(formula.body, positive)


def quantified_types(formula: Formula) -> Iterator[TypedName]:
    """Every variable a quantifier inside ``formula`` binds."""
    if isinstance(formula, And | Or):
        for p in formula.parts:
            yield from quantified_types(p)
    elif isinstance(formula, Not):
        yield from quantified_types(formula.part)
    elif isinstance(formula, Imply):
        yield from quantified_types(formula.condition)
        yield from quantified_types(formula.consequence)
    elif isinstance(formula, Exists | ForAll):
        yield from formula.variables
        yield from quantified_types(formula.body)


InferenceKind = TypingLiteral["predicate", "function", "derived", "repeat"]


@dataclass(frozen=True)
class Inference:
    """A declaration the files left out, made from its first use (PDDLStream's leniency), or a
    repeated declaration that agrees with the first, accepted. ``tamp check`` lists them; a
    strict parse refuses each as an error at the same place.

    ``kind``: ``predicate`` or ``function`` declared by a use (``use`` says where: ``action
    move``, ``stream sample-grasp :domain``, ``init``, ...); ``derived`` a derived predicate
    declared by its ``:derived`` head; ``repeat`` a predicate or function declared twice alike.
    """

    kind: InferenceKind
    name: str
    arity: int
    file: str
    line: int
    column: int
    use: str
    near: str = ""  # a declared name one letter away (a likely typo), or ""

    @property
    def place(self) -> str:
        return f"{self.file}:{self.line}:{self.column}"

    @property
    def message(self) -> str:
        args = f"{self.arity} argument{'' if self.arity == 1 else 's'}"
        typo = f" (did you mean {self.near!r}?)" if self.near else ""
        if self.kind == "predicate":
            return (
                f"predicate {self.name!r} ({args}) is not in :predicates; declared by its use "
                f"in {self.use}{typo}"
            )
        if self.kind == "function":
            return (
                f"function {self.name!r} ({args}) is not in :functions; declared by its use "
                f"in {self.use}{typo}"
            )
        if self.kind == "derived":
            return (
                f"derived predicate {self.name!r} ({args}) is not in :predicates; declared by "
                "its (:derived ...) head"
            )
        return f"{self.use}; the repeat is ignored"

    def __str__(self) -> str:
        return f"{self.place}: {self.message}"


@dataclass(frozen=True)
class Predicate:
    name: str
    params: tuple[TypedName, ...] = ()

    @property
    def arity(self) -> int:
        return len(self.params)


@dataclass(frozen=True, order=True)
class FunctionTerm:
    """A numeric function applied to terms, e.g. ``(dist ?q1 ?q2)``."""

    name: str
    args: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.name:
            raise ValueError("a function term needs a function name")

    def substitute(self, mapping: Mapping[str, str]) -> FunctionTerm:
        return FunctionTerm(self.name, tuple(mapping.get(a, a) for a in self.args))

    @property
    def variables(self) -> tuple[str, ...]:
        return tuple(a for a in self.args if is_variable(a))

    def __str__(self) -> str:
        return f"({' '.join((self.name, *self.args))})"


@dataclass(frozen=True)
class FunctionDecl:
    """A numeric function of the domain's ``(:functions ...)`` other than ``total-cost``."""

    name: str
    params: tuple[TypedName, ...] = ()

    @property
    def arity(self) -> int:
        return len(self.params)


def _check_variables(owner: str, known: set[str], atoms: Iterable[Atom | FunctionTerm]) -> None:
    for atom in atoms:
        for term in atom.variables:
            if term not in known:
                raise ValueError(f"{owner}: variable {term} in {atom} is not a parameter")


def _check_formula(owner: str, known: set[str], formula: Formula) -> None:
    extra = sorted(free_variables(formula) - known)
    if extra:
        raise ValueError(f"{owner}: variable {extra[0]} in {formula} is not a parameter")


@dataclass(frozen=True)
class ConditionalEffect:
    """``(forall (vars) (when condition effects))``: for every binding of ``variables``
    under which ``condition`` holds (before the action), add ``adds`` and delete ``dels``.
    Either part may be missing: no variables, or no condition (``None``)."""

    variables: tuple[TypedName, ...]
    condition: Formula | None
    adds: tuple[Atom, ...]
    dels: tuple[Atom, ...]

    def __post_init__(self) -> None:
        if not self.adds and not self.dels:
            raise ValueError("a conditional effect changes nothing")
        if self.variables:
            _check_quantified("forall", self.variables)
        if not self.variables and self.condition is None:
            raise ValueError("an effect with neither forall nor when is a plain effect")

    def check(self, owner: str, params: set[str]) -> None:
        known = params | {v.name for v in self.variables}
        if self.condition is not None:
            _check_formula(owner, known, self.condition)
        _check_variables(owner, known, self.adds + self.dels)

    def substitute(self, mapping: Mapping[str, str]) -> ConditionalEffect:
        inner = _bound_mapping(mapping, self.variables)
        return ConditionalEffect(
            self.variables,
            None if self.condition is None else self.condition.substitute(inner),
            tuple(a.substitute(inner) for a in self.adds),
            tuple(a.substitute(inner) for a in self.dels),
        )

    def __str__(self) -> str:
        parts = [str(a) for a in self.adds] + [f"(not {a})" for a in self.dels]
        text = parts[0] if len(parts) == 1 else "(and " + " ".join(parts) + ")"
        if self.condition is not None:
            text = f"(when {self.condition} {text})"
        if self.variables:
            text = f"(forall ({_typed_text(self.variables)}) {text})"
        return text


@dataclass(frozen=True)
class Action:
    """An action schema: a precondition, effects and an optional cost.

    ``preconditions`` are the literal conjuncts of the precondition and ``conditions`` the
    others (``or``, ``exists``, ...); ``add_effects``/``del_effects`` always happen and
    ``effects`` are the conditional or quantified ones. The cost is ``cost`` (a number) plus
    the values of ``cost_terms`` (``(increase (total-cost) (dist ?a ?b))``).
    """

    name: str
    params: tuple[TypedName, ...]
    preconditions: tuple[Literal, ...]
    add_effects: tuple[Atom, ...]
    del_effects: tuple[Atom, ...]
    cost: float | None = None  # (increase (total-cost) N), if the domain uses action costs
    conditions: tuple[Formula, ...] = ()
    effects: tuple[ConditionalEffect, ...] = ()
    cost_terms: tuple[FunctionTerm, ...] = ()

    def __post_init__(self) -> None:
        names = [p.name for p in self.params]
        if len(set(names)) != len(names):
            raise ValueError(f"action {self.name}: repeated parameter")
        known = set(names)
        owner = f"action {self.name}"
        _check_variables(owner, known, (lit.atom for lit in self.preconditions))
        _check_variables(owner, known, self.add_effects + self.del_effects)
        _check_variables(owner, known, self.cost_terms)
        for formula in self.conditions:
            if isinstance(formula, Literal):
                raise ValueError(f"{owner}: the literal {formula} belongs in preconditions")
            _check_formula(owner, known, formula)
        for effect in self.effects:
            effect.check(owner, known)
        if self.cost is not None and self.cost < 0:
            raise ValueError(f"action {self.name}: negative cost {self.cost}")

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.params)

    @property
    def precondition(self) -> Formula:
        """The whole precondition as one formula."""
        return And((*self.preconditions, *self.conditions))

    @property
    def is_strips(self) -> bool:
        """Literal preconditions, plain effects, no function-valued cost, no (either ...)."""
        return (
            not self.conditions
            and not self.effects
            and not self.cost_terms
            and not any(p.either for p in self.params)
        )


@dataclass(frozen=True)
class DerivedPredicate:
    """``(:derived (name ?x ...) body)``: the atom holds wherever the body does. A predicate
    may have several; it holds where any of them does (least fixed point: recursion is
    allowed)."""

    name: str
    params: tuple[TypedName, ...]
    body: Formula

    def __post_init__(self) -> None:
        names = [p.name for p in self.params]
        for n in names:
            if not is_variable(n):
                raise ValueError(f"derived predicate {self.name}: {n!r} must start with '?'")
        if len(set(names)) != len(names):
            raise ValueError(f"derived predicate {self.name}: repeated parameter")
        _check_formula(f"derived predicate {self.name}", set(names), self.body)


@dataclass(frozen=True)
class Domain:
    """A parsed PDDL domain."""

    name: str
    requirements: tuple[str, ...]
    types: tuple[TypedName, ...]  # each type with its parent
    constants: tuple[TypedName, ...]
    predicates: tuple[Predicate, ...]
    actions: tuple[Action, ...]
    uses_action_costs: bool = False
    source: str = "<string>"
    derived: tuple[DerivedPredicate, ...] = ()
    functions: tuple[FunctionDecl, ...] = ()  # numeric functions besides total-cost
    # What the files left undeclared and the parser declared from its use (lenient parses)
    inferred: tuple[Inference, ...] = field(default=(), compare=False)
    # Where each predicate (and "(function NAME)") was declared, for error messages
    places: Mapping[str, str] = field(default_factory=dict, compare=False, hash=False, repr=False)
    _index: dict[str, dict[str, object]] = field(
        default_factory=dict, init=False, repr=False, compare=False, hash=False
    )

    def __post_init__(self) -> None:
        for kind, names in (
            ("action", [a.name for a in self.actions]),
            ("predicate", [p.name for p in self.predicates]),
            ("function", [f.name for f in self.functions]),
        ):
            _check_unique(names, f"domain {self.name}: repeated {kind}")
        self._index["predicate"] = {p.name: p for p in self.predicates}
        self._index["action"] = {a.name: a for a in self.actions}
        self._index["function"] = {f.name: f for f in self.functions}
        for d in self.derived:
            pred = self._index["predicate"].get(d.name)
            if not isinstance(pred, Predicate):
                raise ValueError(f"domain {self.name}: derived predicate {d.name} is not declared")
            if pred.arity != len(d.params):
                raise ValueError(
                    f"domain {self.name}: derived predicate {d.name} takes {pred.arity} "
                    f"arguments, its :derived head has {len(d.params)}"
                )
        derived = self.derived_predicates
        for a in self.actions:
            changed = (*a.add_effects, *a.del_effects, *(x for e in a.effects for x in e.adds))
            for atom in (*changed, *(x for e in a.effects for x in e.dels)):
                if atom.predicate in derived:
                    raise ValueError(
                        f"action {a.name} changes {atom.predicate}, a derived predicate"
                    )

    @property
    def typed(self) -> bool:
        return bool(self.types)

    def declaring(
        self,
        predicates: Iterable[Predicate] = (),
        functions: Iterable[FunctionDecl] = (),
        inferred: Iterable[Inference] = (),
    ) -> Domain:
        """This domain with more predicates and functions (those a stream file or a problem
        declared by their use); names it has already are left as they are."""
        have = {p.name for p in self.predicates}
        new_predicates = [p for p in predicates if p.name not in have]
        have_f = {f.name for f in self.functions}
        new_functions = [f for f in functions if f.name not in have_f]
        more = tuple(inferred)
        if not new_predicates and not new_functions and not more:
            return self
        return replace(
            self,
            predicates=(*self.predicates, *new_predicates),
            functions=(*self.functions, *new_functions),
            inferred=(*self.inferred, *more),
        )

    @property
    def derived_predicates(self) -> frozenset[str]:
        return frozenset(d.name for d in self.derived)

    @functools.cached_property
    def fluent_predicates(self) -> frozenset[str]:
        """Predicates some action changes (conditional effects included); computed once (the
        search and the model's stream order ask for it for every fact they read)."""
        out: set[str] = set()
        for a in self.actions:
            out.update(x.predicate for x in a.add_effects + a.del_effects)
            for e in a.effects:
                out.update(x.predicate for x in e.adds + e.dels)
        return frozenset(out)

    @property
    def is_strips(self) -> bool:
        """No derived predicates, no ADL formulas or effects, no function-valued costs."""
        return not self.derived and all(a.is_strips for a in self.actions)

    def predicate(self, name: str) -> Predicate:
        found = self._index["predicate"].get(name)
        if isinstance(found, Predicate):
            return found
        raise KeyError(f"domain {self.name} has no predicate {name!r}")

    def action(self, name: str) -> Action:
        found = self._index["action"].get(name)
        if isinstance(found, Action):
            return found
        known = ", ".join(a.name for a in self.actions)
        raise KeyError(f"domain {self.name} has no action {name!r} (known: {known})")

    def function(self, name: str) -> FunctionDecl:
        found = self._index["function"].get(name)
        if isinstance(found, FunctionDecl):
            return found
        raise KeyError(f"domain {self.name} declares no function {name!r}")

    def supertypes(self, type_name: str) -> tuple[str, ...]:
        """``type_name`` and all its ancestors, up to ``object``."""
        parents = {t.name: t.type for t in self.types}
        chain = [type_name]
        while chain[-1] in parents and chain[-1] != OBJECT_TYPE:
            nxt = parents[chain[-1]]
            if nxt in chain:
                break
            chain.append(nxt)
        if OBJECT_TYPE not in chain:
            chain.append(OBJECT_TYPE)
        return tuple(chain)


StreamKind = TypingLiteral["stream", "rule", "predicate"]


@dataclass(frozen=True)
class Stream:
    """A PDDLStream conditional generator: ``:inputs :domain :outputs :certified``.

    A stream with no outputs is a test: it certifies facts about its inputs. ``kind`` says
    where it came from: a ``(:stream ...)``; a ``(:rule ...)`` (a test that always holds and
    needs no sampler); or a ``(:predicate (P ?x) domain)``, a lazily evaluated test whose
    ``certified`` is its head: planning assumes ``P`` false, and a query succeeds when the
    Python test says it is false. ``fluents`` are the fluent predicates the sampler reads.
    """

    name: str
    inputs: tuple[str, ...]
    domain: tuple[Atom, ...]
    outputs: tuple[TypedName, ...]
    certified: tuple[Atom, ...]
    source: str = "<string>"
    line: int = 0
    fluents: tuple[str, ...] = ()
    kind: StreamKind = "stream"

    def __post_init__(self) -> None:  # plain loops: a large stream file makes 48,000
        outs = [o.name for o in self.outputs]
        inputs = set(self.inputs)
        declared = inputs.union(outs)
        if len(declared) != len(self.inputs) + len(outs):
            raise ValueError(f"stream {self.name}: an input or output is repeated")
        if not self.certified:
            raise ValueError(f"stream {self.name}: certifies nothing")
        in_domain: set[str] = set()
        for atom in self.domain:
            in_domain.update(atom.args)
        for var in self.inputs:
            if var not in in_domain:
                raise ValueError(f"stream {self.name}: input {var} appears in no :domain fact")
        for var in outs:
            if var in in_domain:
                raise ValueError(f"stream {self.name}: output {var} appears in a :domain fact")
        for section, atoms, known in (
            (":domain", self.domain, inputs),
            (":certified", self.certified, declared),
        ):
            for atom in atoms:
                for term in atom.args:
                    if term[:1] == "?" and term not in known:
                        raise ValueError(
                            f"stream {self.name} {section}: variable {term} in {atom} is not "
                            "a parameter"
                        )
        if self.kind != "stream":
            if self.outputs:
                raise ValueError(f"{self.kind} {self.name}: a {self.kind} has no outputs")
            if self.kind == "predicate" and len(self.certified) != 1:
                raise ValueError(f"predicate {self.name}: certifies exactly its head")
            if self.fluents:
                raise ValueError(f"{self.kind} {self.name}: only a stream reads fluents")

    @property
    def is_test(self) -> bool:
        return not self.outputs

    @property
    def output_names(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.outputs)


@dataclass(frozen=True)
class StreamFunction:
    """``(:function (F ?x ?y) domain)``: a numeric function computed by Python from bound
    inputs where its domain holds (PDDLStream's external functions, used as action costs)."""

    name: str
    inputs: tuple[str, ...]
    domain: tuple[Atom, ...]
    source: str = "<string>"
    line: int = 0

    def __post_init__(self) -> None:
        if len(set(self.inputs)) != len(self.inputs):
            raise ValueError(f"function {self.name}: an input is repeated")
        _check_variables(f"function {self.name} :domain", set(self.inputs), self.domain)

    def head(self) -> FunctionTerm:
        return FunctionTerm(self.name, self.inputs)


@dataclass(frozen=True)
class StreamSet:
    """All streams (rules and lazy predicates among them) and functions of one
    ``stream.pddl`` file."""

    name: str
    streams: tuple[Stream, ...]
    source: str = "<string>"
    functions: tuple[StreamFunction, ...] = ()
    # Predicates and functions this file declared by their use (lenient parses): the domain
    # gets them through Domain.declaring (planner.pddl.load_pddlstream does it)
    declared: tuple[Predicate, ...] = field(default=(), compare=False)
    declared_functions: tuple[FunctionDecl, ...] = field(default=(), compare=False)
    inferred: tuple[Inference, ...] = field(default=(), compare=False)
    _index: dict[str, Stream | StreamFunction] = field(
        default_factory=dict, init=False, repr=False, compare=False, hash=False
    )

    def __post_init__(self) -> None:
        names = [s.name for s in self.streams] + [f.name for f in self.functions]
        _check_unique(names, f"{self.source}: repeated stream")
        self._index.update({s.name: s for s in self.streams})
        self._index.update({f.name: f for f in self.functions})

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.streams)

    @property
    def binding_names(self) -> tuple[str, ...]:
        """What a domain binds to Python: streams, lazy predicates and functions (rules need
        no binding)."""
        return tuple(s.name for s in self.streams if s.kind != "rule") + tuple(
            f.name for f in self.functions
        )

    def stream(self, name: str) -> Stream:
        found = self._index.get(name)
        if isinstance(found, Stream):
            return found
        raise KeyError(
            f"{self.source} declares no stream {name!r} (known: {', '.join(self.names)})"
        )

    def function(self, name: str) -> StreamFunction:
        found = self._index.get(name)
        if isinstance(found, StreamFunction):
            return found
        known = ", ".join(f.name for f in self.functions) or "none"
        raise KeyError(f"{self.source} declares no function {name!r} (known: {known})")

    @property
    def lazy_predicates(self) -> frozenset[str]:
        """Predicates declared with ``(:predicate ...)``: assumed false until tested."""
        return frozenset(s.certified[0].predicate for s in self.streams if s.kind == "predicate")

    def certified_predicates(self) -> frozenset[str]:
        return frozenset(a.predicate for s in self.streams for a in s.certified)


@dataclass(frozen=True)
class Problem:
    """Objects, initial facts (closed world) and goal over a domain.

    ``goal`` holds the literal conjuncts of the goal, ``goal_conditions`` the others.
    """

    name: str
    domain_name: str
    objects: tuple[TypedName, ...]
    init: frozenset[Atom]
    goal: tuple[Literal, ...]
    source: str = "<string>"
    values: Mapping[str, object] = field(default_factory=dict, compare=False, hash=False)
    # ``values`` maps object names to the Python values the samplers work on (poses, ...).
    goal_conditions: tuple[Formula, ...] = ()
    # ``(= (f a b) 3.5)`` facts of the initial state: values of numeric functions.
    function_values: Mapping[FunctionTerm, float] = field(
        default_factory=dict, compare=False, hash=False
    )
    # Predicates and functions the problem file declared by their use (lenient parses)
    inferred: tuple[Inference, ...] = field(default=(), compare=False)

    def __post_init__(self) -> None:
        _check_unique((o.name for o in self.objects), f"problem {self.name}: repeated object")
        for atom in self.init:
            if atom.variables:
                raise ValueError(f"problem {self.name}: initial fact {atom} has a variable")
        if not self.goal and not self.goal_conditions:
            raise ValueError(f"problem {self.name}: empty goal")
        for formula in self.goal_conditions:
            if isinstance(formula, Literal):
                raise ValueError(f"problem {self.name}: the literal {formula} belongs in goal")
            _check_formula(f"problem {self.name} goal", set(), formula)
        for term, value in self.function_values.items():
            if term.variables:
                raise ValueError(f"problem {self.name}: function value {term} has a variable")
            if value < 0:
                raise ValueError(f"problem {self.name}: {term} = {value} is negative")

    @property
    def object_names(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.objects)

    @property
    def goal_formula(self) -> Formula:
        return And((*self.goal, *self.goal_conditions))


def problem_predicates(domain: Domain, problem: Problem) -> tuple[Predicate, ...]:
    """Predicates of ``problem``'s initial facts and goal that ``domain`` does not declare (a
    PDDLStream problem's static facts are declared by their use), untyped, each with the
    arity of its first use in sorted order."""
    have = {p.name for p in domain.predicates}
    atoms = sorted(problem.init) + [lit.atom for lit in problem.goal]
    for formula in problem.goal_conditions:
        atoms += [lit.atom for lit, _ in literals(formula)]
    found: dict[str, Predicate] = {}
    for atom in atoms:
        if atom.predicate not in have and atom.predicate != EQUALITY:
            found.setdefault(
                atom.predicate,
                Predicate(
                    atom.predicate, tuple(TypedName(f"?x{i}") for i in range(len(atom.args)))
                ),
            )
    return tuple(found.values())
