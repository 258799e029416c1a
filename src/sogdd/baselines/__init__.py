"""Baseline detectors behind one registry: ``available()`` and ``get(name, **params)``.

See ``docs/baselines.md`` for the table of every detector, its source, its
defaults and what was reimplemented or approximated.
"""

# importing a module registers its detectors
from . import (  # noqa: F401
    learned,
    opencv,
    sogdd_entries,
    surf_like,
    zhang2013,
    zhang2020,
    zhang2021,
)
from .registry import BaselineDetector, available, get, registered

__all__ = ["BaselineDetector", "available", "get", "registered"]
