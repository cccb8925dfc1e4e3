"""Typed errors of the problem language; every one says where and what was expected."""

from __future__ import annotations


class PDDLError(Exception):
    """A problem file (domain, problem or stream.pddl) is malformed or unsupported.

    The message always starts with ``file:line:column`` so editors can jump to it.
    """

    def __init__(self, message: str, *, file: str, line: int, column: int) -> None:
        self.file = file
        self.line = line
        self.column = column
        self.reason = message
        super().__init__(f"{file}:{line}:{column}: {message}")


class UnsupportedPDDLError(PDDLError):
    """A construct that is valid PDDL(Stream) but that this planner does not support."""
