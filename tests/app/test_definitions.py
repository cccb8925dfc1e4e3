"""The page names event types and statuses only through /generated/definitions.js, which is made
from the Python definitions: a name the JavaScript uses that Python does not define, or a
literal that would follow Python by hand, fails here."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from planner import figures, status
from planner.events import EVENT_TYPES

STATIC = Path(__file__).resolve().parents[2] / "static"
SCRIPTS = sorted(STATIC.glob("*.js"))
GENERATED = "/generated/definitions.js"


def test_the_definitions_name_every_event_type_and_status() -> None:
    data = figures.definitions()
    assert sorted(data["event"].values()) == sorted(EVENT_TYPES)
    names = set(data["status"].values())
    for group in (
        status.RUN_STATUSES,
        status.LIVE_STATUSES,
        status.SEARCH_STATUSES,
        status.FINISH_STATUSES,
        status.BENCH_STATUSES,
        status.TRAIN_STATUSES,
    ):
        assert set(group) <= names
    assert all(key == value.upper() for key, value in data["event"].items())
    assert set(status.FINAL_STATUSES) == set(status.RUN_STATUSES) - set(status.LIVE_STATUSES)
    js = figures.definitions_js()
    assert "export const EVENT = DEFINITIONS.event;" in js
    assert "export const STATUS = DEFINITIONS.status;" in js


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_the_page_uses_only_the_names_python_defines(script: Path) -> None:
    text = script.read_text()
    data = figures.definitions()
    for const, key in (("EVENT", "event"), ("STATUS", "status")):
        used = set(re.findall(rf"\b{const}\.([A-Z_]+)\b", text))
        unknown = used - set(data[key])
        assert not unknown, f"{script.name} uses {const}.{', '.join(sorted(unknown))}"
        if used:  # imported from the generated module, not defined again here
            imports = re.findall(r'import \{([^}]*)\} from "([^"]+)"', text)
            assert any(
                const in names.replace(" ", "").split(",")
                for names, src in imports
                if src == GENERATED
            ), f"{script.name} uses {const} without importing it from {GENERATED}"


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_the_page_writes_no_event_type_or_compared_status_by_hand(script: Path) -> None:
    text = script.read_text()
    code = "\n".join(line for line in text.splitlines() if not line.lstrip().startswith("//"))
    literals = [t for t in EVENT_TYPES if f'"{t}"' in code or f"'{t}'" in code]
    assert not literals, f"{script.name} spells event types {literals}: use EVENT"
    compared = re.findall(r'\.status\s*[!=]==\s*"(\w+)"', code)
    statuses = [s for s in compared if s in status.all_status_names()]
    assert not statuses, f"{script.name} compares statuses {statuses} by hand: use STATUS"
