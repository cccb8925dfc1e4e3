"""Parsers for PDDL domains and problems and for PDDLStream ``stream.pddl`` files.

Supported: ``:strips :typing :negative-preconditions :equality :action-costs``. Anything else
(``:fluents``, derived predicates, quantifiers, conditional effects, ...) is rejected with an
:class:`UnsupportedPDDLError` that points at the construct.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from planner.pddl.errors import PDDLError, UnsupportedPDDLError
from planner.pddl.sexpr import Node, SList, Symbol, read_sexpr
from planner.pddl.structs import (
    EQUALITY,
    OBJECT_TYPE,
    Action,
    Atom,
    Domain,
    Literal,
    Predicate,
    Problem,
    Stream,
    StreamSet,
    TypedName,
    is_variable,
)

SUPPORTED_REQUIREMENTS = frozenset(
    {":strips", ":typing", ":negative-preconditions", ":equality", ":action-costs"}
)
_UNSUPPORTED_CONNECTIVES = {
    "or": "disjunctive preconditions",
    "exists": "existential quantifiers",
    "forall": "universal quantifiers",
    "imply": "implications",
    "when": "conditional effects",
}
TOTAL_COST = "total-cost"


class _Reader:
    """Shared helpers that turn S-expression nodes into checked values, with positions."""

    def __init__(self, file: str) -> None:
        self.file = file

    def error(self, node: Node, message: str) -> PDDLError:
        return PDDLError(message, file=self.file, line=node.line, column=node.column)

    def unsupported(self, node: Node, message: str) -> UnsupportedPDDLError:
        return UnsupportedPDDLError(message, file=self.file, line=node.line, column=node.column)

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

    def typed_list(self, lst: SList | Iterable[Node], what: str) -> tuple[TypedName, ...]:
        """``a b - t c`` -> a:t, b:t, c:object."""
        items = list(lst.items if isinstance(lst, SList) else lst)
        out: list[TypedName] = []
        pending: list[str] = []
        i = 0
        while i < len(items):
            node = items[i]
            if isinstance(node, Symbol) and node.text == "-":
                if i + 1 >= len(items):
                    raise self.error(node, f"expected a type name after '-' in {what}")
                type_node = items[i + 1]
                if isinstance(type_node, SList):
                    raise self.unsupported(type_node, "'either' types are not supported")
                if not pending:
                    raise self.error(node, f"expected a name before '- {type_node.text}' in {what}")
                out.extend(TypedName(n, type_node.text) for n in pending)
                pending = []
                i += 2
                continue
            pending.append(self.symbol(node, f"a name in {what}"))
            i += 1
        out.extend(TypedName(n) for n in pending)
        return tuple(out)

    def keyword_sections(self, lst: SList, start: int, what: str) -> list[tuple[Symbol, Node]]:
        """``:key value :key value`` pairs of an action or stream body."""
        items = lst.items[start:]
        pairs: list[tuple[Symbol, Node]] = []
        for i in range(0, len(items), 2):
            key = items[i]
            if not isinstance(key, Symbol) or not key.text.startswith(":"):
                raise self.error(key, f"expected a keyword such as ':parameters' in {what}")
            if i + 1 >= len(items):
                raise self.error(key, f"expected a value after {key.text} in {what}")
            pairs.append((key, items[i + 1]))
        return pairs


class _Scope:
    """What a formula may mention: declared predicates, variables and objects."""

    def __init__(
        self,
        predicates: dict[str, Predicate],
        variables: Iterable[str],
        objects: Iterable[str],
        owner: str,
    ) -> None:
        self.predicates = predicates
        self.variables = set(variables)
        self.objects = set(objects)
        self.owner = owner


def _atom(reader: _Reader, node: Node, scope: _Scope, *, allow_equality: bool) -> Atom:
    lst = reader.slist(node, "an atom such as (pred ?x)")
    name = reader.head(lst, "a predicate name")
    if name in _UNSUPPORTED_CONNECTIVES:
        raise reader.unsupported(lst, f"{_UNSUPPORTED_CONNECTIVES[name]} are not supported")
    args = tuple(reader.symbol(a, f"an argument of ({name} ...)") for a in lst.items[1:])
    if name == EQUALITY:
        if not allow_equality:
            raise reader.error(lst, f"equality is not allowed here ({scope.owner})")
        if len(args) != 2:
            raise reader.error(lst, "expected exactly two arguments to '='")
    else:
        pred = scope.predicates.get(name)
        if pred is None:
            raise reader.error(lst, f"undeclared predicate {name!r} in {scope.owner}")
        if pred.arity != len(args):
            raise reader.error(
                lst, f"predicate {name!r} takes {pred.arity} arguments but {len(args)} are given"
            )
    for arg, arg_node in zip(args, lst.items[1:], strict=True):
        if is_variable(arg):
            if arg not in scope.variables:
                raise reader.error(arg_node, f"variable {arg} is not declared in {scope.owner}")
        elif arg not in scope.objects:
            raise reader.error(arg_node, f"unknown object or constant {arg!r} in {scope.owner}")
    return Atom(name, args)


def _literal(reader: _Reader, node: Node, scope: _Scope) -> Literal:
    lst = reader.slist(node, "a literal")
    if lst.items and isinstance(lst.items[0], Symbol) and lst.items[0].text == "not":
        if len(lst.items) != 2:
            raise reader.error(lst, "expected exactly one formula inside (not ...)")
        return Literal(_atom(reader, lst.items[1], scope, allow_equality=True), positive=False)
    return Literal(_atom(reader, lst, scope, allow_equality=True))


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


def parse_domain(text: str, *, file: str = "<string>") -> Domain:
    """Parse a PDDL domain; errors carry file, line and column."""
    reader = _Reader(file)
    root = read_sexpr(text, file=file)
    name = _definition(reader, root, "domain")
    requirements: tuple[str, ...] = ()
    types: tuple[TypedName, ...] = ()
    constants: tuple[TypedName, ...] = ()
    predicates: dict[str, Predicate] = {}
    action_nodes: list[SList] = []
    uses_costs = False
    for node in root.items[2:]:
        section = reader.slist(node, "a domain section such as (:predicates ...)")
        key = reader.head(section, "a section keyword")
        if key == ":requirements":
            requirements = _check_requirements(reader, section)
        elif key == ":types":
            types = reader.typed_list(section.items[1:], ":types")
        elif key == ":constants":
            constants = reader.typed_list(section.items[1:], ":constants")
        elif key == ":predicates":
            for pnode in section.items[1:]:
                plst = reader.slist(pnode, "a predicate declaration such as (on ?x ?y)")
                pname = reader.head(plst, "a predicate name")
                if pname in predicates:
                    raise reader.error(plst, f"predicate {pname!r} is declared twice")
                params = reader.typed_list(plst.items[1:], f"predicate {pname}")
                predicates[pname] = Predicate(pname, params)
        elif key == ":functions":
            for fnode in section.items[1:]:
                if isinstance(fnode, Symbol) and fnode.text in ("-", "number"):
                    continue
                flst = reader.slist(fnode, "a function declaration")
                if reader.head(flst, "a function name") != TOTAL_COST or len(flst.items) != 1:
                    raise reader.unsupported(
                        flst, "numeric fluents are not supported (only (total-cost))"
                    )
                uses_costs = True
        elif key == ":action":
            action_nodes.append(section)
        elif key in (":derived", ":durative-action", ":process", ":event", ":axiom"):
            raise reader.unsupported(section, f"{key} is not supported")
        else:
            raise reader.error(
                section,
                f"unknown domain section {key!r} (expected :requirements, :types, :constants, "
                ":predicates, :functions or :action)",
            )
    known_types = {OBJECT_TYPE} | {t.name for t in types} | {t.type for t in types}
    for typed in (*constants, *(p for pr in predicates.values() for p in pr.params)):
        if typed.type not in known_types:
            raise reader.error(root, f"type {typed.type!r} of {typed.name} is not declared")
    const_names = [c.name for c in constants]
    actions = tuple(
        _parse_action(reader, a, predicates, const_names, uses_costs) for a in action_nodes
    )
    names = [a.name for a in actions]
    for a, anode in zip(actions, action_nodes, strict=True):
        if names.count(a.name) > 1:
            raise reader.error(anode, f"action {a.name!r} is defined twice")
    return Domain(
        name=name,
        requirements=requirements,
        types=types,
        constants=constants,
        predicates=tuple(predicates.values()),
        actions=actions,
        uses_action_costs=uses_costs,
        source=file,
    )


def _parse_action(
    reader: _Reader,
    lst: SList,
    predicates: dict[str, Predicate],
    constants: list[str],
    uses_costs: bool,
) -> Action:
    if len(lst.items) < 2:
        raise reader.error(lst, "expected an action name after :action")
    name = reader.symbol(lst.items[1], "an action name")
    owner = f"action {name}"
    params: tuple[TypedName, ...] = ()
    pre_node: Node | None = None
    eff_node: Node | None = None
    for key, value in reader.keyword_sections(lst, 2, owner):
        if key.text == ":parameters":
            params = reader.typed_list(reader.slist(value, ":parameters (...)"), owner)
            for p in params:
                if not is_variable(p.name):
                    raise reader.error(
                        value, f"parameter {p.name!r} of {owner} must start with '?'"
                    )
        elif key.text == ":precondition":
            pre_node = value
        elif key.text == ":effect":
            eff_node = value
        else:
            raise reader.error(key, f"unknown keyword {key.text} in {owner}")
    names = [p.name for p in params]
    if len(set(names)) != len(names):
        raise reader.error(lst, f"{owner} repeats a parameter")
    scope = _Scope(predicates, names, constants, owner)
    pre = (
        tuple(_literal(reader, n, scope) for n in _conjunction(reader, pre_node))
        if pre_node
        else ()
    )
    adds: list[Atom] = []
    dels: list[Atom] = []
    cost: int | None = None
    for node in _conjunction(reader, eff_node) if eff_node else ():
        elst = reader.slist(node, "an effect")
        head = reader.head(elst, "an effect")
        if head == "not":
            if len(elst.items) != 2:
                raise reader.error(elst, "expected exactly one atom inside (not ...)")
            dels.append(_atom(reader, elst.items[1], scope, allow_equality=False))
        elif head == "increase":
            cost = _parse_cost(reader, elst, uses_costs)
        elif head in ("decrease", "assign", "scale-up", "scale-down"):
            raise reader.unsupported(elst, f"numeric effect {head!r} is not supported")
        else:
            adds.append(_atom(reader, elst, scope, allow_equality=False))
    return Action(name, params, pre, tuple(adds), tuple(dels), cost)


def _parse_cost(reader: _Reader, lst: SList, uses_costs: bool) -> int:
    if not uses_costs:
        raise reader.error(lst, "(increase ...) needs (:functions (total-cost) - number)")
    if len(lst.items) != 3:
        raise reader.error(lst, "expected (increase (total-cost) N)")
    target = reader.slist(lst.items[1], "(total-cost)")
    if reader.head(target, "total-cost") != TOTAL_COST:
        raise reader.unsupported(target, "only (total-cost) may be increased")
    amount = reader.symbol(lst.items[2], "a non-negative integer cost")
    if not amount.isdigit():
        raise reader.unsupported(
            lst.items[2], f"cost must be a non-negative integer, not {amount!r}"
        )
    return int(amount)


def parse_problem(text: str, domain: Domain, *, file: str = "<string>") -> Problem:
    """Parse a PDDL problem against ``domain``; objects and predicates are checked."""
    reader = _Reader(file)
    root = read_sexpr(text, file=file)
    name = _definition(reader, root, "problem")
    domain_name = ""
    objects: tuple[TypedName, ...] = ()
    init_nodes: tuple[Node, ...] = ()
    goal_node: Node | None = None
    for node in root.items[2:]:
        section = reader.slist(node, "a problem section such as (:init ...)")
        key = reader.head(section, "a section keyword")
        if key == ":domain":
            domain_name = reader.symbol(section.items[1], "the domain name")
            if domain_name != domain.name:
                raise reader.error(
                    section, f"problem is for domain {domain_name!r}, not {domain.name!r}"
                )
        elif key == ":requirements":
            _check_requirements(reader, section)
        elif key == ":objects":
            objects = reader.typed_list(section.items[1:], ":objects")
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
    for obj in objects:
        if obj.type not in known_types:
            raise reader.error(root, f"object {obj.name} has undeclared type {obj.type!r}")
    names = [o.name for o in objects] + [c.name for c in domain.constants]
    for o in objects:
        if names.count(o.name) > 1:
            raise reader.error(root, f"object {o.name!r} is declared twice")
    preds = {p.name: p for p in domain.predicates}
    scope = _Scope(preds, (), names, f"problem {name}")
    init: set[Atom] = set()
    for node in init_nodes:
        lst = reader.slist(node, "an initial fact")
        if lst.items and isinstance(lst.items[0], Symbol) and lst.items[0].text == EQUALITY:
            continue  # (= (total-cost) 0)
        if lst.items and isinstance(lst.items[0], Symbol) and lst.items[0].text == "not":
            raise reader.error(lst, "initial facts must be positive (the world is closed)")
        init.add(_atom(reader, lst, scope, allow_equality=False))
    goal = tuple(_literal(reader, n, scope) for n in _conjunction(reader, goal_node))
    if not goal:
        raise reader.error(goal_node, "the goal is empty")
    return Problem(name, domain.name, objects, frozenset(init), goal, source=file)


def parse_streams(text: str, domain: Domain, *, file: str = "<string>") -> StreamSet:
    """Parse a PDDLStream ``stream.pddl`` whose facts use ``domain``'s predicates."""
    reader = _Reader(file)
    root = read_sexpr(text, file=file)
    name = _definition(reader, root, "stream")
    preds = {p.name: p for p in domain.predicates}
    constants = [c.name for c in domain.constants]
    streams: list[Stream] = []
    for node in root.items[2:]:
        section = reader.slist(node, "(:stream ...)")
        key = reader.head(section, ":stream")
        if key in (":function", ":predicate", ":rule", ":optimizer", ":wild-stream"):
            raise reader.unsupported(section, f"{key} declarations are not supported")
        if key != ":stream":
            raise reader.error(section, f"expected (:stream ...) but found ({key} ...)")
        streams.append(_parse_stream(reader, section, preds, constants))
    for s, snode in zip(streams, root.items[2:], strict=True):
        if sum(1 for o in streams if o.name == s.name) > 1:
            raise reader.error(snode, f"stream {s.name!r} is declared twice")
    return StreamSet(name, tuple(streams), source=file)


def _parse_stream(
    reader: _Reader, lst: SList, predicates: dict[str, Predicate], constants: list[str]
) -> Stream:
    if len(lst.items) < 2:
        raise reader.error(lst, "expected a stream name after :stream")
    name = reader.symbol(lst.items[1], "a stream name")
    owner = f"stream {name}"
    inputs: tuple[TypedName, ...] = ()
    outputs: tuple[TypedName, ...] = ()
    domain_node: Node | None = None
    certified_node: Node | None = None
    for key, value in reader.keyword_sections(lst, 2, owner):
        if key.text == ":inputs":
            inputs = reader.typed_list(reader.slist(value, ":inputs (...)"), owner)
        elif key.text == ":outputs":
            outputs = reader.typed_list(reader.slist(value, ":outputs (...)"), owner)
        elif key.text == ":domain":
            domain_node = value
        elif key.text == ":certified":
            certified_node = value
        elif key.text == ":fluents":
            raise reader.unsupported(key, f":fluents in {owner} are not supported")
        else:
            raise reader.error(
                key,
                f"unknown keyword {key.text} in {owner} "
                "(expected :inputs, :domain, :outputs or :certified)",
            )
    for typed in (*inputs, *outputs):
        if not is_variable(typed.name):
            raise reader.error(lst, f"{owner}: {typed.name!r} must start with '?'")
    in_names = [i.name for i in inputs]
    out_names = [o.name for o in outputs]
    if len(set(in_names + out_names)) != len(in_names) + len(out_names):
        raise reader.error(lst, f"{owner} repeats an input or output")
    dscope = _Scope(predicates, in_names, constants, f"{owner} :domain")
    domain_atoms = tuple(
        _atom(reader, n, dscope, allow_equality=False)
        for n in (_conjunction(reader, domain_node) if domain_node else ())
    )
    mentioned = {v for a in domain_atoms for v in a.variables}
    for var in in_names:
        if var not in mentioned:
            raise reader.error(lst, f"{owner}: input {var} must appear in a :domain fact")
    if certified_node is None:
        raise reader.error(lst, f"{owner}: expected a :certified formula")
    cscope = _Scope(predicates, in_names + out_names, constants, f"{owner} :certified")
    certified = tuple(
        _atom(reader, n, cscope, allow_equality=False) for n in _conjunction(reader, certified_node)
    )
    if not certified:
        raise reader.error(certified_node, f"{owner} certifies nothing")
    return Stream(
        name,
        tuple(in_names),
        domain_atoms,
        outputs,
        certified,
        source=reader.file,
        line=lst.line,
    )


def load_domain(path: str | Path) -> Domain:
    p = Path(path)
    return parse_domain(p.read_text(encoding="utf-8"), file=str(p))


def load_problem(path: str | Path, domain: Domain) -> Problem:
    p = Path(path)
    return parse_problem(p.read_text(encoding="utf-8"), domain, file=str(p))


def load_streams(path: str | Path, domain: Domain) -> StreamSet:
    p = Path(path)
    return parse_streams(p.read_text(encoding="utf-8"), domain, file=str(p))
