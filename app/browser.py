"""Headless Chromium for the browser tests and the page benchmark: Debian's /usr/bin/chromium
(Playwright's own browser download does not work on these machines), with the flags that let
it render WebGL in software without a GPU, a network or a first-run dialog."""

from __future__ import annotations

from pathlib import Path

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--enable-unsafe-swiftshader",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def require_chromium() -> str:
    """The browser's path; a clear error when it is not installed."""
    if not CHROMIUM.exists():
        raise FileNotFoundError(
            f"no Chromium at {CHROMIUM}: install it with `apt-get install -y chromium` "
            "(make test does this)"
        )
    return str(CHROMIUM)
