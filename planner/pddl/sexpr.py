"""S-expression reader that keeps the line and column of every token (for error messages)."""

from __future__ import annotations

from dataclasses import dataclass

from planner.pddl.errors import PDDLError


@dataclass(frozen=True)
class Symbol:
    """One token; PDDL is case-insensitive, so ``text`` is lower-cased."""

    text: str
    line: int
    column: int


@dataclass(frozen=True)
class SList:
    """A parenthesised list and the position of its opening parenthesis."""

    items: tuple[Symbol | SList, ...]
    line: int
    column: int


Node = Symbol | SList


def read_sexpr(text: str, *, file: str) -> SList:
    """Read exactly one top-level list from ``text``; comments start with ``;``."""
    stack: list[tuple[list[Node], int, int]] = []
    result: SList | None = None
    line, column = 1, 0
    i, n = 0, len(text)
    while i < n:
        ch = text[i]
        column += 1
        if ch == "\n":
            line, column = line + 1, 0
            i += 1
            continue
        if ch.isspace():
            i += 1
            continue
        if ch == ";":
            while i < n and text[i] != "\n":
                i += 1
            column -= 1
            continue
        if ch == "(":
            if result is not None and not stack:
                raise PDDLError(
                    "expected end of file after the closing ')' of the definition",
                    file=file,
                    line=line,
                    column=column,
                )
            stack.append(([], line, column))
            i += 1
            continue
        if ch == ")":
            if not stack:
                raise PDDLError("unexpected ')'", file=file, line=line, column=column)
            items, l0, c0 = stack.pop()
            lst = SList(tuple(items), l0, c0)
            if stack:
                stack[-1][0].append(lst)
            else:
                result = lst
            i += 1
            continue
        start, start_col = i, column
        while i < n and not text[i].isspace() and text[i] not in "();":
            i += 1
        column = start_col + (i - start) - 1
        token = Symbol(text[start:i].lower(), line, start_col)
        if not stack:
            raise PDDLError(
                f"expected '(' but found {token.text!r}", file=file, line=line, column=start_col
            )
        stack[-1][0].append(token)
    if stack:
        _, l0, c0 = stack[-1]
        raise PDDLError(
            f"expected ')' to close the list opened at line {l0}, column {c0}, but the file ended",
            file=file,
            line=line,
            column=max(column, 1),
        )
    if result is None:
        raise PDDLError(
            "expected '(define ...)' but the file is empty", file=file, line=1, column=1
        )
    return result
