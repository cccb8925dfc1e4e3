"""A throwaway PostgreSQL server for the tests and the store benchmark: ``initdb`` in a
temporary folder, ``pg_ctl`` on a free port of 127.0.0.1, stopped and removed at the end.

Debian's ``postgresql`` package provides the binaries (``make test`` installs it). PostgreSQL
refuses to run as root, so as root the server runs as the package's ``postgres`` user.
"""

from __future__ import annotations

import glob
import logging
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

log = logging.getLogger(__name__)

MISSING = (
    "PostgreSQL is not installed (no /usr/lib/postgresql/*/bin/initdb): the store, API and "
    "benchmark tests run on it too. Run `make test`, which installs Debian's postgresql, or "
    "`apt-get install postgresql` as root."
)


class PostgresMissingError(RuntimeError):
    """No PostgreSQL server binaries on this machine."""


def _bin_dir() -> Path:
    found = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"))
    if not found:
        raise PostgresMissingError(MISSING)
    return Path(found[-1]).parent  # the newest version


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class PostgresServer:
    """A running server; :meth:`new_database` gives a fresh database's SQLAlchemy URL."""

    def __init__(self, folder: Path, port: int, bin_dir: Path, user: str | None) -> None:
        self.folder = folder
        self.port = port
        self.bin_dir = bin_dir
        self.user = user  # the system user running it (None: this one)

    def url(self, database: str = "postgres") -> str:
        return f"postgresql+psycopg://postgres@127.0.0.1:{self.port}/{database}"

    def new_database(self, prefix: str = "t") -> str:
        """Create an empty database; its URL."""
        import psycopg

        name = f"{prefix}_{uuid.uuid4().hex[:12]}"
        with psycopg.connect(
            f"host=127.0.0.1 port={self.port} user=postgres dbname=postgres", autocommit=True
        ) as conn:
            conn.execute(f'CREATE DATABASE "{name}"')
        return self.url(name)

    def run(self, *args: str) -> subprocess.CompletedProcess[str]:
        """A server binary (``pg_ctl``, ``initdb``, ...) as the server's user."""
        command = [str(self.bin_dir / args[0]), *args[1:]]
        if self.user is not None:
            command = ["runuser", "-u", self.user, "--", *command]
        return subprocess.run(command, capture_output=True, text=True, check=False, timeout=120)


def _check(result: subprocess.CompletedProcess[str], what: str) -> None:
    if result.returncode != 0:
        raise RuntimeError(f"{what} failed ({result.returncode}): {result.stderr or result.stdout}")


@contextmanager
def postgres_server(*, durable: bool = False) -> Iterator[PostgresServer]:
    """Start a server; stop it and remove its folder afterwards. ``durable`` keeps PostgreSQL's
    default fsync settings (the benchmark's figures); tests run without fsync."""
    bin_dir = _bin_dir()
    user = None
    folder = Path(tempfile.mkdtemp(prefix="tamp-pg-"))
    if os.geteuid() == 0:
        user = "postgres"
        try:
            entry = pwd.getpwnam(user)
        except KeyError:
            raise PostgresMissingError(
                f"{MISSING} (the binaries are there but the package's 'postgres' user is not)"
            ) from None
        os.chown(folder, entry.pw_uid, entry.pw_gid)
    server = PostgresServer(folder, _free_port(), bin_dir, user)
    data = folder / "data"
    try:
        _check(
            server.run(
                "initdb",
                "-D",
                str(data),
                "-U",
                "postgres",
                "--auth=trust",
                "-E",
                "UTF8",
                "--no-sync",
            ),
            "initdb",
        )
        options = [
            "-c listen_addresses=127.0.0.1",
            f"-c port={server.port}",
            f"-c unix_socket_directories={folder}",
            "-c max_connections=200",
        ]
        if not durable:
            options += ["-c fsync=off", "-c synchronous_commit=off", "-c full_page_writes=off"]
        _check(
            server.run(
                "pg_ctl",
                "-D",
                str(data),
                "-l",
                str(folder / "log"),
                "-w",
                "-o",
                " ".join(options),
                "start",
            ),
            "pg_ctl start",
        )
        log.info("PostgreSQL %s on 127.0.0.1:%d in %s", bin_dir.parent.name, server.port, folder)
        yield server
    finally:
        if (data / "postmaster.pid").exists():
            stopped = server.run("pg_ctl", "-D", str(data), "-m", "immediate", "-w", "stop")
            if stopped.returncode != 0:
                log.warning("pg_ctl stop: %s", stopped.stderr)
        shutil.rmtree(folder, ignore_errors=True)
