"""Worker processes for the evaluations' ``--jobs``, safe where a learned detector has run.

The evaluations build every detector once in the main process (a bad spec fails
before any work), and the learned entries (the ``learned`` extra) load their
network with PyTorch there. A process forked from one in which PyTorch has
started its OpenMP thread pool hangs at its first parallel operation (checked
here: ``sogdd eval repeatability --detectors xfeat --jobs 2`` never finished).
:func:`process_pool` therefore starts its workers by the package's one rule,
:func:`sogdd.collection.processes.safe_start_method` (fork while safe, spawn once
PyTorch is loaded).
"""

from __future__ import annotations

import multiprocessing
from concurrent.futures import ProcessPoolExecutor

from ..collection.processes import safe_start_method

__all__ = ["process_pool"]


def process_pool(max_workers: int) -> ProcessPoolExecutor:
    """A ``ProcessPoolExecutor`` of ``max_workers`` that starts its workers by the package's rule
    (:func:`~sogdd.collection.processes.safe_start_method`).

    Examples
    --------
    >>> with process_pool(1) as ex:
    ...     ex.submit(abs, -3).result()
    3
    """
    context = multiprocessing.get_context(safe_start_method())
    return ProcessPoolExecutor(max_workers=max_workers, mp_context=context)
