"""Helpers the benchmark scripts share (they run as ``python benchmarks/NAME.py``, so this
folder is on their path)."""

from __future__ import annotations


def parse_seeds(text: str) -> list[int]:
    """Seeds as a command line gives them: ``0-9``, ``0,3,5`` or a mix (``0-4,9``); ``""`` is
    none. A ValueError for anything else."""
    seeds: list[int] = []
    for part in text.split(","):
        if "-" in part:
            lo, hi = part.split("-", 1)
            seeds.extend(range(int(lo), int(hi) + 1))
        elif part:
            seeds.append(int(part))
    return seeds
