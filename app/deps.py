"""What every router needs: the dashboard of the app, and the errors it answers with."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import Depends, HTTPException, Path, Request

from app.schemas import ErrorOut, ValidationErrorOut
from app.services import Dashboard

ERROR: dict[str, Any] = {"model": ErrorOut}
# Answers any route may give, before it runs (app/security.py) or on a bad field.
COMMON_RESPONSES: dict[int | str, dict[str, Any]] = {
    400: {**ERROR, "description": "the Host header names another server"},
    401: {**ERROR, "description": "the server's token (TAMP_TOKEN) is missing or wrong"},
    403: {**ERROR, "description": "a browser page of another origin"},
    413: {**ERROR, "description": "the request body is larger than the server takes"},
    422: {"model": ValidationErrorOut, "description": "a bad field, named"},
}

RunId = Annotated[str, Path(min_length=1, max_length=64, description="a run id")]


def get_dashboard(request: Request) -> Dashboard:
    dash: Dashboard = request.app.state.dashboard
    return dash


Dash = Annotated[Dashboard, Depends(get_dashboard)]


def bad_field(field: str | list[str | int], message: str, where: str = "body") -> HTTPException:
    """A 422 naming one field (``["runs", 3]``: the fourth run of the body)."""
    loc = [where, *(field if isinstance(field, list) else [field])]
    return HTTPException(422, detail=[{"loc": loc, "msg": message, "type": "value_error"}])


def not_found(message: str) -> HTTPException:
    return HTTPException(404, detail=message)
