"""Which process owns a live run, and whether that process is still there.

A run that is ``queued`` or ``running`` records its owner as ``host:pid:start`` (``start`` is
the process's start time in clock ticks since boot, from ``/proc``, so a recycled pid is not
mistaken for the owner). A starting dashboard finishes only the live runs whose owner is gone,
so a ``tamp plan`` recording into the same database at that moment is left alone.
"""

from __future__ import annotations

import os
import socket
from pathlib import Path

_PROC = Path("/proc")


def _stat(pid: int) -> tuple[str, str] | None:
    """(state, start time) of process ``pid`` from ``/proc/PID/stat``; None if it is gone."""
    try:
        text = (_PROC / str(pid) / "stat").read_text()
    except (FileNotFoundError, ProcessLookupError, PermissionError):
        return None
    fields = text.rpartition(")")[2].split()  # the command name may hold spaces and ")"
    return fields[0], fields[19]  # fields 3 (state) and 22 (starttime) of proc(5)


def process_token(pid: int | None = None) -> str:
    """``host:pid:start`` of process ``pid`` (this one by default)."""
    pid = os.getpid() if pid is None else pid
    stat = _stat(pid) if _PROC.is_dir() else None
    return f"{socket.gethostname()}:{pid}:{stat[1] if stat else ''}"


def is_alive(token: str | None) -> bool:
    """Whether the owner ``token`` names still runs. A token from another host cannot be
    checked and counts as alive; no token (a run stored before owners were recorded) and a
    malformed one count as gone. A zombie (exited, not yet reaped) is gone."""
    if not token:
        return False
    host, _, rest = token.partition(":")
    pid_text, _, start = rest.partition(":")
    if host != socket.gethostname():
        return True
    try:
        pid = int(pid_text)
    except ValueError:
        return False
    if pid <= 0:
        return False
    if _PROC.is_dir():
        stat = _stat(pid)
        if stat is None or stat[0] in ("Z", "X"):
            return False
        return not start or stat[1] == start
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
