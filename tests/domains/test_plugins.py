"""Domains as plug-ins: found by folder path, through installed entry points and through the
folders in TAMP_DOMAINS, with an error naming the folder, file or entry point for every way one
can be broken; a broken installed domain is reported (logged and listed) and skipped, never
fatal."""

from __future__ import annotations

import logging
import shutil
import textwrap
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from planner.cli import main
from planner.domains import (
    DomainLoadError,
    domain_infos,
    known_domains,
    load_domain,
    problem_for_scene,
    registry,
)
from planner.scene import SceneError
from planner.values import ValueCodec, ValueDecodeError, ValueType, ValueTypeError

ROOT = Path(__file__).resolve().parents[2]
TUTORIAL = ROOT / "examples" / "tabletop2d"


def _copy(tmp_path: Path, name: str = "mine") -> Path:
    folder = tmp_path / name
    shutil.copytree(TUTORIAL, folder, ignore=shutil.ignore_patterns("__pycache__"))
    return folder


def test_a_copied_folder_loads_by_path_and_its_scenes_name_it_relatively(tmp_path: Path) -> None:
    folder = _copy(tmp_path)
    loaded = load_domain(folder)
    assert loaded.name == "tabletop2d" and loaded.directory == folder.resolve()
    assert loaded.source == f"folder {folder.resolve()}"
    scene = folder / "scenes" / "tabletop-2.json"
    found, problem = problem_for_scene(str(scene), seed=3)
    assert found.directory == folder.resolve()  # "domain": ".." from the scene's folder
    assert {o.name for o in problem.objects} >= {"b1", "b2", "start", "goal"}
    by_name, _ = problem_for_scene("tabletop-2", domain=str(folder))  # a name in its scenes/
    assert by_name.directory == folder.resolve()


def test_a_folder_whose_pddl_files_live_elsewhere_plans_and_validates(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``DomainSpec.directory`` names where the PDDL files are (a PDDLStream example's own
    folder, which holds an ``__init__.py`` of its own): the folder with domain.py loads, its
    scenes are its own, and a run and ``tamp validate`` load it again from that folder."""
    folder = _copy(tmp_path)
    elsewhere = tmp_path / "pddlstream" / "examples" / "tabletop"
    elsewhere.mkdir(parents=True)
    (elsewhere / "__init__.py").write_text("")  # as in PDDLStream's examples: no domain here
    for name in ("domain.pddl", "stream.pddl"):
        (folder / name).rename(elsewhere / name)
    with (folder / "domain.py").open("a") as module:
        module.write(
            "\nimport dataclasses as _dc\nfrom pathlib import Path as _Path\n\n"
            "DOMAIN = _dc.replace(DOMAIN, directory=_Path('../pddlstream/examples/tabletop'))\n"
        )
    loaded = load_domain(folder)
    assert loaded.directory == elsewhere.resolve() and loaded.home == folder.resolve()
    assert loaded.scenes_dir == folder.resolve() / "scenes"
    out = tmp_path / "plan.json"
    scene = str(folder / "scenes" / "tabletop-2.json")
    args = ["plan", "--scene", scene, "--planner", "baseline", "--seed", "1", "--no-record"]
    assert main([*args, "--out", str(out)]) == 0, capsys.readouterr().out
    assert main(["validate", str(out)]) == 0
    assert "valid" in capsys.readouterr().out
    again = tmp_path / "again"
    shutil.copytree(folder, again, ignore=shutil.ignore_patterns("__pycache__"))
    (elsewhere / "stream.pddl").unlink()
    with pytest.raises(DomainLoadError, match=r"tabletop \(DomainSpec\.directory\) has no"):
        load_domain(again)


@pytest.mark.parametrize(
    ("breakage", "says"),
    [
        ("no-stream", r"mine has no stream\.pddl"),
        ("no-module", r"mine: no domain\.py or __init__\.py"),
        ("no-object", r"domain\.py: no domain object: export DOMAIN = DomainSpec"),
        ("import-error", r"domain\.py:2: cannot import the domain module: ModuleNotFoundError"),
        ("not-a-spec", r"DOMAIN is a str, expected a DomainSpec"),
        ("bad-value-type", r"domain 'broken': value_types\[0\] is a dict, expected a ValueType"),
    ],
)
def test_a_broken_folder_names_what_is_missing(tmp_path: Path, breakage: str, says: str) -> None:
    folder = _copy(tmp_path)
    module = folder / "domain.py"
    if breakage == "no-stream":
        (folder / "stream.pddl").unlink()
    elif breakage == "no-module":
        module.unlink()
        (folder / "__init__.py").unlink()
    elif breakage == "no-object":
        module.write_text('"""Nothing exported."""\nVALUE = 3\n')
    elif breakage == "import-error":
        module.write_text('"""A typo."""\nfrom .samplerz import bindings\n')
    elif breakage == "not-a-spec":
        module.write_text('DOMAIN = "tabletop2d"\n')
    else:
        module.write_text(
            "from planner.domains import DomainSpec\n"
            "DOMAIN = DomainSpec('broken', lambda s, d, k: None, None, value_types=({},))\n"
        )
    with pytest.raises(DomainLoadError, match=says):
        load_domain(folder)


def test_a_scene_naming_a_domain_that_cannot_load_names_the_scene_and_field(
    tmp_path: Path,
) -> None:
    scene = tmp_path / "lost.json"
    scene.write_text('{"name": "lost", "domain": "./nowhere", "goal": []}')
    with pytest.raises(SceneError, match=r"lost\.json: domain: .*nowhere: no such domain folder"):
        problem_for_scene(str(scene))
    scene.write_text('{"name": "lost", "domain": "atlantis", "goal": []}')
    with pytest.raises(SceneError, match=r"unknown domain 'atlantis' \(known: kitchen, line"):
        problem_for_scene(str(scene))
    with pytest.raises(SceneError, match="scene is for 'line', not 'kitchen'"):
        problem_for_scene("line-2", domain="kitchen")


def test_value_types_without_a_codec_or_an_encoder_are_refused() -> None:
    def fields(v: object) -> dict[str, object]:
        return {}

    with pytest.raises(ValueTypeError, match="'pose2' has no codec: decode must be a function"):
        ValueType("pose2", tuple, fields, None, lambda d: [0.0], 1)  # type: ignore[arg-type]
    with pytest.raises(ValueTypeError, match="'pose2' has no feature encoder"):
        ValueType("pose2", tuple, fields, lambda d: d, None, 1)  # type: ignore[arg-type]
    with pytest.raises(ValueTypeError, match="reserved"):
        ValueType("number", float, fields, lambda d: d, lambda d: [0.0], 1)


def test_values_round_trip_and_unknown_ones_are_stored_as_text(
    caplog: pytest.LogCaptureFixture,
) -> None:
    loaded = load_domain(TUTORIAL)
    from_module = loaded.spec.value_types[0]
    pose = from_module.decode({"type": "pose", "xy": [0.25, -0.5]})
    assert loaded.decode(loaded.encode(pose), "p") == pose
    codec = ValueCodec()
    assert codec.encode(np.array([1.0, 2.0])) == [1.0, 2.0]  # numpy: a vector
    assert codec.kind_of([1.0, 2.0]) == "vector" and codec.kind_of(2.5) == "number"

    class Odd:
        pass

    stored = codec.encode(Odd())
    assert stored["type"] == "opaque" and "Odd" in stored["python_type"]
    assert "have no value type" in caplog.text
    with pytest.raises(ValueDecodeError, match="cannot be read back"):
        codec.decode(stored, "values.opt-x1")
    with pytest.raises(
        ValueDecodeError, match=r"values\.q\.type: unknown value type 'pose' \(known: none\)"
    ):
        codec.decode({"type": "pose"}, "values.q")


def test_a_folder_in_tamp_domains_is_found_by_its_domain_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = _copy(tmp_path)  # the folder is "mine"; its domain is called tabletop2d
    monkeypatch.delenv("TAMP_DOMAINS", raising=False)
    monkeypatch.setattr(registry, "_extra_folders", [])  # none added by earlier servers
    assert "tabletop2d" not in known_domains()
    monkeypatch.setenv("TAMP_DOMAINS", str(folder))
    loaded = load_domain("tabletop2d")
    assert loaded.directory == folder.resolve() and loaded.source == f"folder {folder.resolve()}"
    found, problem = problem_for_scene("tabletop-3")  # a scene of its scenes/, by name
    assert found.directory == folder.resolve() and problem.domain_name == "tabletop2d"
    assert main(["domains"]) == 0
    listed = capsys.readouterr().out.splitlines()
    at = next(i for i, line in enumerate(listed) if line.startswith("tabletop2d "))
    assert f"folder {folder.resolve()}" in listed[at] and str(folder.resolve()) in listed[at + 1]


# --- installed domains (entry points) --------------------------------------------------------


@pytest.fixture()
def installed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A site folder on sys.path with two installed distributions: the tutorial as a package
    (entry point ``tabletop2d``) and a package whose domain module fails to import."""
    site = tmp_path / "site"
    shutil.copytree(TUTORIAL, site / "tabletop_pkg", ignore=shutil.ignore_patterns("__pycache__"))
    (site / "broken_pkg").mkdir()
    (site / "broken_pkg" / "__init__.py").write_text("import numpyy  # a typo\n")
    for dist, entry in (
        ("tabletop_pkg", "tabletop2d = tabletop_pkg.domain:DOMAIN"),
        ("broken_pkg", "broken = broken_pkg:DOMAIN"),
    ):
        info = site / f"{dist}-0.1.dist-info"
        info.mkdir()
        (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 0.1\n")
        (info / "entry_points.txt").write_text(
            textwrap.dedent(f"""\
                [guided_tamp.domains]
                {entry}
                """)
        )
    monkeypatch.syspath_prepend(str(site))
    yield site


def test_installed_domains_register_by_entry_point(installed: Path) -> None:
    assert {"kitchen", "line", "tabletop2d", "broken"} <= set(known_domains())
    loaded = load_domain("tabletop2d")
    assert loaded.source.startswith("entry point tabletop2d")
    _, problem = problem_for_scene("tabletop-3")  # found in the installed domain's scenes/
    assert problem.domain_name == "tabletop2d"
    with pytest.raises(DomainLoadError, match=r"entry point 'broken' .*ModuleNotFoundError"):
        load_domain("broken")
    infos = {i.name: i for i in domain_infos()}
    assert infos["broken"].error is not None and "numpyy" in infos["broken"].error
    assert infos["tabletop2d"].error is None and infos["kitchen"].error is None


def test_a_broken_installed_domain_never_stops_the_server(
    installed: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    settings = Settings(
        database_url=str(tmp_path / "runs.db"), viewer=False, reports_dir=tmp_path / "reports"
    )
    with TestClient(create_app(settings), base_url="http://127.0.0.1:8000") as client:
        domains = {d["name"]: d for d in client.get("/api/domains").json()}
        assert domains["broken"]["loaded"] is False
        assert "numpyy" in domains["broken"]["error"]
        # The server's log says which entry point was skipped and why, as a warning.
        (skipped,) = {
            r.getMessage()
            for r in caplog.records
            if r.levelno == logging.WARNING and "is skipped" in r.getMessage()
        }
        assert "entry point broken = broken_pkg:DOMAIN" in skipped
        assert "ModuleNotFoundError: No module named 'numpyy'" in skipped
        assert domains["tabletop2d"]["loaded"] and domains["tabletop2d"]["scenes"] == 5
        scenes = {s["name"]: s["domain"] for s in client.get("/api/scenes").json()}
        assert scenes["kitchen-1"] == "kitchen" and scenes["tabletop-1"] == "tabletop2d"
        assert client.get("/api/health").json()["status"] == "ok"
