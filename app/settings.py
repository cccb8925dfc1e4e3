"""Dashboard settings: `tamp serve` flags over TAMP_* environment variables over defaults."""

from __future__ import annotations

import ipaddress
import socket
from pathlib import Path
from typing import Annotated, Self

from pydantic import Field, SecretStr, field_validator, model_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

from planner.store import default_db_path

WILDCARD_HOSTS = ("", "0.0.0.0", "::")  # bind every interface
MIN_TOKEN = 16  # characters of TAMP_TOKEN, so it cannot be guessed


def is_loopback(host: str) -> bool:
    """Whether binding ``host`` keeps the server on this machine (every address it names is
    a loopback address)."""
    if host in WILDCARD_HOSTS:
        return False
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        pass
    try:
        infos = socket.getaddrinfo(host, None)
    except OSError:
        return False
    addresses = {info[4][0] for info in infos}
    return bool(addresses) and all(
        ipaddress.ip_address(str(a).split("%")[0]).is_loopback for a in addresses
    )


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="TAMP_", extra="forbid")

    host: str = "127.0.0.1"  # only this machine, unless the user asks otherwise
    port: int = Field(8000, ge=0, le=65535)
    database_url: str = Field(default_factory=lambda: str(default_db_path()))  # path or URL
    # Model files (*.pt) offered by name, besides every domain's shipped model.
    model_dir: Path = Field(default_factory=lambda: default_db_path().parent / "models")
    # Domain folders whose scenes are offered (tamp serve --domain); TAMP_DOMAINS also works.
    extra_domains: list[Path] = Field(default_factory=list)
    reports_dir: Path = Field(default_factory=lambda: default_db_path().parent / "reports")
    viewer: bool = True  # start the viser 3D view
    viewer_port: int = Field(8080, ge=0, le=65535)
    max_running: int = Field(1, ge=1, le=64)  # runs planning at once, each in its own process
    max_queued: int = Field(20, ge=0, le=10_000)  # runs waiting for a slot; more is a 429
    max_benchmarks: int = Field(1, ge=1, le=16)  # benchmarks run from the page at once
    cancel_grace_s: float = Field(10.0, gt=0)  # a cancelled run that has not stopped is killed
    ws_queue_events: int = Field(5000, ge=10)  # a websocket client this far behind resyncs
    # Binding beyond loopback needs a token, or this to say anyone who reaches it may use it.
    allow_remote: bool = False
    # A shared secret (TAMP_TOKEN); when set, every request needs it as a bearer token or cookie.
    token: SecretStr | None = None
    # Host names the server answers besides localhost and the bound address ("*": any).
    allowed_hosts: Annotated[list[str], NoDecode] = Field(default_factory=list)
    # Browser origins allowed besides the dashboard itself ("http://host:port"; "*": any).
    allowed_origins: Annotated[list[str], NoDecode] = Field(default_factory=list)
    max_body_bytes: int = Field(1_000_000, ge=1024, le=100_000_000)  # larger requests get a 413
    # A JSON body of more values than this is a 413 before it is parsed (the largest a route
    # takes is a training job's 10,000 run ids).
    max_json_items: int = Field(12_000, ge=100, le=10_000_000)

    @field_validator("allowed_hosts", "allowed_origins", mode="before")
    @classmethod
    def _comma_separated(cls, value: object) -> object:
        if isinstance(value, str):
            return [part.strip() for part in value.split(",") if part.strip()]
        return value

    @field_validator("token", mode="before")
    @classmethod
    def _empty_is_none(cls, value: object) -> object:
        return None if value == "" else value

    @field_validator("token")
    @classmethod
    def _long_enough(cls, value: SecretStr | None) -> SecretStr | None:
        if value is not None and len(value.get_secret_value()) < MIN_TOKEN:
            raise ValueError(
                f"the token must be at least {MIN_TOKEN} characters (one: python -c "
                "'import secrets; print(secrets.token_urlsafe())')"
            )
        return value

    @model_validator(mode="after")
    def _remote_needs_consent(self) -> Self:
        if not self.loopback and not self.allow_remote and self.token is None:
            raise ValueError(
                f"host {self.host!r} is reachable from other machines: set TAMP_TOKEN (a "
                "secret of 16 or more characters every client must send) or pass "
                "--allow-remote (TAMP_ALLOW_REMOTE=1) to let anyone who reaches it launch runs"
            )
        return self

    @property
    def loopback(self) -> bool:
        return is_loopback(self.host)
