"""Parsers for PDDL domains and problems and for PDDLStream ``stream.pddl`` files.

Supported: STRIPS with typing (``either`` types too), negative preconditions and equality;
ADL formulas (``and or not imply exists forall``) in preconditions, goals and derived
predicates; conditional (``when``) and universal (``forall``) effects; ``:derived``
predicates; action costs that are numbers or numeric functions (``(increase (total-cost)
(dist ?a ?b))``). Stream files: ``:stream`` (with ``:fluents``), ``:rule``, ``:predicate`` and
``:function``. Anything else (durative actions, numeric conditions, ...) is rejected with an
:class:`UnsupportedPDDLError` that points at the construct; every error names file, line and
column.
"""

from __future__ import annotations

import gc
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from functools import wraps
from pathlib import Path
from typing import ParamSpec, TypeVar

from planner.pddl.errors import PDDLError, UnsupportedPDDLError
from planner.pddl.sexpr import Node, SList, Source, Symbol, read_file, read_sexpr
from planner.pddl.structs import (
    EQUALITY,
    OBJECT_TYPE,
    TOTAL_COST,
    Action,
    And,
    Atom,
    ConditionalEffect,
    DerivedPredicate,
    Domain,
    Exists,
    ForAll,
    Formula,
    FunctionDecl,
    FunctionTerm,
    Imply,
    Inference,
    InferenceKind,
    Literal,
    Not,
    Or,
    Predicate,
    Problem,
    Stream,
    StreamFunction,
    StreamSet,
    TypedName,
    conjunction,
    is_variable,
)

SUPPORTED_REQUIREMENTS = frozenset(
    {
        ":strips",
        ":typing",
        ":negative-preconditions",
        ":equality",
        ":action-costs",
        ":disjunctive-preconditions",
        ":existential-preconditions",
        ":universal-preconditions",
        ":quantified-preconditions",
        ":conditional-effects",
        ":derived-predicates",
        ":adl",
        ":numeric-fluents",  # accepted for numeric functions used as action costs
    }
)
_CONNECTIVES = frozenset({"and", "or", "not", "imply", "exists", "forall"})
_NUMERIC_CONDITIONS = frozenset({"<", "<=", ">", ">="})
_NUMERIC_EFFECTS = frozenset({"decrease", "assign", "scale-up", "scale-down"})
_ARITHMETIC = frozenset({"+", "-", "*", "/"})
_SECTIONS_ONCE = (":requirements", ":types", ":constants", ":predicates", ":functions")


_P = ParamSpec("_P")
_T = TypeVar("_T")


@contextmanager
def _collector_paused() -> Iterator[None]:
    """No cyclic garbage collection while a file is read: it makes only acyclic tuples and
    dataclasses, and a collection every 700 of them made a 5 MB file read 2.5 times slower."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def _paused(fn: Callable[_P, _T]) -> Callable[_P, _T]:
    @wraps(fn)
    def run(*args: _P.args, **kwargs: _P.kwargs) -> _T:
        with _collector_paused():
            return fn(*args, **kwargs)

    return run


class _Reader:
    """Shared helpers that turn S-expression nodes into checked values, with positions."""

    def __init__(self, source: Source) -> None:
        self.source = source
        self.file = source.file
        self._untyped: dict[str, TypedName] = {}  # names without a type, made once each
        self._typed: dict[tuple[str, str], TypedName] = {}  # and with one

    def where(self, node: Node) -> str:
        line, column = self.source.position(node.token)
        return f"line {line}, column {column}"

    def place(self, node: Node) -> str:
        """``file:line:column`` of ``node``."""
        line, column = self.source.position(node.token)
        return f"{self.file}:{line}:{column}"

    def line(self, node: SList) -> int:
        return node.line

    def error(self, node: Node, message: str) -> PDDLError:
        line, column = self.source.position(node.token)
        return PDDLError(message, file=self.file, line=line, column=column)

    def unsupported(self, node: Node, message: str) -> UnsupportedPDDLError:
        line, column = self.source.position(node.token)
        return UnsupportedPDDLError(message, file=self.file, line=line, column=column)

    def symbol(self, node: Node, what: str) -> str:
        if not isinstance(node, Symbol):
            raise self.error(node, f"expected {what} but found a list")
        return node.text

    def slist(self, node: Node, what: str) -> SList:
        if not isinstance(node, SList):
            raise self.error(
                node, f"expected {what} (a parenthesised list) but found {node.text!r}"
            )
        return node

    def head(self, lst: SList, what: str) -> str:
        if not lst.items:
            raise self.error(lst, f"expected {what} but found '()'")
        return self.symbol(lst.items[0], what)

    def typed_items(
        self, items: Sequence[Node], what: str, *, either: bool = False
    ) -> list[tuple[TypedName, Node]]:
        """``a b - t c`` -> a:t, b:t, c:object, each with its node; ``- (either t u)`` only
        where ``either`` allows it."""
        if all(type(n) is Symbol and n.text != "-" for n in items):  # no types: the usual
            cache = self._untyped
            out_: list[tuple[TypedName, Node]] = []
            for n in items:
                text = n.text  # type: ignore[union-attr]
                typed = cache.get(text)
                if typed is None:
                    typed = cache[text] = TypedName(text)
                out_.append((typed, n))
            return out_
        out: list[tuple[TypedName, Node]] = []
        pending: list[tuple[str, Node]] = []
        i = 0
        while i < len(items):
            node = items[i]
            if isinstance(node, Symbol) and node.text == "-":
                if i + 1 >= len(items):
                    raise self.error(node, f"expected a type name after '-' in {what}")
                type_node = items[i + 1]
                if not pending:
                    raise self.error(node, f"expected a name before '-' in {what}")
                if isinstance(type_node, SList):
                    alternatives = self._either(type_node, what, either)
                    out.extend((TypedName(n, OBJECT_TYPE, alternatives), at) for n, at in pending)
                else:
                    kind = type_node.text
                    made = self._typed
                    for name, at in pending:
                        one = made.get((name, kind))
                        if one is None:
                            one = made[(name, kind)] = TypedName(name, kind)
                        out.append((one, at))
                pending = []
                i += 2
                continue
            pending.append((self.symbol(node, f"a name in {what}"), node))
            i += 1
        out.extend((TypedName(n), at) for n, at in pending)
        return out

    def _either(self, node: SList, what: str, allowed: bool) -> tuple[str, ...]:
        if not node.items or self.head(node, "'either'") != "either":
            raise self.error(node, f"expected a type name or (either TYPE ...) in {what}")
        if not allowed:
            raise self.unsupported(
                node, f"(either ...) types are not supported in {what} (only for variables)"
            )
        names = tuple(self.symbol(t, "a type name in (either ...)") for t in node.items[1:])
        if not names:
            raise self.error(node, "expected at least one type in (either ...)")
        return tuple(dict.fromkeys(names))

    def typed_list(
        self, lst: SList | Iterable[Node], what: str, *, either: bool = False
    ) -> tuple[TypedName, ...]:
        items = list(lst.items if isinstance(lst, SList) else lst)
        return tuple(t for t, _ in self.typed_items(items, what, either=either))

    def keyword_sections(self, lst: SList, start: int, what: str) -> list[tuple[Symbol, Node]]:
        """``:key value :key value`` pairs of an action or stream body."""
        items = lst.items[start:]
        pairs: list[tuple[Symbol, Node]] = []
        seen: dict[str, Symbol] = {}
        for i in range(0, len(items), 2):
            key = items[i]
            if not isinstance(key, Symbol) or not key.text.startswith(":"):
                raise self.error(key, f"expected a keyword such as ':parameters' in {what}")
            if i + 1 >= len(items):
                raise self.error(key, f"expected a value after {key.text} in {what}")
            if key.text in seen:
                first = seen[key.text]
                raise self.error(
                    key,
                    f"{key.text} appears twice in {what} (first at {self.where(first)})",
                )
            seen[key.text] = key
            pairs.append((key, items[i + 1]))
        return pairs

    def check_types(self, names: Iterable[tuple[TypedName, Node]], known: set[str]) -> None:
        for typed, node in names:
            for t in typed.types:
                if t not in known:
                    raise self.error(node, f"type {t!r} of {typed.name} is not declared")


def _number(text: str) -> float | None:
    """A non-negative number token (an int stays an int), or None."""
    try:
        value = float(text)
    except ValueError:
        return None
    if value != value or value in (float("inf"), float("-inf")):
        return None
    return int(text) if text.isdigit() else value


class _Scope:
    """What a formula may mention: declared predicates, variables (with types), objects,
    numeric functions. (A plain class: one is made per stream of a large file.)"""

    __slots__ = ("declarer", "functions", "objects", "owner", "predicates", "variables")

    def __init__(
        self,
        predicates: dict[str, Predicate],
        variables: dict[str, TypedName],
        objects: set[str],
        owner: str,
        functions: dict[str, FunctionDecl] | None = None,
        declarer: _Declarer | None = None,
    ) -> None:
        self.predicates = predicates
        self.variables = variables
        self.objects = objects
        self.owner = owner
        self.functions = functions if functions is not None else {}
        self.declarer = declarer

    def with_variables(self, names: Iterable[TypedName]) -> _Scope:
        inner = dict(self.variables)
        inner.update((t.name, t) for t in names)
        return _Scope(
            self.predicates, inner, self.objects, self.owner, self.functions, self.declarer
        )


STRICT_HINT = "without --strict (strict=False) it is declared by its first use"


def one_edit_apart(a: str, b: str) -> bool:
    """Whether ``a`` becomes ``b`` by one inserted, deleted, replaced or swapped letter (a
    likely typo: 'fre' for 'free'); names shorter than three letters never are."""
    if a == b or min(len(a), len(b)) < 3 or abs(len(a) - len(b)) > 1:
        return False
    if len(a) == len(b):
        diff = [i for i, (x, y) in enumerate(zip(a, b, strict=True)) if x != y]
        if len(diff) == 1:
            return True
        i = diff[0]
        return len(diff) == 2 and diff[1] == i + 1 and a[i] == b[i + 1] and a[i + 1] == b[i]
    short, long = (a, b) if len(a) < len(b) else (b, a)
    i = 0
    while i < len(short) and short[i] == long[i]:
        i += 1
    return short[i:] == long[i + 1 :]


class _Declarer:
    """PDDLStream's leniency: a predicate or function that is used but not declared is
    declared by its first use (its arity from that use) and recorded as an :class:`Inference`;
    a later use with another arity is an error naming both places. With ``strict`` every such
    use is an error instead."""

    def __init__(
        self,
        predicates: dict[str, Predicate],
        functions: dict[str, FunctionDecl],
        *,
        strict: bool,
        places: dict[str, str] | None = None,
    ) -> None:
        self.predicates = predicates
        self.functions = functions
        self.strict = strict
        self.inferred: list[Inference] = []
        self.new_predicates: list[Predicate] = []
        self.new_functions: list[FunctionDecl] = []
        # name -> where it was declared, or first used when that declared it; functions
        # under "(function NAME)"
        self.places: dict[str, str] = dict(places or {})

    def origin(self, name: str, *, function: bool = False) -> str:
        """`` (declared at PLACE)`` for an error about ``name``, or nothing when unknown."""
        place = self.places.get(f"(function {name})" if function else name)
        return f" ({place})" if place else ""

    def _record(
        self,
        reader: _Reader,
        node: Node,
        kind: InferenceKind,
        name: str,
        arity: int,
        use: str,
        known: Iterable[str],
    ) -> None:
        line, column = reader.source.position(node.token)
        # A typo is likely where an action or a derived predicate uses a name one letter away
        # from a declared one; stream files and problems declaring static facts by use are
        # PDDLStream's idiom, and their names often differ by a letter ('cash', 'mcash').
        typo_prone = use.startswith(("action ", "derived predicate "))
        near = next((k for k in sorted(known) if typo_prone and one_edit_apart(name, k)), "")
        self.inferred.append(Inference(kind, name, arity, reader.file, line, column, use, near))

    def predicate(
        self, reader: _Reader, node: SList, name: str, arity: int, owner: str
    ) -> Predicate:
        if self.strict:
            raise reader.error(
                node,
                f"undeclared predicate {name!r} in {owner} (declare it in the domain's "
                f":predicates; {STRICT_HINT})",
            )
        self._record(reader, node, "predicate", name, arity, owner, self.predicates)
        pred = Predicate(name, tuple(TypedName(f"?x{i}") for i in range(arity)))
        self.predicates[name] = pred
        self.new_predicates.append(pred)
        self.places[name] = f"declared by its use in {owner} at {reader.place(node)}"
        return pred

    def function(
        self, reader: _Reader, node: SList, name: str, arity: int, owner: str
    ) -> FunctionDecl:
        if self.strict:
            raise reader.error(
                node,
                f"undeclared function {name!r} in {owner} (declare it in the domain's "
                f":functions; {STRICT_HINT})",
            )
        self._record(reader, node, "function", name, arity, owner, self.functions)
        decl = FunctionDecl(name, tuple(TypedName(f"?x{i}") for i in range(arity)))
        self.functions[name] = decl
        self.new_functions.append(decl)
        self.places[f"(function {name})"] = (
            f"declared by its use in {owner} at {reader.place(node)}"
        )
        return decl


def _check_term(reader: _Reader, arg: str, node: Node, scope: _Scope) -> None:
    if is_variable(arg):
        if arg not in scope.variables:
            raise reader.error(node, f"variable {arg} is not declared in {scope.owner}")
    elif arg not in scope.objects:
        raise reader.error(node, f"unknown object or constant {arg!r} in {scope.owner}")


def _atom(reader: _Reader, node: Node, scope: _Scope, *, allow_equality: bool) -> Atom:
    lst = reader.slist(node, "an atom such as (pred ?x)")
    name = reader.head(lst, "a predicate name")
    items = lst.items
    args = []
    variables, objects = scope.variables, scope.objects
    for item in items[1:]:  # written out: the hot loop of reading a large file
        if type(item) is not Symbol:
            raise reader.error(item, f"expected an argument of ({name} ...) but found a list")
        arg = item.text
        if arg[0] == "?":
            if arg not in variables:
                raise reader.error(item, f"variable {arg} is not declared in {scope.owner}")
        elif arg not in objects:
            raise reader.error(item, f"unknown object or constant {arg!r} in {scope.owner}")
        args.append(arg)
    if name == EQUALITY:
        if not allow_equality:
            raise reader.error(lst, f"equality is not allowed here ({scope.owner})")
        if len(args) != 2:
            raise reader.error(lst, "expected exactly two arguments to '='")
    else:
        pred = scope.predicates.get(name)
        if pred is None:
            if scope.declarer is None:
                raise reader.error(lst, f"undeclared predicate {name!r} in {scope.owner}")
            pred = scope.declarer.predicate(reader, lst, name, len(args), scope.owner)
        if len(pred.params) != len(args):
            where = scope.declarer.origin(name) if scope.declarer is not None else ""
            raise reader.error(
                lst,
                f"predicate {name!r} takes {pred.arity} arguments but {len(args)} are given{where}",
            )
    return Atom(name, tuple(args))


def _formula(reader: _Reader, node: Node, scope: _Scope) -> Formula:
    """A condition: literals joined by ``and or not imply exists forall``."""
    lst = reader.slist(node, "a formula such as (pred ?x) or (and ...)")
    if not lst.items:
        return And(())
    head = reader.head(lst, "a predicate or connective")
    args = lst.items[1:]
    if head == "and":
        return And(tuple(_formula(reader, a, scope) for a in args))
    if head == "or":
        return Or(tuple(_formula(reader, a, scope) for a in args))
    if head == "not":
        if len(args) != 1:
            raise reader.error(lst, "expected exactly one formula inside (not ...)")
        inner = _formula(reader, args[0], scope)
        if isinstance(inner, Literal):
            return Literal(inner.atom, not inner.positive)
        return Not(inner)
    if head == "imply":
        if len(args) != 2:
            raise reader.error(lst, "expected (imply CONDITION CONSEQUENCE)")
        return Imply(_formula(reader, args[0], scope), _formula(reader, args[1], scope))
    if head in ("exists", "forall"):
        if len(args) != 2:
            raise reader.error(lst, f"expected ({head} (?x - type ...) FORMULA)")
        variables = _variables(reader, args[0], f"({head} ...) in {scope.owner}")
        body = _formula(reader, args[1], scope.with_variables(variables))
        return Exists(variables, body) if head == "exists" else ForAll(variables, body)
    if head == "when":
        raise reader.error(lst, "(when ...) is an effect; it cannot be part of a condition")
    if head in _NUMERIC_CONDITIONS or (head == EQUALITY and args and isinstance(args[0], SList)):
        raise reader.unsupported(lst, f"numeric conditions ({head} ...) are not supported")
    return Literal(_atom(reader, lst, scope, allow_equality=True))


def _variables(reader: _Reader, node: Node, what: str) -> tuple[TypedName, ...]:
    lst = reader.slist(node, f"the variables of {what}")
    items = reader.typed_items(lst.items, what, either=True)
    if not items:
        raise reader.error(lst, f"expected at least one variable in {what}")
    seen: set[str] = set()
    for typed, at in items:
        if not is_variable(typed.name):
            raise reader.error(at, f"{typed.name!r} in {what} must start with '?'")
        if typed.name in seen:
            raise reader.error(at, f"{what} repeats the variable {typed.name}")
        seen.add(typed.name)
    return tuple(t for t, _ in items)


def _flatten(formula: Formula) -> list[Formula]:
    """The conjuncts of nested ``and``s."""
    if isinstance(formula, And):
        return [c for p in formula.parts for c in _flatten(p)]
    return [formula]


def _split(formula: Formula) -> tuple[tuple[Literal, ...], tuple[Formula, ...]]:
    """A condition as its literal conjuncts and its other conjuncts."""
    parts = _flatten(formula)
    return (
        tuple(p for p in parts if isinstance(p, Literal)),
        tuple(p for p in parts if not isinstance(p, Literal)),
    )


def _conjunction(reader: _Reader, node: Node) -> tuple[Node, ...]:
    """The conjuncts of ``(and a b)``, ``a`` or ``()``."""
    lst = reader.slist(node, "a formula")
    if not lst.items:
        return ()
    if isinstance(lst.items[0], Symbol) and lst.items[0].text == "and":
        return lst.items[1:]
    return (lst,)


def _check_requirements(reader: _Reader, lst: SList) -> tuple[str, ...]:
    reqs = []
    for node in lst.items[1:]:
        req = reader.symbol(node, "a requirement such as :strips")
        if req in (":durative-actions", ":duration-inequalities", ":timed-initial-literals"):
            raise reader.unsupported(
                node,
                f"requirement {req} is not supported: temporal planning (durative actions) is "
                "not; write each durative action as an :action whose duration is its cost "
                "((increase (total-cost) ...)), and its :condition as :precondition",
            )
        if req not in SUPPORTED_REQUIREMENTS:
            raise reader.unsupported(
                node,
                f"requirement {req} is not supported "
                f"(supported: {' '.join(sorted(SUPPORTED_REQUIREMENTS))})",
            )
        reqs.append(req)
    return tuple(reqs)


def _definition(reader: _Reader, root: SList, kind: str) -> str:
    if reader.head(root, "'define'") != "define":
        raise reader.error(root, f"expected '(define ({kind} NAME) ...)'")
    if len(root.items) < 2:
        raise reader.error(root, f"expected '({kind} NAME)' after 'define'")
    header = reader.slist(root.items[1], f"'({kind} NAME)'")
    if len(header.items) != 2 or reader.head(header, kind) != kind:
        raise reader.error(header, f"expected '({kind} NAME)'")
    return reader.symbol(header.items[1], f"the {kind} name")


def _unique(
    reader: _Reader, items: Iterable[tuple[TypedName, Node]], what: str
) -> list[tuple[TypedName, Node]]:
    """``items`` with no name twice (linear): a repeat is an error at its second place."""
    seen: dict[str, Node] = {}
    out = []
    for typed, node in items:
        first = seen.get(typed.name)
        if first is not None:
            raise reader.error(
                node,
                f"{what} {typed.name!r} is declared twice (first at {reader.where(first)})",
            )
        seen[typed.name] = node
        out.append((typed, node))
    return out


def _parse_functions(reader: _Reader, section: SList, declarer: _Declarer) -> bool:
    """``(:functions (total-cost) - number (dist ?a ?b) ...)``; True if total-cost is one. A
    function declared twice alike is accepted (with an :class:`Inference`) unless strict."""
    functions = declarer.functions
    uses_costs = False
    items = section.items[1:]
    i = 0
    while i < len(items):
        node = items[i]
        if isinstance(node, Symbol):
            if node.text != "-" or i + 1 >= len(items):
                raise reader.error(node, "expected a function declaration such as (f ?x)")
            kind = items[i + 1]
            if not isinstance(kind, Symbol) or kind.text != "number":
                raise reader.unsupported(
                    kind, "only numeric functions ('- number') are supported, not object fluents"
                )
            i += 2
            continue
        flst = reader.slist(node, "a function declaration")
        fname = reader.head(flst, "a function name")
        if fname == TOTAL_COST:
            if len(flst.items) != 1:
                raise reader.error(flst, "(total-cost) takes no arguments")
            uses_costs = True
        else:
            params = reader.typed_list(flst.items[1:], f"function {fname}", either=True)
            for p in params:
                if not is_variable(p.name):
                    raise reader.error(flst, f"parameter {p.name!r} of {fname} must start with ?")
            decl = FunctionDecl(fname, params)
            key = f"(function {fname})"
            if fname in functions:
                _repeat(reader, flst, declarer, "function", fname, functions[fname], decl, key)
            else:
                functions[fname] = decl
                declarer.places[key] = f"declared at {reader.place(flst)}"
        i += 1
    return uses_costs


def _types_text(params: tuple[TypedName, ...]) -> str:
    return " ".join(p.type_text() for p in params) or "no arguments"


def _repeat(
    reader: _Reader,
    node: SList,
    declarer: _Declarer,
    kind: str,
    name: str,
    first: Predicate | FunctionDecl,
    again: Predicate | FunctionDecl,
    key: str,
) -> None:
    """A predicate or function declared a second time: accepted with an :class:`Inference`
    when both declarations agree (Fast Downward's reading), an error when they do not or
    when strict."""
    where = declarer.places.get(key, "")
    if declarer.strict:
        raise reader.error(
            node,
            f"{kind} {name!r} is declared twice ({where}; without --strict a repeat that "
            "agrees is accepted)",
        )
    same = len(first.params) == len(again.params) and all(
        a.types == b.types for a, b in zip(first.params, again.params, strict=True)
    )
    if not same:
        raise reader.error(
            node,
            f"{kind} {name!r} is declared twice and the two disagree: {first.arity} "
            f"argument(s) ({_types_text(first.params)}) {where}, {again.arity} "
            f"({_types_text(again.params)}) here",
        )
    line, column = reader.source.position(node.token)
    declarer.inferred.append(
        Inference(
            "repeat",
            name,
            again.arity,
            reader.file,
            line,
            column,
            f"{kind} {name!r} is declared twice, alike ({where})",
        )
    )


@_paused
def parse_domain(text: str, *, file: str = "<string>", strict: bool = False) -> Domain:
    """Parse a PDDL domain; errors carry file, line and column.

    Lenient by default, as PDDLStream is: a predicate or function used in an action or a
    derived predicate without a declaration is declared by its first use, a derived predicate
    by its ``:derived`` head, and a repeated declaration that agrees is accepted; each is an
    :class:`~planner.pddl.structs.Inference` in ``Domain.inferred``. ``strict`` refuses them."""
    root, source = read_sexpr(text, file=file)
    reader = _Reader(source)
    name = _definition(reader, root, "domain")
    requirements: tuple[str, ...] = ()
    types: list[tuple[TypedName, Node]] = []
    constants: list[tuple[TypedName, Node]] = []
    predicates: dict[str, Predicate] = {}
    predicate_params: list[tuple[TypedName, Node]] = []
    functions: dict[str, FunctionDecl] = {}
    declarer = _Declarer(predicates, functions, strict=strict)
    action_nodes: list[SList] = []
    derived_nodes: list[SList] = []
    uses_costs = False
    seen_sections: dict[str, SList] = {}
    for node in root.items[2:]:
        section = reader.slist(node, "a domain section such as (:predicates ...)")
        key = reader.head(section, "a section keyword")
        if key in _SECTIONS_ONCE:
            if key in seen_sections:
                first = seen_sections[key]
                raise reader.error(
                    section,
                    f"a second ({key} ...) section; the first is at {reader.where(first)}",
                )
            seen_sections[key] = section
        if key == ":requirements":
            requirements = _check_requirements(reader, section)
        elif key == ":types":
            types = _unique(reader, reader.typed_items(section.items[1:], ":types"), "type")
        elif key == ":constants":
            constants = _unique(
                reader, reader.typed_items(section.items[1:], ":constants"), "constant"
            )
        elif key == ":predicates":
            for pnode in section.items[1:]:
                plst = reader.slist(pnode, "a predicate declaration such as (on ?x ?y)")
                pname = reader.head(plst, "a predicate name")
                params = reader.typed_items(plst.items[1:], f"predicate {pname}", either=True)
                predicate_params += params
                pred = Predicate(pname, tuple(t for t, _ in params))
                if pname in predicates:
                    _repeat(
                        reader, plst, declarer, "predicate", pname, predicates[pname], pred, pname
                    )
                    continue
                predicates[pname] = pred
                declarer.places[pname] = f"declared at {reader.place(plst)}"
        elif key == ":functions":
            uses_costs = _parse_functions(reader, section, declarer)
        elif key == ":action":
            action_nodes.append(section)
        elif key == ":derived":
            derived_nodes.append(section)
        elif key in (":durative-action", ":process", ":event", ":axiom", ":constraints"):
            raise reader.unsupported(section, f"{key} is not supported")
        else:
            raise reader.error(
                section,
                f"unknown domain section {key!r} (expected :requirements, :types, :constants, "
                ":predicates, :functions, :derived or :action)",
            )
    known_types = {OBJECT_TYPE} | {t.name for t, _ in types} | {t.type for t, _ in types}
    reader.check_types(constants, known_types)
    reader.check_types(predicate_params, known_types)
    for t, tnode in types:
        if t.name == OBJECT_TYPE and t.type != OBJECT_TYPE:
            raise reader.error(tnode, "the type 'object' cannot have a parent")
    for c, cnode in constants:
        if is_variable(c.name):
            raise reader.error(cnode, f"constant {c.name!r} must not start with '?'")
    const_names = {c.name for c, _ in constants}
    if not strict:
        for d in derived_nodes:  # a derived predicate declares itself (bodies may use others)
            _declare_derived(reader, d, declarer, known_types)
    derived = tuple(
        _parse_derived(reader, d, declarer, const_names, known_types) for d in derived_nodes
    )
    derived_names = {d.name for d in derived}
    actions: dict[str, Action] = {}
    for anode in action_nodes:
        action = _parse_action(reader, anode, declarer, const_names, known_types)
        if action.name in actions:
            raise reader.error(anode, f"action {action.name!r} is defined twice")
        for atom in _changed(action):
            if atom.predicate in derived_names:
                raise reader.error(
                    anode,
                    f"action {action.name} changes {atom.predicate}, a derived predicate "
                    "(derived predicates follow from the state; actions cannot set them)",
                )
        actions[action.name] = action
    return Domain(
        name=name,
        requirements=requirements,
        types=tuple(t for t, _ in types),
        constants=tuple(c for c, _ in constants),
        predicates=tuple(predicates.values()),
        actions=tuple(actions.values()),
        # PDDLStream's dialect: (increase (total-cost) ...) without declaring total-cost
        uses_action_costs=uses_costs
        or any(a.cost is not None or a.cost_terms for a in actions.values()),
        source=file,
        derived=derived,
        functions=tuple(functions.values()),
        inferred=tuple(declarer.inferred),
        places=declarer.places,
    )


def _changed(action: Action) -> list[Atom]:
    atoms = [*action.add_effects, *action.del_effects]
    for e in action.effects:
        atoms += [*e.adds, *e.dels]
    return atoms


def _declare_derived(
    reader: _Reader, lst: SList, declarer: _Declarer, known_types: set[str]
) -> None:
    """A derived predicate missing from ``:predicates`` declared by its head (lenient)."""
    if len(lst.items) != 3 or not isinstance(lst.items[1], SList) or not lst.items[1].items:
        return  # _parse_derived says what is wrong
    head = lst.items[1]
    name = reader.head(head, "a predicate name")
    if name in declarer.predicates:
        return
    items = reader.typed_items(head.items[1:], f"derived predicate {name}", either=True)
    reader.check_types(items, known_types)
    params = tuple(t for t, _ in items)
    declarer.predicates[name] = Predicate(name, params)
    declarer.new_predicates.append(declarer.predicates[name])
    line, column = reader.source.position(head.token)
    declarer.inferred.append(
        Inference("derived", name, len(params), reader.file, line, column, f"derived {name}")
    )
    declarer.places[name] = f"declared by its (:derived ...) head at {reader.place(head)}"


def _parse_derived(
    reader: _Reader,
    lst: SList,
    declarer: _Declarer,
    constants: set[str],
    known_types: set[str],
) -> DerivedPredicate:
    predicates = declarer.predicates
    if len(lst.items) != 3:
        raise reader.error(lst, "expected (:derived (NAME ?x ...) FORMULA)")
    head = reader.slist(lst.items[1], "the derived predicate, such as (clear ?x)")
    name = reader.head(head, "a predicate name")
    pred = predicates.get(name)
    if pred is None:
        raise reader.error(
            head,
            f"derived predicate {name!r} is not declared in :predicates ({STRICT_HINT})",
        )
    items = reader.typed_items(head.items[1:], f"derived predicate {name}", either=True)
    for typed, at in items:
        if not is_variable(typed.name):
            raise reader.error(at, f"parameter {typed.name!r} of {name} must start with '?'")
    if len(items) != pred.arity:
        raise reader.error(
            head,
            f"predicate {name!r} takes {pred.arity} arguments but {len(items)} are given"
            f"{declarer.origin(name)}",
        )
    if len({t.name for t, _ in items}) != len(items):
        raise reader.error(head, f"derived predicate {name} repeats a parameter")
    reader.check_types(items, known_types)
    params = tuple(
        t if t.types != (OBJECT_TYPE,) else TypedName(t.name, p.type, p.either)
        for (t, _), p in zip(items, pred.params, strict=True)
    )
    scope = _Scope(
        predicates,
        {p.name: p for p in params},
        constants,
        f"derived predicate {name}",
        declarer.functions,
        declarer,
    )
    return DerivedPredicate(name, params, _formula(reader, lst.items[2], scope))


def _parse_action(
    reader: _Reader,
    lst: SList,
    declarer: _Declarer,
    constants: set[str],
    known_types: set[str],
) -> Action:
    predicates, functions = declarer.predicates, declarer.functions
    if len(lst.items) < 2:
        raise reader.error(lst, "expected an action name after :action")
    name = reader.symbol(lst.items[1], "an action name")
    owner = f"action {name}"
    params: list[tuple[TypedName, Node]] = []
    pre_node: Node | None = None
    eff_node: Node | None = None
    for key, value in reader.keyword_sections(lst, 2, owner):
        if key.text == ":parameters":
            params = reader.typed_items(
                reader.slist(value, ":parameters (...)").items, owner, either=True
            )
            for p, at in params:
                if not is_variable(p.name):
                    raise reader.error(at, f"parameter {p.name!r} of {owner} must start with '?'")
        elif key.text == ":precondition":
            pre_node = value
        elif key.text == ":effect":
            eff_node = value
        else:
            raise reader.error(key, f"unknown keyword {key.text} in {owner}")
    names = [p.name for p, _ in params]
    if len(set(names)) != len(names):
        raise reader.error(lst, f"{owner} repeats a parameter")
    reader.check_types(params, known_types)
    typed = tuple(p for p, _ in params)
    scope = _Scope(
        predicates,
        {p.name: p for p in typed},
        constants,
        owner,
        functions,
        declarer,
    )
    pre: tuple[Literal, ...] = ()
    conditions: tuple[Formula, ...] = ()
    if pre_node is not None:
        pre, conditions = _split(_formula(reader, pre_node, scope))
    effects = _Effects(reader, scope)
    if eff_node is not None:
        effects.walk(eff_node, (), ())
    return Action(
        name,
        typed,
        pre,
        tuple(effects.adds),
        tuple(effects.dels),
        effects.cost,
        conditions,
        tuple(effects.conditional),
        tuple(effects.cost_terms),
    )


class _Effects:
    """Collects an action's effects: plain adds and deletes, conditional or quantified
    groups, and its cost."""

    def __init__(self, reader: _Reader, scope: _Scope) -> None:
        self.reader = reader
        self.scope = scope
        self.adds: list[Atom] = []
        self.dels: list[Atom] = []
        self.conditional: list[ConditionalEffect] = []
        self.cost: float | None = None
        self.cost_terms: list[FunctionTerm] = []

    def walk(
        self,
        node: Node,
        variables: tuple[TypedName, ...],
        conditions: tuple[Formula, ...],
    ) -> None:
        reader = self.reader
        scope = self.scope.with_variables(variables)
        elst = reader.slist(node, "an effect")
        if not elst.items:
            return
        head = reader.head(elst, "an effect")
        nested = bool(variables or conditions)
        if head == "and":
            if not nested:
                for item in elst.items[1:]:
                    self.walk(item, variables, conditions)
                return
            group = _Effects(reader, self.scope)
            for item in elst.items[1:]:
                group.walk(item, variables, conditions)
            self._nested(group, elst, variables, conditions)
            return
        if head == "when":
            if len(elst.items) != 3:
                raise reader.error(elst, "expected (when CONDITION EFFECT)")
            condition = _formula(reader, elst.items[1], scope)
            group = _Effects(reader, self.scope)
            group.walk(elst.items[2], variables, (*conditions, condition))
            self._nested(group, elst, variables, (*conditions, condition))
            return
        if head == "forall":
            if len(elst.items) != 3:
                raise reader.error(elst, "expected (forall (?x - type ...) EFFECT)")
            inner = _variables(reader, elst.items[1], f"(forall ...) in {scope.owner}")
            clash = {v.name for v in variables} & {v.name for v in inner}
            if clash:
                raise reader.error(elst, f"(forall ...) rebinds {sorted(clash)[0]}")
            group = _Effects(reader, self.scope)
            group.walk(elst.items[2], (*variables, *inner), conditions)
            self._nested(group, elst, (*variables, *inner), conditions)
            return
        if head == "increase":
            if nested:
                raise reader.unsupported(
                    elst, "a cost inside (when ...) or (forall ...) is not supported"
                )
            self._cost(elst)
            return
        if head in _NUMERIC_EFFECTS:
            raise reader.unsupported(elst, f"numeric effect {head!r} is not supported")
        if head == "not":
            if len(elst.items) != 2:
                raise reader.error(elst, "expected exactly one atom inside (not ...)")
            self.dels.append(_atom(reader, elst.items[1], scope, allow_equality=False))
            return
        if head in _CONNECTIVES:
            raise reader.error(elst, f"({head} ...) is a condition, not an effect")
        self.adds.append(_atom(reader, elst, scope, allow_equality=False))

    def _nested(
        self,
        group: _Effects,
        node: SList,
        variables: tuple[TypedName, ...],
        conditions: tuple[Formula, ...],
    ) -> None:
        """Effects gathered inside a when/forall become one conditional group (plus the
        groups nested deeper, already made)."""
        self.conditional.extend(group.conditional)
        if group.adds or group.dels:
            condition = conjunction(conditions) if conditions else None
            self.conditional.append(
                ConditionalEffect(variables, condition, tuple(group.adds), tuple(group.dels))
            )
        elif not group.conditional:
            raise self.reader.error(node, "this effect changes nothing")

    def _cost(self, lst: SList) -> None:
        reader = self.reader
        if len(lst.items) != 3:
            raise reader.error(lst, "expected (increase (total-cost) N)")
        target = reader.slist(lst.items[1], "(total-cost)")
        if reader.head(target, "total-cost") != TOTAL_COST:
            raise reader.unsupported(target, "only (total-cost) may be increased")
        amount = lst.items[2]
        if isinstance(amount, Symbol):
            value = _number(amount.text)
            if value is None or value < 0:
                raise reader.error(
                    amount, f"expected a non-negative number or (function ...), not {amount.text!r}"
                )
            self.cost = value if self.cost is None else self.cost + value
            return
        fname = reader.head(amount, "a function name")
        if fname in _ARITHMETIC:
            raise reader.unsupported(
                amount, f"arithmetic ({fname} ...) in costs is not supported; use one function"
            )
        self.cost_terms.append(_function_term(reader, amount, self.scope))


def _function_term(reader: _Reader, lst: SList, scope: _Scope) -> FunctionTerm:
    """``(f a ?x)``: a declared function, its arity, its terms in scope."""
    name = reader.head(lst, "a function name")
    args = tuple(reader.symbol(a, f"an argument of ({name} ...)") for a in lst.items[1:])
    decl = scope.functions.get(name)
    if decl is None:
        if scope.declarer is None:
            raise reader.error(lst, f"undeclared function {name!r} in {scope.owner}")
        decl = scope.declarer.function(reader, lst, name, len(args), scope.owner)
    if len(args) != decl.arity:
        where = scope.declarer.origin(name, function=True) if scope.declarer else ""
        raise reader.error(
            lst,
            f"function {name!r} takes {decl.arity} arguments but {len(args)} are given{where}",
        )
    for arg, at in zip(args, lst.items[1:], strict=True):
        _check_term(reader, arg, at, scope)
    return FunctionTerm(name, args)


@_paused
def parse_problem(
    text: str, domain: Domain, *, file: str = "<string>", strict: bool = False
) -> Problem:
    """Parse a PDDL problem against ``domain``; objects and predicates are checked.

    Lenient by default (PDDLStream's reading): a predicate or function of ``:init`` or the
    goal that the domain does not declare is declared by its first use (``Problem.inferred``);
    ``strict`` refuses it."""
    root, source = read_sexpr(text, file=file)
    reader = _Reader(source)
    name = _definition(reader, root, "problem")
    domain_name = ""
    objects: list[tuple[TypedName, Node]] = []
    init_nodes: tuple[Node, ...] = ()
    goal_node: Node | None = None
    seen: dict[str, SList] = {}
    for node in root.items[2:]:
        section = reader.slist(node, "a problem section such as (:init ...)")
        key = reader.head(section, "a section keyword")
        if key in seen:
            first = seen[key]
            raise reader.error(
                section,
                f"a second ({key} ...) section; the first is at {reader.where(first)}",
            )
        seen[key] = section
        if key == ":domain":
            if len(section.items) != 2:
                raise reader.error(section, "expected (:domain NAME)")
            domain_name = reader.symbol(section.items[1], "the domain name")
            if domain_name != domain.name:
                raise reader.error(
                    section, f"problem is for domain {domain_name!r}, not {domain.name!r}"
                )
        elif key == ":requirements":
            _check_requirements(reader, section)
        elif key == ":objects":
            objects = reader.typed_items(section.items[1:], ":objects")
        elif key == ":init":
            init_nodes = section.items[1:]
        elif key == ":goal":
            if len(section.items) != 2:
                raise reader.error(section, "expected exactly one formula in (:goal ...)")
            goal_node = section.items[1]
        elif key == ":metric":
            continue
        else:
            raise reader.error(section, f"unknown problem section {key!r}")
    if goal_node is None:
        raise reader.error(root, "expected a (:goal ...) section")
    known_types = {OBJECT_TYPE} | {t.name for t in domain.types}
    for obj, at in objects:
        if obj.type not in known_types:
            raise reader.error(at, f"object {obj.name} has undeclared type {obj.type!r}")
        if is_variable(obj.name):
            raise reader.error(at, f"object {obj.name!r} must not start with '?'")
    _unique(reader, objects, "object")
    constant_names = {c.name for c in domain.constants}
    for obj, at in objects:
        if obj.name in constant_names:
            raise reader.error(at, f"object {obj.name!r} is already a constant of the domain")
    names = {o.name for o, _ in objects} | {c.name for c in domain.constants}
    preds = {p.name: p for p in domain.predicates}
    funcs = {f.name: f for f in domain.functions}
    declarer = _Declarer(preds, funcs, strict=strict, places=dict(domain.places))
    scope = _Scope(preds, {}, names, f"problem {name}", funcs, declarer)
    init: set[Atom] = set()
    values: dict[FunctionTerm, float] = {}
    derived = domain.derived_predicates
    for node in init_nodes:
        lst = reader.slist(node, "an initial fact")
        head = reader.head(lst, "a predicate") if lst.items else ""
        if head == EQUALITY:
            _init_value(reader, lst, scope, values)
            continue
        if head == "not":
            raise reader.error(lst, "initial facts must be positive (the world is closed)")
        atom = _atom(reader, lst, scope, allow_equality=False)
        if atom.predicate in derived:
            raise reader.error(
                lst, f"{atom.predicate} is a derived predicate; it follows from the other facts"
            )
        init.add(atom)
    goal, conditions = _split(_formula(reader, goal_node, scope))
    if not goal and not conditions:
        raise reader.error(goal_node, "the goal is empty")
    return Problem(
        name,
        domain.name,
        tuple(o for o, _ in objects),
        frozenset(init),
        goal,
        source=file,
        goal_conditions=conditions,
        function_values=values,
        inferred=tuple(declarer.inferred),
    )


def _init_value(
    reader: _Reader, lst: SList, scope: _Scope, values: dict[FunctionTerm, float]
) -> None:
    """``(= (f a b) 3.5)``; ``(= (total-cost) 0)`` is accepted and ignored."""
    if len(lst.items) != 3:
        raise reader.error(lst, "expected (= (FUNCTION ...) NUMBER)")
    target = reader.slist(lst.items[1], "a function term such as (dist a b)")
    fname = reader.head(target, "a function name")
    amount = reader.symbol(lst.items[2], "a number")
    value = _number(amount)
    if value is None or value < 0:
        raise reader.error(lst.items[2], f"expected a non-negative number, not {amount!r}")
    if fname == TOTAL_COST:
        return
    term = _function_term(reader, target, scope)
    if term in values:
        raise reader.error(lst, f"{term} is given a value twice")
    values[term] = value


@dataclass
class _StreamScope:
    """What the declarations of one stream file may refer to."""

    domain: Domain
    predicates: dict[str, Predicate]
    constants: set[str]
    known_types: set[str]
    fluents: frozenset[str]
    declarer: _Declarer

    def scope(self, variables: dict[str, TypedName], owner: str) -> _Scope:
        return _Scope(
            self.predicates,
            variables,
            self.constants,
            owner,
            self.declarer.functions,
            self.declarer,
        )


OPTIMIZER_HELP = (
    "this planner queries each stream on its own and learns what each costs, so it has no "
    "joint solver: write the optimizer's (:variables ...) as a (:stream ...) whose :outputs "
    "are those variables (a sampler proposing values) and each (:constraint ...) as a test "
    "stream or a (:predicate ...), and bind them in the stream map (docs/pddl.md, Optimizers)"
)
WILD_HELP = (
    "a wild stream certifies facts it does not declare; declare what it may certify in the "
    ":certified of a (:stream ...)"
)


@_paused
def parse_streams(
    text: str, domain: Domain, *, file: str = "<string>", strict: bool = False
) -> StreamSet:
    """Parse a PDDLStream ``stream.pddl`` whose facts use ``domain``'s predicates.

    Lenient by default (PDDLStream's reading): a predicate in a stream's ``:domain`` or
    ``:certified``, or a ``(:predicate ...)`` or ``(:function ...)`` the domain does not
    declare, is declared by its first use (``StreamSet.declared``, ``declared_functions``,
    ``inferred``; :func:`load_pddlstream` gives the domain those declarations). ``strict``
    refuses them."""
    root, source = read_sexpr(text, file=file)
    reader = _Reader(source)
    name = _definition(reader, root, "stream")
    predicates = {p.name: p for p in domain.predicates}
    declarer = _Declarer(
        predicates,
        {f.name: f for f in domain.functions},
        strict=strict,
        places=dict(domain.places),
    )
    ctx = _StreamScope(
        domain,
        predicates,
        {c.name for c in domain.constants},
        {OBJECT_TYPE} | {t.name for t in domain.types} | {t.type for t in domain.types},
        domain.fluent_predicates,
        declarer,
    )
    streams: list[Stream] = []
    functions: list[StreamFunction] = []
    where: dict[str, SList] = {}
    rules = 0
    for node in root.items[2:]:
        section = reader.slist(node, "(:stream ...)")
        key = reader.head(section, ":stream")
        declared: Stream | StreamFunction
        if key == ":stream":
            declared = _parse_stream(reader, section, ctx)
        elif key == ":rule":
            rules += 1
            declared = _parse_rule(reader, section, ctx, rules)
        elif key == ":predicate":
            declared = _parse_lazy_predicate(reader, section, ctx)
        elif key == ":function":
            declared = _parse_function(reader, section, ctx)
        elif key == ":optimizer":
            raise reader.unsupported(
                section, f"(:optimizer ...) blocks are not supported: {OPTIMIZER_HELP}"
            )
        elif key in (":wild-stream", ":wild"):
            raise reader.unsupported(section, f"({key} ...) is not supported: {WILD_HELP}")
        else:
            raise reader.error(
                section,
                f"expected (:stream ...), (:rule ...), (:predicate ...) or (:function ...) "
                f"but found ({key} ...)",
            )
        first = where.get(declared.name)
        if first is not None:
            raise reader.error(
                section,
                f"stream {declared.name!r} is declared twice (first at {reader.where(first)})",
            )
        where[declared.name] = section
        if isinstance(declared, StreamFunction):
            functions.append(declared)
        else:
            streams.append(declared)
    _check_lazy(reader, streams, where)
    return StreamSet(
        name,
        tuple(streams),
        source=file,
        functions=tuple(functions),
        declared=tuple(declarer.new_predicates),
        declared_functions=tuple(declarer.new_functions),
        inferred=tuple(declarer.inferred),
    )


def _check_lazy(reader: _Reader, streams: list[Stream], where: dict[str, SList]) -> None:
    """A lazily evaluated predicate is only ever tested, never certified by a stream."""
    lazy = {s.certified[0].predicate: s for s in streams if s.kind == "predicate"}
    for s in streams:
        if s.kind == "predicate":
            continue
        for atom in s.certified:
            if atom.predicate in lazy:
                raise reader.error(
                    where[s.name],
                    f"{s.kind} {s.name} certifies {atom.predicate}, which a (:predicate ...) "
                    "declares as a lazily evaluated test",
                )


def _fact_list(
    reader: _Reader, node: Node | None, scope: _Scope, owner: str, keyword: str
) -> tuple[Atom, ...]:
    """The positive atoms of a stream's ``:domain`` or ``:certified`` conjunction."""
    if node is None:
        return ()
    out = []
    for item in _conjunction(reader, node):
        lst = reader.slist(item, "a fact such as (pose ?b ?p)")
        head = reader.head(lst, "a predicate")
        if head == "not":
            raise reader.error(
                lst,
                f"{owner}: {keyword} facts must be positive atoms; (not ...) is not allowed "
                f"(a stream only ever makes facts true)",
            )
        if head in _CONNECTIVES or head == "when":
            raise reader.error(
                lst, f"{owner}: {keyword} is a conjunction of atoms, not ({head} ...)"
            )
        out.append(_atom(reader, lst, scope, allow_equality=False))
    return tuple(out)


def _typed_vars(
    reader: _Reader, node: Node, owner: str, keyword: str, ctx: _StreamScope
) -> list[tuple[TypedName, Node]]:
    items = reader.typed_items(reader.slist(node, f"{keyword} (...)").items, owner)
    for typed, at in items:
        if not is_variable(typed.name):
            raise reader.error(at, f"{owner}: {typed.name!r} must start with '?'")
        if typed.type not in ctx.known_types:
            raise reader.error(
                at,
                f"{owner}: type {typed.type!r} of {keyword[1:-1]} {typed.name} is not a type "
                "of the domain",
            )
    return items


def _parse_stream(reader: _Reader, lst: SList, ctx: _StreamScope) -> Stream:
    if len(lst.items) < 2:
        raise reader.error(lst, "expected a stream name after :stream")
    name = reader.symbol(lst.items[1], "a stream name")
    owner = f"stream {name}"
    inputs: list[tuple[TypedName, Node]] = []
    outputs: list[tuple[TypedName, Node]] = []
    domain_node: Node | None = None
    certified_node: Node | None = None
    fluents: tuple[str, ...] = ()
    has_outputs = False
    for key, value in reader.keyword_sections(lst, 2, owner):
        if key.text == ":inputs":
            inputs = _typed_vars(reader, value, owner, ":inputs", ctx)
        elif key.text == ":outputs":
            outputs = _typed_vars(reader, value, owner, ":outputs", ctx)
            has_outputs = True
        elif key.text == ":domain":
            domain_node = value
        elif key.text == ":certified":
            certified_node = value
        elif key.text == ":fluents":
            fluents = _fluents(reader, value, owner, ctx)
        else:
            raise reader.error(
                key,
                f"unknown keyword {key.text} in {owner} "
                "(expected :inputs, :domain, :outputs, :certified or :fluents)",
            )
    in_names = [i.name for i, _ in inputs]
    declared: dict[str, TypedName] = {}
    for typed, at in [*inputs, *outputs]:
        if typed.name in declared:
            raise reader.error(at, f"{owner} repeats {typed.name} among its inputs and outputs")
        declared[typed.name] = typed
    dscope = ctx.scope({i.name: i for i, _ in inputs}, f"{owner} :domain")
    domain_atoms = _fact_list(reader, domain_node, dscope, owner, ":domain")
    mentioned = {v for a in domain_atoms for v in a.variables}
    for typed, at in inputs:
        if typed.name not in mentioned:
            raise reader.error(at, f"{owner}: input {typed.name} must appear in a :domain fact")
    for typed, at in outputs:
        if typed.name in mentioned:
            raise reader.error(
                at, f"{owner}: output {typed.name} appears in a :domain fact (outputs are new)"
            )
    if certified_node is None:
        raise reader.error(lst, f"{owner}: expected a :certified formula")
    cscope = ctx.scope(declared, f"{owner} :certified")
    _undeclared_output(reader, certified_node, declared, owner, has_outputs)
    certified = _fact_list(reader, certified_node, cscope, owner, ":certified")
    if not certified:
        raise reader.error(certified_node, f"{owner} certifies nothing")
    return Stream(
        name,
        tuple(in_names),
        domain_atoms,
        tuple(o for o, _ in outputs),
        certified,
        source=reader.file,
        line=reader.line(lst),
        fluents=fluents,
    )


def _undeclared_output(
    reader: _Reader, node: Node, declared: dict[str, TypedName], owner: str, has_outputs: bool
) -> None:
    """A stream with no ``:outputs`` whose certified facts mention a new variable forgot to
    declare its outputs: say so, rather than "not declared"."""
    if has_outputs:
        return
    for item in _conjunction(reader, node):
        if not isinstance(item, SList):
            continue
        for arg in item.items[1:]:
            if isinstance(arg, Symbol) and is_variable(arg.text) and arg.text not in declared:
                raise reader.error(
                    arg,
                    f"{owner}: {arg.text} in :certified is not an input, and the stream has no "
                    f":outputs; declare it with ':outputs ({arg.text})' (a stream without "
                    "outputs is a test of its inputs)",
                )


def _fluents(reader: _Reader, node: Node, owner: str, ctx: _StreamScope) -> tuple[str, ...]:
    lst = reader.slist(node, ":fluents (predicate ...)")
    names = []
    for item in lst.items:
        pname = reader.symbol(item, "a predicate name in :fluents")
        if pname not in ctx.predicates:
            raise reader.error(item, f"{owner}: :fluents names {pname!r}, which is not declared")
        if pname in ctx.domain.derived_predicates:
            raise reader.unsupported(
                item,
                f"{owner}: :fluents names the derived predicate {pname}; name the fluents "
                "it is derived from",
            )
        if pname not in ctx.fluents:
            raise reader.error(
                item, f"{owner}: :fluents names {pname!r}, which no action changes (not a fluent)"
            )
        if pname in names:
            raise reader.error(item, f"{owner}: :fluents names {pname!r} twice")
        names.append(pname)
    return tuple(names)


def _parse_rule(reader: _Reader, lst: SList, ctx: _StreamScope, number: int) -> Stream:
    start = 1
    name = f"rule-{number}"
    if (
        len(lst.items) > 1
        and isinstance(lst.items[1], Symbol)
        and not lst.items[1].text.startswith(":")
    ):
        name = lst.items[1].text
        start = 2
    owner = f"rule {name}"
    inputs: list[tuple[TypedName, Node]] = []
    domain_node: Node | None = None
    certified_node: Node | None = None
    for key, value in reader.keyword_sections(lst, start, owner):
        if key.text == ":inputs":
            inputs = _typed_vars(reader, value, owner, ":inputs", ctx)
        elif key.text == ":domain":
            domain_node = value
        elif key.text == ":certified":
            certified_node = value
        else:
            raise reader.error(
                key,
                f"unknown keyword {key.text} in {owner} (expected :inputs, :domain, :certified)",
            )
    declared = {i.name: i for i, _ in inputs}
    dscope = ctx.scope(declared, f"{owner} :domain")
    domain_atoms = _fact_list(reader, domain_node, dscope, owner, ":domain")
    mentioned = {v for a in domain_atoms for v in a.variables}
    for typed, at in inputs:
        if typed.name not in mentioned:
            raise reader.error(at, f"{owner}: input {typed.name} must appear in a :domain fact")
    if certified_node is None:
        raise reader.error(lst, f"{owner}: expected a :certified formula")
    cscope = ctx.scope(declared, f"{owner} :certified")
    certified = _fact_list(reader, certified_node, cscope, owner, ":certified")
    if not certified:
        raise reader.error(certified_node, f"{owner} certifies nothing")
    return Stream(
        name,
        tuple(declared),
        domain_atoms,
        (),
        certified,
        source=reader.file,
        line=reader.line(lst),
        kind="rule",
    )


def _head_vars(reader: _Reader, head: SList, owner: str) -> tuple[str, ...]:
    names = []
    for item in head.items[1:]:
        var = reader.symbol(item, f"a variable in the head of {owner}")
        if not is_variable(var):
            raise reader.error(item, f"{owner}: {var!r} must be a variable such as ?x")
        if var in names:
            raise reader.error(item, f"{owner} repeats {var}")
        names.append(var)
    return tuple(names)


def _head_and_domain(
    reader: _Reader, lst: SList, ctx: _StreamScope, kind: str, arities: dict[str, int]
) -> tuple[str, tuple[str, ...], tuple[Atom, ...], SList]:
    """``(:predicate (NAME ?x ...) DOMAIN)`` or ``(:function ...)``: the name (one of
    ``arities``, with that many variables), the variables and the domain facts."""
    example = "(collision ?p ?q)" if kind == "predicate" else "(dist ?q1 ?q2)"
    if len(lst.items) not in (2, 3):
        raise reader.error(lst, f"expected (:{kind} (NAME ?x ...) DOMAIN)")
    head = reader.slist(lst.items[1], f"the {kind}, such as {example}")
    name = reader.head(head, f"a {kind} name")
    owner = f"{kind} {name}"
    inputs = _head_vars(reader, head, owner)
    if name not in arities:
        section = ":predicates" if kind == "predicate" else ":functions"
        if ctx.declarer.strict:
            raise reader.error(
                head, f"{owner} is not declared in the domain's {section} ({STRICT_HINT})"
            )
        if kind == "predicate":
            ctx.declarer.predicate(reader, head, name, len(inputs), f"(:predicate {name} ...)")
        else:
            ctx.declarer.function(reader, head, name, len(inputs), f"(:function {name} ...)")
        arities[name] = len(inputs)
    if len(inputs) != arities[name]:
        where = ctx.declarer.origin(name, function=kind == "function")
        raise reader.error(
            head,
            f"{kind} {name!r} takes {arities[name]} arguments but {len(inputs)} are given{where}",
        )
    dscope = ctx.scope({v: TypedName(v) for v in inputs}, f"{owner} domain")
    domain_atoms = _fact_list(
        reader, lst.items[2] if len(lst.items) == 3 else None, dscope, owner, "its domain"
    )
    mentioned = {v for a in domain_atoms for v in a.variables}
    for var, at in zip(inputs, head.items[1:], strict=True):
        if var not in mentioned:
            raise reader.error(at, f"{owner}: {var} must appear in a domain fact")
    return name, inputs, domain_atoms, head


def _parse_lazy_predicate(reader: _Reader, lst: SList, ctx: _StreamScope) -> Stream:
    arities = {p.name: p.arity for p in ctx.predicates.values()}
    name, inputs, domain_atoms, head = _head_and_domain(reader, lst, ctx, "predicate", arities)
    if name in ctx.fluents or name in ctx.domain.derived_predicates:
        kind = "an action changes it" if name in ctx.fluents else "it is derived"
        raise reader.error(head, f"predicate {name} cannot be a lazily evaluated test: {kind}")
    return Stream(
        name,
        inputs,
        domain_atoms,
        (),
        (Atom(name, inputs),),
        source=reader.file,
        line=reader.line(lst),
        kind="predicate",
    )


def _parse_function(reader: _Reader, lst: SList, ctx: _StreamScope) -> StreamFunction:
    arities = {f.name: f.arity for f in ctx.declarer.functions.values()}
    name, inputs, domain_atoms, _ = _head_and_domain(reader, lst, ctx, "function", arities)
    return StreamFunction(name, inputs, domain_atoms, source=reader.file, line=reader.line(lst))


def load_domain(path: str | Path, *, strict: bool = False) -> Domain:
    return parse_domain(read_file(path), file=str(path), strict=strict)


def load_problem(path: str | Path, domain: Domain, *, strict: bool = False) -> Problem:
    return parse_problem(read_file(path), domain, file=str(path), strict=strict)


def load_streams(path: str | Path, domain: Domain, *, strict: bool = False) -> StreamSet:
    return parse_streams(read_file(path), domain, file=str(path), strict=strict)


def with_stream_declarations(domain: Domain, streams: StreamSet) -> Domain:
    """``domain`` with the predicates and functions ``streams`` declared by their use."""
    return domain.declaring(streams.declared, streams.declared_functions)


def load_pddlstream(
    domain_path: str | Path, stream_path: str | Path, *, strict: bool = False
) -> tuple[Domain, StreamSet]:
    """A domain file and its stream file, the domain holding what the stream file declared
    by use (each file's ``inferred`` lists what was inferred from it)."""
    domain = load_domain(domain_path, strict=strict)
    streams = load_streams(stream_path, domain, strict=strict)
    return with_stream_declarations(domain, streams), streams
