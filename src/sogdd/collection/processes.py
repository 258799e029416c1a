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
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
from collections import deque
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from multiprocessing.connection import Connection

from .items import BatchItem

__all__ = ["run_local"]

DIED = "worker process died (killed by the system, e.g. out of memory)"


def run_local(work: Callable[..., BatchItem], args: list[tuple], jobs: int,
              done: Callable[[BatchItem], None]) -> None:
    """``work(*a)`` for each ``a`` in ``args`` on ``jobs`` worker processes; ``done`` gets each outcome."""
    pending = deque(args)
    while pending:
        lost = _run_executor(work, pending, jobs, done)
        for a in lost:  # each alone: only an image that kills its own worker fails
            if _run_executor(work, deque([a]), 1, done):
                done(BatchItem(a[0], "failed", message=f"{a[0]}: {DIED}"))


def _run_executor(work: Callable[..., BatchItem], queue: deque, width: int,
                  done: Callable[[BatchItem], None]) -> list[tuple]:
    """Run tasks from ``queue`` until it is empty or the executor breaks; return the tasks lost in a break."""
    lifeline, holder = multiprocessing.Pipe(duplex=False)
    pool = ProcessPoolExecutor(width, initializer=_worker_init, initargs=(lifeline, holder))
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
