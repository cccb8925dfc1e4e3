"""Finding domains and scenes: installed packages (an entry-point group), folders given by path,
and the scene files of each.

A domain is found by

- **name**, among the installed domains: every entry point of the group
  :data:`ENTRY_POINT_GROUP` (``guided_tamp.domains``) names a module attribute holding a
  :class:`~planner.domains.spec.DomainSpec` (the kitchen and line domains register so, in
  ``pyproject.toml``), and the folders listed in ``TAMP_DOMAINS`` (separated by ``:``);
- **folder path**: ``tamp ... --domain PATH``, or a scene file's ``"domain"`` when it is a
  path (resolved against the scene file's folder). The folder holds ``domain.pddl``,
  ``stream.pddl`` and ``domain.py`` (or ``__init__.py``) exporting ``DOMAIN``.

Scenes are found by path (``.json``) or by name: in ``scenes/`` of the project (the shipped
scenes), then in the ``scenes/`` folder of the given domain or of every domain found.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import logging
import os
import re
import sys
import threading
import traceback
from collections.abc import Iterable
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from types import ModuleType

from planner.domains.spec import DomainSpec, LoadedDomain
from planner.pddl.parser import load_pddlstream
from planner.pddl.structs import Problem
from planner.scene import SCENES_DIR, Scene, SceneError, known_scenes, load_scene
from planner.values import ValueCodec, ValueTypeError, check_value_types

log = logging.getLogger(__name__)

ENTRY_POINT_GROUP = "guided_tamp.domains"  # installed domains register here
DOMAINS_ENV = "TAMP_DOMAINS"  # extra domain folders, separated by os.pathsep
DOMAIN_ATTR = "DOMAIN"  # what a domain module exports
MODULE_FILES = ("domain.py", "__init__.py")  # where a folder's domain object is looked for
PDDL_FILES = ("domain.pddl", "stream.pddl")


class DomainLoadError(ValueError):
    """A domain cannot be found or loaded; the message names the folder, file or entry point
    and what is missing."""


@dataclass(frozen=True)
class DomainInfo:
    """A domain found (or that failed to load), for listings such as ``GET /api/domains``."""

    name: str
    source: str  # "entry point ..." or "folder ..."
    directory: str | None
    error: str | None  # why it did not load; None when it did
    description: str = ""


_lock = threading.RLock()
_cache: dict[tuple[Path, tuple[float, ...], Path | None], LoadedDomain] = {}
_warned: set[Path] = set()  # folders whose inferred declarations were logged
_extra_folders: list[Path] = []  # added in this process (tamp serve --domain PATH)


# --- entry points and folders ------------------------------------------------------------------


def add_domain_folder(path: str | Path) -> LoadedDomain:
    """Load the domain in ``path`` and make it (and its scenes) findable by name in this
    process (``tamp serve --domain PATH``)."""
    loaded = load_domain_folder(path)
    with _lock:
        if loaded.home not in _extra_folders:
            _extra_folders.append(loaded.home)
    return loaded


def _env_folders() -> list[Path]:
    raw = os.environ.get(DOMAINS_ENV, "")
    return [Path(p).expanduser() for p in raw.split(os.pathsep) if p.strip()]


def _folders() -> list[Path]:
    with _lock:
        extra = list(_extra_folders)
    out: list[Path] = []
    for p in [*_env_folders(), *extra]:
        resolved = p.resolve()
        if resolved not in out:
            out.append(resolved)
    return out


def _entry_points() -> list[metadata.EntryPoint]:
    return sorted(metadata.entry_points(group=ENTRY_POINT_GROUP), key=lambda ep: ep.name)


def _spec_from_entry_point(ep: metadata.EntryPoint) -> tuple[DomainSpec, Path]:
    where = f"entry point {ep.name!r} ({ep.value}) of group {ENTRY_POINT_GROUP}"
    try:
        obj = ep.load()
    except Exception as exc:
        raise DomainLoadError(f"{where}: cannot import it: {type(exc).__name__}: {exc}") from exc
    if isinstance(obj, ModuleType):
        obj = _domain_object(obj, where)
    if not isinstance(obj, DomainSpec):
        raise DomainLoadError(
            f"{where}: names a {type(obj).__name__}, expected a DomainSpec (the domain object)"
        )
    directory = obj.directory
    if directory is None:
        module = sys.modules.get(ep.module)
        file = getattr(module, "__file__", None)
        if file is None:
            raise DomainLoadError(f"{where}: its module has no folder; set DomainSpec.directory")
        directory = Path(file).resolve().parent
    return obj, directory


def _domain_object(module: ModuleType, where: str) -> DomainSpec:
    obj = getattr(module, DOMAIN_ATTR, None)
    if isinstance(obj, DomainSpec):
        return obj
    found = [v for v in vars(module).values() if isinstance(v, DomainSpec)]
    if len(found) == 1:
        return found[0]
    if obj is not None:
        raise DomainLoadError(
            f"{where}: {DOMAIN_ATTR} is a {type(obj).__name__}, expected a DomainSpec"
        )
    if not found:
        raise DomainLoadError(
            f"{where}: no domain object: export {DOMAIN_ATTR} = DomainSpec(...) (docs/domains.md)"
        )
    raise DomainLoadError(
        f"{where}: {len(found)} DomainSpec objects and no {DOMAIN_ATTR}; name the one to use "
        f"{DOMAIN_ATTR}"
    )


def _import_error(exc: BaseException, folder: Path, file: Path) -> DomainLoadError:
    """Where an import inside the domain folder went wrong (file:line of the deepest frame in
    the folder)."""
    line = ""
    for frame in reversed(traceback.extract_tb(exc.__traceback__)):
        if frame.filename and Path(frame.filename).resolve().is_relative_to(folder):
            line = f"{frame.filename}:{frame.lineno}: "
            break
    if isinstance(exc, SyntaxError) and exc.filename:
        line = f"{exc.filename}:{exc.lineno}: "
    return DomainLoadError(
        f"{line or f'{file}: '}cannot import the domain module: {type(exc).__name__}: {exc}"
    )


def _import_folder(folder: Path) -> ModuleType:
    """Import a domain folder as a package of its own (so its modules import each other with
    ``from . import samplers``) and return the module holding the domain object."""
    files = [folder / f for f in MODULE_FILES if (folder / f).is_file()]
    if not files:
        raise DomainLoadError(
            f"{folder}: no {' or '.join(MODULE_FILES)} (the Python module that exports "
            f"{DOMAIN_ATTR} = DomainSpec(...))"
        )
    digest = hashlib.sha1(str(folder).encode()).hexdigest()[:10]
    package = f"tamp_domain_{re.sub(r'[^0-9A-Za-z_]', '_', folder.name)}_{digest}"
    init = folder / "__init__.py"
    if package not in sys.modules:
        if init.is_file():
            spec = importlib.util.spec_from_file_location(
                package, init, submodule_search_locations=[str(folder)]
            )
        else:
            spec = importlib.util.spec_from_loader(package, loader=None, is_package=True)
        if spec is None:
            raise DomainLoadError(f"{folder}: cannot be imported as a Python package")
        module = importlib.util.module_from_spec(spec)
        if not init.is_file():
            module.__path__ = [str(folder)]
        sys.modules[package] = module
        try:
            if spec.loader is not None:
                spec.loader.exec_module(module)
        except Exception as exc:
            del sys.modules[package]
            raise _import_error(exc, folder, init) from exc
    if (folder / "domain.py").is_file():
        try:
            return importlib.import_module(f"{package}.domain")
        except Exception as exc:
            sys.modules.pop(f"{package}.domain", None)
            raise _import_error(exc, folder, folder / "domain.py") from exc
    return sys.modules[package]


def _load(
    spec: DomainSpec, directory: Path, source: str, folder: Path | None = None
) -> LoadedDomain:
    directory = directory.resolve()
    if not directory.is_dir():
        raise DomainLoadError(
            f"domain {spec.name!r} ({source}): DomainSpec.directory {directory} is not a folder"
        )
    missing = [f for f in PDDL_FILES if not (directory / f).is_file()]
    if missing:
        where = "" if spec.directory is None else " (DomainSpec.directory)"
        raise DomainLoadError(
            f"domain {spec.name!r} ({source}): {directory}{where} has no {' and no '.join(missing)}"
        )
    stamps = tuple((directory / f).stat().st_mtime for f in PDDL_FILES)
    key = (directory, stamps, folder)
    with _lock:
        cached = _cache.get(key)
        if cached is not None and cached.spec is spec:
            return cached
    domain, streams = load_pddlstream(
        directory / "domain.pddl", directory / "stream.pddl", strict=spec.strict
    )
    inferred = len(domain.inferred) + len(streams.inferred)
    if inferred and directory not in _warned:  # once per folder and process, not per trial
        _warned.add(directory)
        log.warning(
            "domain %s: %d declaration%s inferred from use in %s (PDDLStream's leniency); "
            "`tamp check %s` lists them",
            spec.name,
            inferred,
            "" if inferred == 1 else "s",
            directory,
            directory,
        )
    known = {s.name for s in streams.streams}
    unknown = sorted(set(spec.unread) - known)
    if unknown:
        raise DomainLoadError(
            f"domain {spec.name!r}: unread names streams not in {streams.source}: "
            f"{', '.join(unknown)}"
        )
    unknown = sorted(set(spec.input_kinds) - known)
    if unknown:
        raise DomainLoadError(
            f"domain {spec.name!r}: input_kinds names streams not in {streams.source}: "
            f"{', '.join(unknown)}"
        )
    try:
        types = check_value_types(spec.value_types, f"domain {spec.name!r}")
    except ValueTypeError as exc:
        raise DomainLoadError(f"{exc} ({source})") from exc
    loaded = LoadedDomain(
        spec, domain, streams, directory, source, ValueCodec(types), folder=folder
    )
    with _lock:
        _cache[key] = loaded
    return loaded


def load_domain_folder(path: str | Path) -> LoadedDomain:
    """The domain in folder ``path``; :class:`DomainLoadError` names what is missing."""
    folder = Path(path).expanduser()
    if not folder.exists():
        raise DomainLoadError(f"{folder}: no such domain folder")
    if not folder.is_dir():
        raise DomainLoadError(
            f"{folder}: not a folder (a domain is a folder with domain.pddl, "
            "stream.pddl and domain.py)"
        )
    folder = folder.resolve()
    if not any((folder / f).is_file() for f in MODULE_FILES):
        missing = [f for f in PDDL_FILES if not (folder / f).is_file()]
        if missing:  # neither the files nor a module that could say where they are
            raise DomainLoadError(
                f"{folder}: no {' and no '.join(missing)} in the domain folder, and no "
                f"{' or '.join(MODULE_FILES)} (a module whose DomainSpec.directory names "
                "where they are)"
            )
    module = _import_folder(folder)
    spec = _domain_object(module, f"{module.__file__ or folder}")
    directory = folder
    if spec.directory is not None:  # relative: against the domain folder
        directory = (folder / spec.directory).resolve()
    return _load(spec, directory, f"folder {folder}", folder)


def _installed() -> dict[str, tuple[metadata.EntryPoint | Path, str]]:
    """Name -> (entry point or folder, how it was found); a folder goes by its domain's name
    (by the folder's name when it does not load)."""
    found: dict[str, tuple[metadata.EntryPoint | Path, str]] = {}
    for ep in _entry_points():
        found.setdefault(ep.name, (ep, f"entry point {ep.name} = {ep.value}"))
    for folder in _folders():
        try:
            name = load_domain_folder(folder).name
        except Exception:  # reported when it is loaded by name or listed
            name = folder.name
        found.setdefault(name, (folder, f"folder {folder}"))
    return found


def _load_installed(name: str, ref: metadata.EntryPoint | Path, source: str) -> LoadedDomain:
    if isinstance(ref, Path):
        return load_domain_folder(ref)
    spec, directory = _spec_from_entry_point(ref)
    loaded = _load(spec, directory, source)
    if loaded.name != name:
        raise DomainLoadError(
            f"{source}: is registered as {name!r} but its domain object is called {loaded.name!r}"
        )
    return loaded


def domain_infos() -> list[DomainInfo]:
    """Every installed domain (entry points and ``TAMP_DOMAINS``, then folders added in this
    process), each loaded, with the error of any that did not load."""
    found = _installed()
    out: list[DomainInfo] = []
    for name, (ref, source) in sorted(found.items()):
        try:
            loaded = _load_installed(name, ref, source)
        except Exception as exc:  # reported, never raised: one bad domain must not stop a server
            log.warning("domain %s (%s) is skipped: %s", name, source, exc)
            out.append(DomainInfo(name, source, None, f"{type(exc).__name__}: {exc}"))
            continue
        out.append(DomainInfo(name, source, str(loaded.home), None, loaded.spec.description))
    return out


def known_domains() -> tuple[str, ...]:
    """Names of the installed domains (those that load or not)."""
    found = _installed()
    return tuple(sorted(found))


def _looks_like_path(ref: str) -> bool:
    return "/" in ref or os.sep in ref or ref.startswith((".", "~"))


def load_domain(ref: str | Path, *, base: Path | None = None) -> LoadedDomain:
    """The domain ``ref`` names: an installed domain's name, or a folder path (relative paths
    against ``base``, else the working directory)."""
    if isinstance(ref, Path) or _looks_like_path(ref):
        path = Path(ref).expanduser()
        if not path.is_absolute() and base is not None:
            path = base / path
        return load_domain_folder(path)
    found = _installed()
    if ref in found:
        entry, source = found[ref]
        return _load_installed(ref, entry, source)
    if Path(ref).is_dir():
        return load_domain_folder(ref)
    raise DomainLoadError(
        f"unknown domain {ref!r} (known: {', '.join(sorted(found)) or 'none'}; or give the "
        "path of a domain folder)"
    )


def get_domain(name: str) -> LoadedDomain:
    """The installed domain called ``name`` (or the folder ``name`` is a path of)."""
    return load_domain(name)


# --- scenes ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SceneRef:
    """A scene file found by name, and the domain it names (as written in the file)."""

    name: str
    path: Path
    domain: str


def _scene_dirs(domain: LoadedDomain | None) -> list[Path]:
    """Where scenes are looked up by name, first first."""
    dirs = [SCENES_DIR.resolve()]
    if domain is not None:
        dirs.insert(0, domain.scenes_dir)
        return dirs
    found = _installed()
    for name, (ref, source) in sorted(found.items()):
        if isinstance(ref, Path):
            dirs.append(ref / "scenes")
            continue
        try:
            dirs.append(_load_installed(name, ref, source).scenes_dir)
        except Exception as exc:  # a broken domain's scenes are not offered
            log.debug("domain %s skipped while listing scenes: %s", name, exc)
    out: list[Path] = []
    for d in dirs:
        if d not in out:
            out.append(d)
    return out


def scene_refs(domains: Iterable[LoadedDomain] = ()) -> list[SceneRef]:
    """The scene files findable by name: the project's, then those of every domain found (and
    of ``domains``); a name found twice is offered once, from the first folder."""
    dirs = _scene_dirs(None)
    for d in domains:
        if d.scenes_dir not in dirs:
            dirs.append(d.scenes_dir)
    out: dict[str, SceneRef] = {}
    for directory in dirs:
        if not directory.is_dir():
            continue
        for name in known_scenes(directory):
            if name in out:
                continue
            path = directory / f"{name}.json"
            try:
                scene = load_scene(str(path))
            except SceneError as exc:
                log.warning("scene %s is not offered: %s", path, exc)
                continue
            out[name] = SceneRef(name, path, scene.domain)
    return list(out.values())


def find_scene(name_or_path: str, *, domain: LoadedDomain | None = None) -> Scene:
    """A scene by path (``.json``) or by name (see the module docstring)."""
    if name_or_path.endswith(".json"):
        return load_scene(name_or_path)
    for directory in _scene_dirs(domain):
        if (directory / f"{name_or_path}.json").is_file():
            return load_scene(str(directory / f"{name_or_path}.json"))
    names = sorted({n for d in _scene_dirs(domain) if d.is_dir() for n in known_scenes(d)})
    raise SceneError(f"unknown scene {name_or_path!r} (known scenes: {', '.join(names) or 'none'})")


def domain_of_scene(scene: Scene, domain: LoadedDomain | str | Path | None = None) -> LoadedDomain:
    """The domain a scene is for: its ``"domain"`` (a name, or a folder path against the scene
    file's folder), which must agree with ``domain`` when that is given."""
    base = Path(scene.source).resolve().parent if scene.source != "<dict>" else None
    given = domain if isinstance(domain, LoadedDomain) or domain is None else load_domain(domain)
    if given is not None:
        if scene.domain == given.name:
            return given
        same = base is not None and (base / scene.domain).resolve() == given.home
        if _looks_like_path(scene.domain) and same:
            return given
        raise scene.field_error(
            "domain",
            f"scene is for {scene.domain!r}, not {given.name!r} ({given.home})",
        )
    try:
        return load_domain(scene.domain, base=base if _looks_like_path(scene.domain) else None)
    except DomainLoadError as exc:
        raise scene.field_error("domain", str(exc)) from exc


def problem_for_scene(
    scene_name: str, *, seed: int = 0, domain: LoadedDomain | str | Path | None = None
) -> tuple[LoadedDomain, Problem]:
    """Load a scene by name or path, its domain, and the problem it describes."""
    given = domain if isinstance(domain, LoadedDomain) or domain is None else load_domain(domain)
    scene = find_scene(scene_name, domain=given)
    loaded = domain_of_scene(scene, given)
    return loaded, loaded.problem_from_scene(scene, seed=seed)


def scene_domain(ref: SceneRef) -> LoadedDomain:
    """The domain of a listed scene."""
    return domain_of_scene(load_scene(str(ref.path)))
