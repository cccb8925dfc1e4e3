"""Starting a real ``tamp serve`` for a test: free ports, the process, waiting for it to answer."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

TAMP = Path(sys.executable).with_name("tamp")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def request(url: str, body: dict[str, Any] | None = None, *, timeout: float = 10) -> Any:
    """GET ``url`` (POST ``body`` as JSON when given) and return the JSON answer."""
    data = None if body is None else json.dumps(body).encode()
    headers = {"Content-Type": "application/json"} if data else {}
    with urllib.request.urlopen(
        urllib.request.Request(url, data=data, headers=headers), timeout=timeout
    ) as response:
        return json.load(response)


@contextmanager
def serving(
    args: Sequence[str], *, cwd: Path, log: Path
) -> Iterator[tuple[str, subprocess.Popen[bytes]]]:
    """``tamp serve --port P ARGS`` until the block ends; yields its URL and process. A server
    that exits or does not answer ``/api/health`` within 90 s fails the test with its log."""
    port = free_port()
    command = [str(TAMP), "serve", "--host", "127.0.0.1", "--port", str(port), *args]
    with log.open("wb") as out:
        process = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT, cwd=cwd)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 90
    try:
        while True:
            if process.poll() is not None:
                pytest.fail(f"tamp serve exited with {process.returncode}:\n{log.read_text()}")
            try:
                request(url + "/api/health", timeout=5)
                break
            except OSError:
                if time.monotonic() > deadline:
                    pytest.fail(f"tamp serve did not answer /api/health:\n{log.read_text()}")
                time.sleep(0.2)
        yield url, process
    finally:
        process.terminate()
        try:
            process.wait(20)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
