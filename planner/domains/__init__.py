"""Domains as plug-ins: the public interface (:class:`DomainSpec`) and how domains are found.

A domain is a folder with ``domain.pddl``, ``stream.pddl`` and a Python module exporting one
:class:`DomainSpec` as ``DOMAIN``; it is found by folder path or, installed, by name through the
entry-point group ``guided_tamp.domains`` (:mod:`planner.domains.registry`). Generic code never
imports a particular domain: it calls the hooks of the :class:`LoadedDomain` it is given.
docs/domains.md explains every hook; ``examples/tabletop2d/`` is a domain to copy.
"""

from planner.domains.registry import (
    DOMAINS_ENV,
    ENTRY_POINT_GROUP,
    DomainInfo,
    DomainLoadError,
    SceneRef,
    add_domain_folder,
    domain_infos,
    domain_of_scene,
    find_scene,
    get_domain,
    known_domains,
    load_domain,
    load_domain_folder,
    problem_for_scene,
    scene_domain,
    scene_refs,
)
from planner.domains.spec import (
    BindingFactory,
    DomainSpec,
    LoadedDomain,
    PlanCheck,
    PlanValidator,
    ProblemBuilder,
    StaticContext,
)

__all__ = [
    "DOMAINS_ENV",
    "ENTRY_POINT_GROUP",
    "BindingFactory",
    "DomainInfo",
    "DomainLoadError",
    "DomainSpec",
    "LoadedDomain",
    "PlanCheck",
    "PlanValidator",
    "ProblemBuilder",
    "SceneRef",
    "StaticContext",
    "add_domain_folder",
    "domain_infos",
    "domain_of_scene",
    "find_scene",
    "get_domain",
    "known_domains",
    "load_domain",
    "load_domain_folder",
    "problem_for_scene",
    "scene_domain",
    "scene_refs",
]
