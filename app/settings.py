"""Dashboard settings: `tamp serve` flags over TAMP_* environment variables over defaults."""

from __future__ import annotations

from pathlib import Path

from pydantic import Field
from pydantic_settings import BaseSettings, SettingsConfigDict

from planner.store import default_db_path


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
    cancel_grace_s: float = Field(10.0, gt=0)  # a cancelled run that has not stopped is killed
    ws_queue_events: int = Field(5000, ge=10)  # a websocket client this far behind resyncs
