"""S-expression reader that keeps where every token is (for error messages).

Reading is linear in the file's size: each line is split into tokens by string methods (a
comment cut off at ``;``, parentheses spaced apart), and a node keeps the index of its token,
turned into line and column only for a message. When the parentheses do not balance, the file is
read again, line by line, to guess from the indentation where one is missing or extra: a
list that starts as far left as an open list that began on an earlier line was probably
meant to follow it, not sit inside it; a line indented deeper than the list its previous
line closed probably follows a ``)`` that closed that list too early.
"""

from __future__ import annotations

import bisect
import re
from pathlib import Path
from typing import NamedTuple

from planner.pddl.errors import PDDLError

BOM = "\ufeff"
_TOKEN = re.compile(r"[()]|[^\s()]+")  # a token of a line without its comment
# Control characters other than whitespace, and a byte-order mark past the start.
_BAD_CHAR = re.compile("[\x00-\x08\x0e-\x1f\x7f\ufeff]")
_CHAR_NAMES = {"\x00": "NUL", "\x7f": "DEL", BOM: "a byte-order mark (U+FEFF)"}


class Symbol(NamedTuple):
    """One token; PDDL is case-insensitive, so ``text`` is lower-cased. ``token`` is its
    index among the tokens of its :class:`Source`. (Named tuples, not dataclasses: a 5 MB
    file has a million of them.)"""

    text: str
    token: int


class SList(NamedTuple):
    """A parenthesised list, the index of its opening parenthesis and its line."""

    items: tuple[Symbol | SList, ...]
    token: int
    line: int


Node = Symbol | SList


class Source:
    """The text a tree was read from: turns token indices into lines and columns (both
    from 1)."""

    def __init__(self, file: str, text: str) -> None:
        self.file = file
        self.text = text
        self._lines = text.split("\n")
        self._firsts: list[int] | None = None  # index of each line's first token

    def position(self, token: int) -> tuple[int, int]:
        if self._firsts is None:
            firsts: list[int] = []
            count = 0
            for text in self._lines:
                firsts.append(count)
                count += len(_tokens(text))
            self._firsts = firsts
        number = bisect.bisect_right(self._firsts, token)
        k = token - self._firsts[number - 1]
        line = self._lines[number - 1]
        for n, m in enumerate(_TOKEN.finditer(_code(line))):
            if n == k:
                return number, m.start() + 1
        return number, len(line) + 1

    def error(self, token: int, message: str) -> PDDLError:
        line, column = self.position(token)
        return PDDLError(message, file=self.file, line=line, column=column)


def _code(line: str) -> str:
    """A line without its comment."""
    cut = line.find(";")
    return line if cut < 0 else line[:cut]


def _tokens(line: str) -> list[str]:
    return _code(line).replace("(", " ( ").replace(")", " ) ").split()


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


def _check_characters(text: str, *, file: str) -> None:
    """Refuse control characters and stray byte-order marks outside comments."""
    bad = _BAD_CHAR.search(text)
    while bad is not None:
        line_start = text.rfind("\n", 0, bad.start()) + 1
        comment = text.find(";", line_start, bad.start())
        if comment < 0:
            line = text.count("\n", 0, bad.start()) + 1
            raise PDDLError(
                f"unexpected {_char_name(bad.group())} (names and keywords are printable text)",
                file=file,
                line=line,
                column=bad.start() - line_start + 1,
            )
        end = text.find("\n", bad.start())
        bad = _BAD_CHAR.search(text, end) if end >= 0 else None


def read_sexpr(text: str, *, file: str) -> tuple[SList, Source]:
    """Read exactly one top-level list from ``text`` (comments start with ``;``), and the
    :class:`Source` that places its nodes."""
    if text.startswith(BOM):
        text = text[1:]
    _check_characters(text, file=file)
    source = Source(file, text)
    ascii_text = text.isascii()  # then lower-case once; else name by name (lengths change)
    stack: list[list[Node]] = []
    opened: list[tuple[int, int]] = []
    result: SList | None = None
    new = tuple.__new__  # what the named tuples' own constructors call, without the wrapper
    add = None  # append of the innermost open list
    i = -1
    lines = (text.lower() if ascii_text else text).split("\n")
    for number, line in enumerate(lines, start=1):
        if ";" in line:
            line = line[: line.index(";")]
        for tok in line.replace("(", " ( ").replace(")", " ) ").split():
            i += 1
            if tok == "(":
                if result is not None and not stack:
                    raise _diagnose(text, file=file)
                items: list[Node] = []
                stack.append(items)
                add = items.append
                opened.append((i, number))
            elif tok == ")":
                if not stack:
                    raise _diagnose(text, file=file)
                lst = new(SList, (tuple(stack.pop()), *opened.pop()))
                if stack:
                    add = stack[-1].append
                    add(lst)
                else:
                    result = lst
                    add = None
            else:
                if add is None:
                    raise _diagnose(text, file=file)
                add(new(Symbol, (tok if ascii_text else tok.lower(), i)))
    if not stack and result is not None:
        return result, source
    raise _diagnose(text, file=file)


def _diagnose(text: str, *, file: str) -> PDDLError:
    """The error of a file whose parentheses do not balance (see the module docstring)."""
    lines = text.split("\n")
    depth: list[tuple[int, int]] = []  # (line, column) of each open list
    result = False
    closed_at = (0, 0)
    missing: PDDLError | None = None
    extra: PDDLError | None = None
    # the ')' ending the previous line: its line and column, and where its '(' is
    line_close: tuple[int, int, int, int] | None = None
    for number, line in enumerate(lines, start=1):
        first = True
        closing: tuple[int, int, int, int] | None = None
        for m in _TOKEN.finditer(_code(line)):
            tok = m.group()
            column = m.start() + 1
            if first:
                first = False
                if tok != ")":
                    if tok == "(" and missing is None and len(depth) >= 2:
                        top = depth[-1]
                        if top[0] < number and column <= top[1]:
                            missing = _missing(file, top, number, column)
                    if line_close and extra is None and column > line_close[3]:
                        extra = _extra(file, line_close, number)
            if tok == "(":
                if result and not depth:
                    return extra or _after_end(file, closed_at)
                depth.append((number, column))
                closing = None
            elif tok == ")":
                if not depth:
                    return extra or PDDLError(
                        "unexpected ')': every list is already closed",
                        file=file,
                        line=number,
                        column=column,
                    )
                o_line, o_col = depth.pop()
                closing = (number, column, o_line, o_col)
                if not depth:
                    result = True
                    closed_at = (number, column)
            else:
                if not depth:
                    if result:
                        return extra or _after_end(file, closed_at)
                    return PDDLError(
                        f"expected '(' but found {tok.lower()!r}",
                        file=file,
                        line=number,
                        column=column,
                    )
                closing = None
        if not first:
            line_close = closing
    if depth:
        if missing is not None:
            return missing
        o_line, o_col = depth[-1]
        return PDDLError(
            f"expected ')' to close the list opened at line {o_line}, column {o_col}, "
            "but the file ended",
            file=file,
            line=len(lines),
            column=max(len(lines[-1].rstrip()), 1),
        )
    return PDDLError("expected '(define ...)' but the file is empty", file=file, line=1, column=1)


def _missing(file: str, top: tuple[int, int], line: int, column: int) -> PDDLError:
    return PDDLError(
        f"expected ')' to close the list opened at line {top[0]}, column {top[1]} "
        "before this list, which starts as far left as that one",
        file=file,
        line=line,
        column=column,
    )


def _extra(file: str, close: tuple[int, int, int, int], line: int) -> PDDLError:
    c_line, c_col, o_line, o_col = close
    return PDDLError(
        f"one ')' too many? It closes the list opened at line {o_line}, column {o_col}, but "
        f"line {line} goes on indented deeper than that list",
        file=file,
        line=c_line,
        column=c_col,
    )


def _after_end(file: str, closed_at: tuple[int, int]) -> PDDLError:
    return PDDLError(
        "one ')' too many? This closes the definition, but more follows after it",
        file=file,
        line=closed_at[0],
        column=closed_at[1],
    )
