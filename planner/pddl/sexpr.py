"""S-expression reader that keeps the line and column of every token (for error messages).

Reading is linear in the file's size (one regular expression per line). When the parentheses
do not balance, the reader guesses where one is missing or extra from the indentation: a list
that starts as far left as an open list that began on an earlier line was probably meant to
follow it, not sit inside it; a line indented deeper than the earlier items of its list
probably follows a ``)`` that closed something too early.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from planner.pddl.errors import PDDLError

BOM = "\ufeff"
_TOKEN = re.compile(r"[()]|;.*|[^\s();]+")
# Control characters other than whitespace, and a byte-order mark past the start.
_BAD_CHAR = re.compile("[\x00-\x08\x0e-\x1f\x7f\ufeff]")
_CHAR_NAMES = {"\x00": "NUL", "\x7f": "DEL", BOM: "a byte-order mark (U+FEFF)"}


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


def decode(data: bytes, *, file: str) -> str:
    """UTF-8 text of a file's bytes; a byte that is not UTF-8 is a :class:`PDDLError` at its
    line and column."""
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        before = data[: exc.start]
        line = before.count(b"\n") + 1
        start = before.rfind(b"\n") + 1
        column = len(before[start:].decode("utf-8", errors="replace")) + 1
        raise PDDLError(
            f"byte 0x{data[exc.start]:02x} is not UTF-8 text (the file must be UTF-8)",
            file=file,
            line=line,
            column=column,
        ) from None


def read_file(path: str | Path) -> str:
    """A PDDL file's text, checked to be UTF-8."""
    p = Path(path)
    return decode(p.read_bytes(), file=str(p))


def _char_name(ch: str) -> str:
    return _CHAR_NAMES.get(ch, f"control character U+{ord(ch):04X}")


def _check_characters(lines: list[str], *, file: str) -> None:
    """Refuse control characters and stray byte-order marks outside comments."""
    for number, text in enumerate(lines, start=1):
        bad = _BAD_CHAR.search(text)
        if bad is None:
            continue
        comment = text.find(";")
        if 0 <= comment < bad.start():
            continue
        raise PDDLError(
            f"unexpected {_char_name(bad.group())} (names and keywords are printable text)",
            file=file,
            line=number,
            column=bad.start() + 1,
        )


@dataclass(eq=False)
class _Open:
    """A list being read: its items and where it opened."""

    items: list[Node]
    line: int
    column: int


def read_sexpr(text: str, *, file: str) -> SList:
    """Read exactly one top-level list from ``text``; comments start with ``;``."""
    if text.startswith(BOM):
        text = text[1:]
    lines = text.split("\n")
    _check_characters(lines, file=file)
    stack: list[_Open] = []
    result: SList | None = None
    closed_at = (0, 0)  # where the top-level list closed
    # The first list that looked unclosed where a later one started as far left, and the
    # first ')' that looked one too many: reported only if the file does not balance.
    missing: PDDLError | None = None
    extra: PDDLError | None = None
    line_close: tuple[int, int, _Open] | None = None  # last ')' of the previous line
    last = (1, 1)
    for number, line in enumerate(lines, start=1):
        first = True
        closing: tuple[int, int, _Open] | None = None
        for m in _TOKEN.finditer(line):
            tok = m.group()
            column = m.start() + 1
            if tok[0] == ";":
                break
            last = (number, column)
            if first and tok != ")":
                if len(stack) >= 2 and tok == "(":
                    top = stack[-1]
                    if top.line < number and column <= top.column and missing is None:
                        missing = _missing(file, top, number, column)
                if line_close is not None and extra is None and column > line_close[2].column:
                    c_line, c_col, opened = line_close
                    extra = PDDLError(
                        f"one ')' too many? It closes the list opened at line {opened.line}, "
                        f"column {opened.column}, but line {number} goes on indented deeper "
                        "than that list",
                        file=file,
                        line=c_line,
                        column=c_col,
                    )
            first = False
            if tok == "(":
                if result is not None and not stack:
                    raise extra or _after_end(file, closed_at)
                stack.append(_Open([], number, column))
                closing = None
            elif tok == ")":
                if not stack:
                    raise extra or PDDLError(
                        "unexpected ')': every list is already closed",
                        file=file,
                        line=number,
                        column=column,
                    )
                done = stack.pop()
                closing = (number, column, done)
                lst = SList(tuple(done.items), done.line, done.column)
                if stack:
                    stack[-1].items.append(lst)
                else:
                    result = lst
                    closed_at = (number, column)
            else:
                if not stack:
                    if result is not None:
                        raise extra or _after_end(file, closed_at)
                    raise PDDLError(
                        f"expected '(' but found {tok.lower()!r}",
                        file=file,
                        line=number,
                        column=column,
                    )
                stack[-1].items.append(Symbol(tok.lower(), number, column))
                closing = None
        if not first:
            line_close = closing
    if stack:
        if missing is not None:
            raise missing
        top = stack[-1]
        raise PDDLError(
            f"expected ')' to close the list opened at line {top.line}, column {top.column}, "
            "but the file ended",
            file=file,
            line=len(lines),
            column=max(last[1] if last[0] == len(lines) else len(lines[-1]), 1),
        )
    if result is None:
        raise PDDLError(
            "expected '(define ...)' but the file is empty", file=file, line=1, column=1
        )
    return result


def _missing(file: str, top: _Open, line: int, column: int) -> PDDLError:
    return PDDLError(
        f"expected ')' to close the list opened at line {top.line}, column {top.column} "
        "before this list, which starts as far left as that one",
        file=file,
        line=line,
        column=column,
    )


def _after_end(file: str, closed_at: tuple[int, int]) -> PDDLError:
    return PDDLError(
        "one ')' too many? This closes the definition, but more follows after it",
        file=file,
        line=closed_at[0],
        column=closed_at[1],
    )
