"""Which stream instances a formula needs: the support of a condition in the optimistic state.

The top-k planner saw the optimistic state O: every certified fact of every stream instance.
A bound plan lives in a smaller state R: the initial facts and the certified facts of the
streams in its stream plan (R is O restricted to those). A condition that holds in O holds in R
once R keeps the facts that make it true, and lacks none whose absence it relies on: a
positive atom certified by a stream needs that stream; a negated atom absent from O is absent
from R; a lazily evaluated predicate assumed false needs its test; an existential witness that
is an optimistic object needs the stream that makes it. Where the formula offers a choice (a
disjunct, a witness) the cheapest support is taken: the fewest instances not already needed.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping

from planner.abstract.errors import AbstractPlanningError
from planner.abstract.instantiate import OPTIMISTIC_PREFIX, OptimisticInstantiation
from planner.pddl.semantics import Evaluator, derived_strata, negation
from planner.pddl.structs import (
    EQUALITY,
    And,
    Atom,
    DerivedPredicate,
    Domain,
    Exists,
    Formula,
    Imply,
    Literal,
    Not,
    Or,
    literals,
)

Support = frozenset[int]  # indices of stream instances
_EMPTY: Support = frozenset()


class Explainer:
    """Supports of formulas in one optimistic state (``evaluator`` reads O)."""

    def __init__(
        self,
        domain: Domain,
        evaluator: Evaluator,
        inst: OptimisticInstantiation,
        init: Collection[Atom],
        needed: Collection[int],
    ) -> None:
        self.domain = domain
        self.ev = evaluator
        self.inst = inst
        self.init = init
        self.needed = needed  # instances the plan needs already: choices prefer them
        self._rules: dict[str, list[DerivedPredicate]] = {}
        for d in domain.derived:
            self._rules.setdefault(d.name, []).append(d)
        self._strata = derived_strata(domain) if domain.derived else {}
        self._memo: dict[tuple[Atom, bool], Support | None] = {}
        self._fixing: dict[str, dict[tuple[str, ...], Support]] = {}
        self._fixed: set[str] = set()
        self._lazy = frozenset(a.predicate for a in inst.tests)

    def cost(self, support: Support) -> int:
        return sum(1 for i in support if i not in self.needed)

    def _cheapest(self, options: list[Support]) -> Support | None:
        best: Support | None = None
        for s in options:
            if best is None or self.cost(s) < self.cost(best):
                best = s
        return best

    # --- atoms ----------------------------------------------------------------------------

    def atom(self, atom: Atom, truth: bool) -> Support | None:
        """What makes ground ``atom`` have ``truth`` in R (None: it does not in O)."""
        if atom.predicate == EQUALITY:
            return _EMPTY if (atom.args[0] == atom.args[1]) == truth else None
        if atom.predicate in self._rules:
            return self._derived(atom, truth)
        if atom.predicate in self._lazy:
            if atom in self.init:
                return _EMPTY if truth else None
            if truth:
                return None
            test = self.inst.tests.get(atom)
            return _EMPTY if test is None else frozenset({test})
        present = self.ev.atom(atom) is True
        if present != truth:
            return None
        if truth and atom not in self.init and atom in self.inst.certifier:
            return frozenset({self.inst.certifier[atom]})
        return _EMPTY

    def _derived(self, atom: Atom, truth: bool) -> Support | None:
        fixing = self._fixing.get(atom.predicate)
        if fixing is not None:
            if not truth:
                raise AbstractPlanningError(
                    f"derived predicate {atom.predicate} is negated inside its own recursion"
                )
            return fixing.get(atom.args)
        key = (atom, truth)
        if key in self._memo:
            return self._memo[key]
        group = self._strata.get(atom.predicate, frozenset())
        if group:
            result = self._recursive(atom, truth, group)
        else:
            self._memo[key] = None  # no recursion: a placeholder cannot be read back
            result = self._rule_support(atom, truth)
        self._memo[key] = result
        return result

    def _bodies(self, atom: Atom) -> list[tuple[Formula, dict[str, str]]]:
        out = []
        for rule in self._rules[atom.predicate]:
            fits = all(
                self.ev.universe.fits(a, p) for a, p in zip(atom.args, rule.params, strict=True)
            )
            if fits:
                env = {p.name: a for p, a in zip(rule.params, atom.args, strict=True)}
                out.append((rule.body, env))
        return out

    def _rule_support(self, atom: Atom, truth: bool) -> Support | None:
        bodies = self._bodies(atom)
        if truth:  # one body that holds
            options = [
                s for body, env in bodies if (s := self.formula(body, env, True)) is not None
            ]
            return self._cheapest(options)
        parts: set[int] = set()  # every body false
        for body, env in bodies:
            s = self.formula(body, env, False)
            if s is None:
                return None
            parts |= s
        return frozenset(parts)

    def _recursive(self, atom: Atom, truth: bool, group: frozenset[str]) -> Support | None:
        if not truth:
            self._check_monotone(group)
            return _EMPTY if self.ev.atom(atom) is not True else None
        if atom.predicate not in self._fixed:
            self._derive_group(group)
        return self._memo.get((atom, True))

    def _derive_group(self, group: frozenset[str]) -> None:
        """A derivation for every atom of a recursive group: rounds of the fixed point, each
        atom keeping the support of the round that first derived it."""
        ext: dict[str, dict[tuple[str, ...], Support]] = {name: {} for name in group}
        self._fixing.update(ext)
        try:
            changed = True
            while changed:
                changed = False
                found: list[tuple[str, tuple[str, ...], Support]] = []
                for name in group:
                    for rule in self._rules[name]:
                        for env in self.ev.witnesses(rule.params, rule.body, {}):
                            args = tuple(env[p.name] for p in rule.params)
                            if args in ext[name]:
                                continue
                            s = self.formula(rule.body, env, True)
                            if s is not None:
                                found.append((name, args, s))
                for name, args, s in found:
                    if args not in ext[name]:
                        ext[name][args] = s
                        changed = True
        finally:
            for name in group:
                self._fixing.pop(name, None)
        for name in group:
            for args, support in ext[name].items():
                self._memo[(Atom(name, args), True)] = support
        self._fixed.update(group)

    def _check_monotone(self, group: frozenset[str]) -> None:
        """A recursive predicate is negated: its absence in O carries over to R only if its
        definition never negates a stream's fact."""
        certified = {a.predicate for a in self.inst.certifier} | self._lazy
        for name in group:
            for rule in self._rules[name]:
                for lit, positive in literals(rule.body):
                    if not positive and lit.atom.predicate in certified:
                        raise AbstractPlanningError(
                            f"derived predicate {name} is recursive, negated in the plan, and "
                            f"negates {lit.atom.predicate}, which streams certify: not supported"
                        )

    # --- formulas -------------------------------------------------------------------------

    def formula(self, formula: Formula, env: Mapping[str, str], truth: bool) -> Support | None:
        """What makes ``formula`` (under ``env``) have ``truth`` in R; None if it does not
        in O."""
        if isinstance(formula, Literal):
            return self.atom(formula.atom.substitute(env), formula.positive == truth)
        if isinstance(formula, Not):
            return self.formula(formula.part, env, not truth)
        if isinstance(formula, Imply):
            return self.formula(Or((negation(formula.condition), formula.consequence)), env, truth)
        if isinstance(formula, And | Or):
            every = isinstance(formula, And) == truth  # all parts must have ``truth``
            if every:
                parts: set[int] = set()
                for part in formula.parts:
                    s = self.formula(part, env, truth)
                    if s is None:
                        return None
                    parts |= s
                return frozenset(parts)
            options = []
            for part in formula.parts:
                s = self.formula(part, env, truth)
                if s is not None:
                    if self.cost(s) == 0:
                        return s
                    options.append(s)
            return self._cheapest(options)
        some = isinstance(formula, Exists) == truth  # one witness suffices
        if some:
            body = formula.body if truth else negation(formula.body)
            best: Support | None = None
            for binding in self.ev.witnesses(formula.variables, body, env):
                s = self.formula(formula.body, binding, truth)
                if s is None:
                    continue
                s = s | self._producers(binding[v.name] for v in formula.variables)
                if best is None or self.cost(s) < self.cost(best):
                    best = s
                    if self.cost(s) == 0:
                        break
            return best
        # every binding: those that could make the body have the other truth value in R
        other = negation(formula.body) if truth else formula.body
        parts = set()
        for binding in self.ev.witnesses(formula.variables, other, env):
            s = self.formula(formula.body, binding, truth)
            if s is None:
                return None
            parts |= s
        return frozenset(parts)

    def _producers(self, names: Iterable[str]) -> Support:
        """The streams that make the optimistic objects among ``names``."""
        return frozenset(
            self.inst.producer[n]
            for n in names
            if n.startswith(OPTIMISTIC_PREFIX) and n in self.inst.producer
        )
