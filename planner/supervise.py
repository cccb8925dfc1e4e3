"""One process supervisor: every process guided-tamp starts is started here, and none outlives
the process that started it.

Two kinds of children:

- **Python workers** (a dashboard run, a benchmark and its trials, a training job):
  :func:`spawn` starts ``target(*args)`` in a fresh interpreter (the ``spawn`` start method:
  OMPL takes one seed per process, so a run is reproducible from its seed). Before the target
  runs, the child watches its parent (:func:`exit_with_parent`): when the parent is gone, killed
  with ``kill -9`` included, the child stops what it started and exits at once. SIGTERM (a
  parent stopping its child) ends the child the same way, unless the target installs a handler
  of its own (a benchmark worker stops its trials first).
- **Planner binaries** (Fast Downward, K*, SymK): :func:`run_group` runs a command in a process
  group of its own, so that a timeout stops all of it (the driver and the search it starts); the
  groups a process has running are tracked, and killed when the process ends because its parent
  went away or sent SIGTERM.

So ``kill -9`` of ``tamp bench`` (or of the server) ends every trial process, and every planner
binary those trials ran, within moments (``tests/test_supervise.py``).
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import signal
import subprocess
import threading
import time
from collections.abc import Callable
from multiprocessing.connection import wait
from multiprocessing.process import BaseProcess
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

ORPHAN_EXIT_CODE = 3  # the exit code of a child whose parent went away

_CONTEXT = multiprocessing.get_context("spawn")
_groups: set[int] = set()  # process groups (their leaders' pids) this process has running
_groups_lock = threading.Lock()


# --- Python workers ----------------------------------------------------------------------------


def context() -> Any:
    """The multiprocessing context of every child (``spawn``): its pipes and events."""
    return _CONTEXT


def spawn(
    target: Callable[..., Any],
    *args: Any,
    name: str | None = None,
    daemon: bool = True,
    what: str | None = None,
    grace_s: float | None = None,
) -> BaseProcess:
    """Start ``target(*args)`` in a child process that ends with this one; returns it started.

    ``what`` names the child in the log line it writes when its parent is gone; ``grace_s``
    (for a child with children of its own, which it stops on SIGTERM): when the parent is gone
    the child is sent SIGTERM first and ended ``grace_s`` later if it is still there. ``daemon``
    False for a child that starts processes itself (multiprocessing forbids it to a daemon)."""
    process: BaseProcess = _CONTEXT.Process(
        target=_child,
        args=(target, args, what or name or getattr(target, "__qualname__", "a child"), grace_s),
        name=name,
        daemon=daemon,
    )
    process.start()
    return process


def _child(
    target: Callable[..., Any], args: tuple[Any, ...], what: str, grace_s: float | None
) -> None:
    """The entry point of every child: watch the parent, end with it, then run the target."""
    signal.signal(signal.SIGTERM, _terminated)
    exit_with_parent(what, grace_s=grace_s)
    target(*args)


def _terminated(signum: int, frame: object) -> None:
    """SIGTERM's default handler in a child: its planner binaries end with it."""
    kill_groups()
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    os.kill(os.getpid(), signal.SIGTERM)


def exit_with_parent(what: str, *, grace_s: float | None = None) -> threading.Thread | None:
    """End this process as soon as its parent is gone (killed, crashed, exited); None when it
    has no parent it was spawned by. With ``grace_s``, it is first sent SIGTERM, so that it
    can stop what it started (a benchmark's trial processes), and ended only if it is still
    there ``grace_s`` later. Planner binaries it runs (:func:`run_group`) are killed first."""
    parent = multiprocessing.parent_process()
    if parent is None:
        return None
    sentinel = parent.sentinel

    def watch() -> None:
        wait([sentinel])
        log.warning("%s: the process that started it is gone; it stops", what)
        kill_groups()
        if grace_s is not None:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(grace_s)
            kill_groups()
        os._exit(ORPHAN_EXIT_CODE)

    thread = threading.Thread(target=watch, name="watch-parent", daemon=True)
    thread.start()
    return thread


# --- planner binaries --------------------------------------------------------------------------


def run_group(
    cmd: list[str],
    cwd: Path,
    timeout_s: float,
    *,
    stdin: str | None = None,
) -> subprocess.CompletedProcess[str]:
    """Run ``cmd`` in ``cwd`` in a process group of its own, tracked while it runs; its output
    as text. A timeout kills the whole group and raises :class:`subprocess.TimeoutExpired`; so
    does any exception (Ctrl-C included) before it is raised on."""
    proc = subprocess.Popen(
        cmd,
        cwd=cwd,
        stdin=subprocess.PIPE if stdin is not None else subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    with _groups_lock:
        _groups.add(proc.pid)
    try:
        out, err = proc.communicate(input=stdin, timeout=timeout_s)
    except BaseException:
        kill_group(proc)
        raise
    finally:
        with _groups_lock:
            _groups.discard(proc.pid)
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def kill_group(proc: subprocess.Popen[str]) -> None:
    """Kill ``proc``'s process group and reap it."""
    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, signal.SIGKILL)
    proc.communicate()


def kill_groups() -> int:
    """Kill every process group this process has running (:func:`run_group`); how many.

    Besides the tracked ones, any child of this process that leads a session of its own: a
    signal handled between ``Popen`` returning and its group being tracked finds it so. (Never
    takes the lock a signal may have interrupted: the handler runs on the thread that holds it.)
    """
    try:
        tracked = set(_groups)
    except RuntimeError:  # changed by another thread as it was read: the scan finds them
        tracked = set()
    groups = tracked | set(_own_session_children())
    for pgid in groups:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(pgid, signal.SIGKILL)
    return len(groups)


def _own_session_children() -> list[int]:
    """The children of this process that lead a session (and a process group) of their own."""
    me = os.getpid()
    out: list[int] = []
    try:
        entries = os.listdir("/proc")
    except OSError:  # no /proc: the tracked groups are all there is
        return out
    for name in entries:
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat", encoding="ascii", errors="replace") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        ppid, pgrp, session = int(fields[1]), int(fields[2]), int(fields[3])
        if ppid == me and pgrp == session == int(name):
            out.append(int(name))
    return out


def running_groups() -> list[int]:
    """The process groups this process has running (their leaders' pids)."""
    with _groups_lock:
        return sorted(_groups)
