"""A batch on local worker processes (:class:`concurrent.futures.ProcessPoolExecutor`).

At most ``jobs`` images are in flight. A worker that dies (``SIGKILL`` from the
out-of-memory killer) breaks the executor and loses every image in flight:
those are retried each alone in a fresh single-worker executor, and an image
whose worker dies again is reported as failed; the rest of the batch goes on in
a fresh executor.

Lifeline. Every worker watches the read end of a pipe whose only write end the
parent holds, and exits the moment it reads end-of-file: when the parent closes
it (Ctrl-C, ``SIGTERM``: the batch stops within a fraction of a second), and
when the parent dies, however (even ``SIGKILL``), because the kernel then closes
it. So no worker outlives its parent, on any POSIX system, with no platform call
and no reach into the executor's private state. The watch is a thread, so it
runs when the worker's main thread releases the GIL; the numba kernels release
it (``nogil``) and so does OpenCV.

Start method (:func:`safe_start_method`, the package's one rule). Forking is fast (the
workers inherit the imports and numba's compiled code) and needs no ``__main__``
guard in the caller's script, so it is the default, except where the parent's
state makes forked children fail: a child of a parent that has run numba's
``parallel=True`` code on the GNU OpenMP layer terminates ("fork() called from a
process already using GNU OpenMP") the moment it runs such code itself (the
calibration's corner refinement does), so then workers come from a fresh
``forkserver``; and a child of a parent in which PyTorch started its OpenMP pool
hangs at its first parallel operation, so once PyTorch is imported they are
spawned.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
from collections import deque
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from multiprocessing.connection import Connection

from .items import BatchItem

__all__ = ["DIED", "died_item", "run_local", "safe_start_method"]

DIED = "worker process died (killed by the system, e.g. out of memory)"


def safe_start_method() -> str:
    """How worker processes start, by this process's state (module doc): ``"spawn"`` once PyTorch is
    imported, ``"forkserver"`` instead of ``"fork"`` once numba's parallel code has run on GNU OpenMP,
    else the platform's default.

    Examples
    --------
    >>> safe_start_method() in ("fork", "forkserver", "spawn")
    True
    """
    import sys

    if "torch" in sys.modules:
        return "spawn"
    default = multiprocessing.get_start_method()
    if default != "fork" or "numba" not in sys.modules:
        return default
    import numba

    try:
        layer = numba.threading_layer()
    except ValueError:  # no parallel code has run here
        return default
    return "forkserver" if layer == "omp" else default


def died_item(a: tuple, message: str) -> BatchItem:
    """The outcome of a batch task whose worker died: its image (``a[0]``) failed with ``message``."""
    return BatchItem(a[0], "failed", message=f"{a[0]}: {message}")


def run_local(work: Callable, args: Sequence[tuple], jobs: int, done: Callable, *,
              died: Callable[[tuple, str], object] = died_item, start_method: str | None = None,
              preload: Sequence[str] = ()) -> None:
    """``work(*a)`` for each ``a`` in ``args`` on ``jobs`` worker processes; ``done`` gets each outcome.

    A task whose worker dies twice (module doc) gives ``died(a, DIED)`` instead.
    ``start_method`` is multiprocessing's (None: :func:`safe_start_method`);
    ``preload`` names modules a ``forkserver`` imports once for all its workers.
    """
    ctx = multiprocessing.get_context(start_method or safe_start_method())
    if preload and ctx.get_start_method() == "forkserver":
        ctx.set_forkserver_preload(list(preload))
    pending = deque(args)
    while pending:
        lost = _run_executor(work, pending, jobs, done, ctx)
        for a in lost:  # each alone: only an image that kills its own worker fails
            if _run_executor(work, deque([a]), 1, done, ctx):
                done(died(a, DIED))


def _run_executor(work: Callable, queue: deque, width: int, done: Callable, ctx) -> list[tuple]:
    """Run tasks from ``queue`` until it is empty or the executor breaks; return the tasks lost in a break."""
    lifeline, holder = ctx.Pipe(duplex=False)
    pool = ProcessPoolExecutor(width, mp_context=ctx, initializer=_worker_init, initargs=(lifeline, holder))
    inflight: dict = {}
    lost: list[tuple] = []
    try:
        while queue or inflight:
            while queue and len(inflight) < width and not lost:
                a = queue.popleft()
                inflight[pool.submit(work, *a)] = a
            if not inflight:
                break
            finished, _ = wait(list(inflight), timeout=0.25, return_when=FIRST_COMPLETED)
            for f in finished:
                a = inflight.pop(f)
                try:
                    done(f.result())
                except BrokenProcessPool:
                    lost.append(a)
        pool.shutdown(wait=True)
    except BaseException:
        holder.close()  # every worker exits at once; the executor then reaps them
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    finally:
        holder.close()
        lifeline.close()
    return lost


def _worker_init(lifeline: Connection, holder: Connection) -> None:
    # a forked worker inherits the parent's write end: only the parent's copy may keep the line open
    holder.close()
    threading.Thread(target=_exit_when_cut, args=(lifeline,), name="sogdd-lifeline", daemon=True).start()
    # the parent handles Ctrl-C (and stops the workers); a worker must not die on it mid-write
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # the processes already fill the cores; threads inside each would oversubscribe them
    os.environ["SOGDD_NUM_THREADS"] = "1"


def _exit_when_cut(lifeline: Connection) -> None:
    try:
        lifeline.recv_bytes()  # the parent never writes: this returns only at end-of-file
    except (EOFError, OSError):
        pass
    os._exit(1)
