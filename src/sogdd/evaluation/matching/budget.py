"""An equal feature budget for every detector, and detectors evaluated in parallel processes.

Comparing detectors that return 500 and 9,000 points per image compares budgets as
much as detectors: mutual-NN matching among more points finds more matches and a
lower fraction of correct ones, and COLMAP's mapper reconstructs more points.
:func:`with_budget` gives every spec the same cap (``top_k``, the strongest points
by ``Corners.response``), keeping a tighter ``top_k`` the spec already has. A
detector that finds fewer points keeps all of them; the tables report the
features per image, so a shortfall shows.

:func:`map_specs` runs one function per detector spec, in ``jobs`` worker
processes (the matching and SfM evaluations' ``--jobs``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import as_completed
from typing import TypeVar

from ..pools import process_pool
from ..specs import DetectorSpec

__all__ = ["budget_of", "map_specs", "with_budget"]

T = TypeVar("T")


def with_budget(spec: DetectorSpec, max_features: int | None) -> DetectorSpec:
    """``spec`` with at most ``max_features`` points per image (its own smaller ``top_k`` kept).

    The label is the spec text of the result, so tables name the budget.

    Examples
    --------
    >>> from sogdd.evaluation.specs import parse_spec
    >>> with_budget(parse_spec("sift"), 2000).label
    'sift:top_k=2000'
    >>> with_budget(parse_spec("orb:top_k=500"), 2000).top_k
    500
    >>> with_budget(parse_spec("sogdd-hr"), None).label
    'sogdd-hr'
    """
    if max_features is None:
        return spec
    if isinstance(max_features, bool) or not isinstance(max_features, int) or max_features < 1:
        raise ValueError(f"max_features must be a positive integer, got {max_features!r}")
    k = max_features if spec.top_k is None else min(spec.top_k, max_features)
    if k == spec.top_k:
        return spec
    pipe = {**spec.pipeline, "top_k": k}
    return DetectorSpec(spec.name, dict(spec.params), "", **pipe)


def budget_of(spec_json: dict) -> int | None:
    """The ``top_k`` recorded in a result's ``spec`` (``DetectorSpec.to_json``), or ``None``.

    Examples
    --------
    >>> budget_of({"detector": "sift", "params": {}, "top_k": 2000})
    2000
    >>> budget_of({"detector": "sift", "params": {}}) is None
    True
    """
    k = (spec_json or {}).get("top_k")
    return int(k) if k is not None else None


def map_specs(fn: Callable[[DetectorSpec], T], specs: Sequence[DetectorSpec], jobs: int = 1,
              on_result: Callable[[DetectorSpec, T], None] | None = None) -> list[T]:
    """``[fn(spec) for spec in specs]``, in ``jobs`` processes when ``jobs > 1`` (results in order).

    ``fn`` must be picklable (a module-level function or a ``functools.partial``
    of one). ``on_result(spec, result)`` is called as each one finishes, so a
    caller can keep what is done. An exception in a worker is raised here.

    Examples
    --------
    >>> from operator import attrgetter
    >>> from sogdd.evaluation.specs import parse_spec
    >>> map_specs(attrgetter("name"), [parse_spec("sift"), parse_spec("orb:top_k=5")])
    ['sift', 'orb']
    """
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise ValueError(f"jobs must be a positive integer, got {jobs!r}")
    specs = list(specs)
    out: list = [None] * len(specs)
    if jobs == 1 or len(specs) <= 1:
        for i, s in enumerate(specs):
            out[i] = fn(s)
            if on_result is not None:
                on_result(s, out[i])
        return out
    with process_pool(min(jobs, len(specs))) as ex:  # spawned once PyTorch is loaded
        futs = {ex.submit(fn, s): i for i, s in enumerate(specs)}
        for f in as_completed(futs):
            i = futs[f]
            out[i] = f.result()
            if on_result is not None:
                on_result(specs[i], out[i])
    return out
