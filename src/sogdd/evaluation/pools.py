"""Worker processes for the evaluations' ``--jobs``, safe where a learned detector has run.

The evaluations build every detector once in the main process (a bad spec fails
before any work), and the learned entries (the ``learned`` extra) load their
network with PyTorch there. A process forked from one in which PyTorch has
started its OpenMP thread pool hangs at its first parallel operation (checked
here: ``sogdd eval repeatability --detectors xfeat --jobs 2`` never finished).
:func:`process_pool` therefore forks (fast: the workers inherit the imports and
numba's compiled code) only while PyTorch is not loaded, and spawns fresh
interpreters once it is.
"""

from __future__ import annotations

import multiprocessing
import sys
from concurrent.futures import ProcessPoolExecutor

__all__ = ["process_pool", "start_method"]


def start_method() -> str:
    """``"spawn"`` once PyTorch is imported in this process, else the platform's default.

    Examples
    --------
    >>> start_method() == ("spawn" if "torch" in sys.modules else multiprocessing.get_start_method())
    True
    """
    return "spawn" if "torch" in sys.modules else multiprocessing.get_start_method()


def process_pool(max_workers: int) -> ProcessPoolExecutor:
    """A ``ProcessPoolExecutor`` of ``max_workers`` that starts its workers by :func:`start_method`.

    Examples
    --------
    >>> with process_pool(1) as ex:
    ...     ex.submit(abs, -3).result()
    3
    """
    return ProcessPoolExecutor(max_workers=max_workers, mp_context=multiprocessing.get_context(start_method()))
