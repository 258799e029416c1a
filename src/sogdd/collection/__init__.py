"""Detection over image collections: one feature file per image, resumable, in
local processes or on a Dask cluster; every good result is kept. A client of
the detector, never imported by the core.

Modules: :mod:`~sogdd.collection.names` (the inputs and the feature file each
gets), :mod:`~sogdd.collection.items` (what a batch reports),
:mod:`~sogdd.collection.processes` (local worker processes),
:mod:`~sogdd.collection.cluster` (Dask); the batch itself and its unit of work
are here, and :func:`run_tasks`, the runner under it, for any other work over
many files (the calibration's board detection uses it).

Names. Each image's feature file is ``<out>/<path relative to the inputs'
common folder>.<format>`` (``photos/a/0001.jpg`` and ``photos/b/0001.jpg`` give
``a/0001.jpg.npz`` and ``b/0001.jpg.npz``), so two inputs never write the same
file; the same file given twice is processed once.

Resume. A feature file counts as done only if it loads, and records the same
resolved parameters (every one: a changed threshold or ``max_corners`` redoes
it), the same sogdd version, and the size and SHA-256 of the image file it was
made from; anything else is redone. The content hash, not the modification
time, decides: an edit in place that keeps the size and the time (a rewrite
within one clock tick, ``cp -p``, ``touch -r``) is still seen, and a file only
touched or copied with a new time is not redone for nothing (hashing costs
about 10 ms for a 10 MB photo, far less than its detection). Temporary
files an interrupted run left behind are removed when the next run starts.
Files are written atomically (:func:`sogdd.formats.features.write_features`).

Failures. A bad image is reported and the others complete. A worker process
that dies (``SIGKILL`` from the out-of-memory killer) costs only the image it
was working on (:mod:`~sogdd.collection.processes`).

Signals. ``SIGINT`` (Ctrl-C) or ``SIGTERM`` stops the batch within a fraction of a
second: workers exit, their partial files are removed, finished files kept,
and :class:`BatchInterrupted` is raised (a ``KeyboardInterrupt`` carrying the
signal number and the finished items). Workers die with their parent, however
it ends (they watch a pipe only the parent holds open), so killing the parent
never leaves orphans.
"""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TypeVar

import cv2
import numpy as np

from .._jit import thread_count
from .._version import __version__
from ..detector import detect_corners
from ..formats.features import (
    FORMATS,
    check_name,
    make_record,
    params_dict,
    read_features,
    remove_stale_temporaries,
    source_stamp,
    write_features,
)
from ..image.files import opencv_message, read_image
from ..image.validate import check_mask
from ..params import resolve_params
from .cluster import connect, run_dask
from .items import BatchInterrupted, BatchItem
from .names import expand_inputs, feature_path, relative_names
from .processes import died_item, run_local

__all__ = [
    "BatchInterrupted", "BatchItem", "expand_inputs", "feature_path", "relative_names", "run_batch",
    "run_tasks",
]

T = TypeVar("T")


def _current(target: Path, params: dict, source: tuple) -> bool:
    """Whether ``target`` loads and was made with these parameters from a file with the stamp ``source``
    (:func:`~sogdd.formats.features.source_stamp`: its size and content hash are compared)."""
    size, _, digest = source
    if digest is None:
        return False
    try:
        recs = read_features(target)
    except ValueError:
        return False
    if len(recs) != 1:
        return False
    r = recs[0]
    return (r.params == params and r.sogdd_version == __version__ and r.source_size == size
            and r.source_sha256 == digest)


def detect_to_file(image: str, target: str, fmt: str, preset: str, params: dict, resume: bool,
                   read_options: dict | None = None, device: str = "cpu", mask=None) -> BatchItem:
    """Detect on one image and write its feature file (the unit of work, picklable)."""
    p = resolve_params(preset, **params)
    out = Path(target)
    source = source_stamp(image)  # before reading: an edit during detection is seen next time
    if resume and _current(out, params_dict(preset, p, mask), source):
        return BatchItem(image, "skipped")
    try:
        check_name(image)
        img = read_image(image, **(read_options or {}))
        c = detect_corners(img, preset=preset, mask=mask, device=device, **params)
        out.parent.mkdir(parents=True, exist_ok=True)
        write_features(out, make_record(image, c, img.shape, preset, p, source, mask=mask), fmt)
    except (ValueError, OSError, cv2.error) as exc:
        msg = opencv_message(exc) if isinstance(exc, cv2.error) else str(exc)
        return BatchItem(image, "failed", message=msg if str(image) in msg else f"{image}: {msg}")
    except MemoryError:
        return BatchItem(image, "failed", message=f"{image}: out of memory")
    return BatchItem(image, "done", len(c))


def run_batch(
    images: list[str | os.PathLike],
    out_dir: str | os.PathLike,
    *,
    fmt: str = "npz",
    preset: str = "paper",
    params: dict | None = None,
    resume: bool = False,
    jobs: int = 1,
    scheduler: str | None = None,
    progress: Callable[[BatchItem], None] | None = None,
    started: Callable[[], None] | None = None,
    read_options: dict | None = None,
    device: str = "cpu",
    mask=None,
) -> list[BatchItem]:
    """Detect on every image, one feature file each; a bad image never stops the others.

    ``jobs`` local processes (the default path), or a Dask distributed cluster at
    ``scheduler`` (``pip install 'sogdd[distributed]'``). ``read_options`` go to
    :func:`sogdd.read_image` (``max_pixels``, ``allow_corrupt``,
    ``ignore_orientation``). ``device="cuda"`` detects on the GPU
    (:mod:`sogdd.gpu`); each worker process opens its own CUDA context, so with
    ``jobs > 1`` they share the GPU. ``mask`` (uint8 or bool, the images' size)
    applies to every image; an image of another size fails. ``progress`` gets
    each image's :class:`BatchItem` as it finishes; ``started()`` is called once,
    after every check and (with ``scheduler``) the connection, just before the
    first image: a progress display opened there never comes before an error.
    Returns one :class:`BatchItem` per image, in input order. Raises
    :class:`BatchInterrupted` on ``SIGINT``/``SIGTERM``.
    """
    params = dict(params or {})
    _check_batch(preset, params, fmt, jobs, device, in_process=jobs == 1 and not scheduler)
    if mask is not None:
        mask = check_mask(mask, np.shape(mask))  # a bad dtype fails once, not once per image
    names = [str(p) for p in images]
    rel = relative_names(names)  # collisions fail before any work
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(out)
    args = [(n, str(feature_path(out, r, fmt)), fmt, preset, params, resume, read_options, device, mask)
            for n, r in zip(names, rel)]
    results: dict[str, BatchItem] = {}

    def done(item: BatchItem) -> None:
        results[item.image] = item
        if progress:
            progress(item)

    try:
        run_tasks(detect_to_file, args, done, jobs=jobs, scheduler=scheduler, started=started)
    except BatchInterrupted as exc:
        remove_stale_temporaries(out)
        raise BatchInterrupted(exc.signum, [results[n] for n in names if n in results]) from None
    return [results[n] for n in names]


def run_tasks(work: Callable[..., T], args: Sequence[tuple], done: Callable[[T], None], *, jobs: int = 1,
              scheduler: str | None = None, started: Callable[[], None] | None = None,
              died: Callable[[tuple, str], T] = died_item, start_method: str | None = None,
              preload: Sequence[str] = ()) -> None:
    """``work(*a)`` for every ``a`` of ``args``: in this process, on ``jobs`` local processes, or on Dask.

    The runner under :func:`run_batch`, for any work over many files. ``done``
    gets each outcome as it finishes (in this process, in completion order);
    ``work`` must be a module-level function and ``args`` picklable when
    ``jobs > 1`` or with ``scheduler``. A task whose worker process dies (the
    out-of-memory killer) gives ``died(a, why)`` and the others complete
    (:mod:`~sogdd.collection.processes`). ``started()`` is called once, after
    the connection to ``scheduler``, before the first task. ``start_method`` and
    ``preload``: :func:`~sogdd.collection.processes.run_local`.

    Raises :class:`BatchInterrupted` on ``SIGINT`` or ``SIGTERM``, its ``items``
    the outcomes finished so far; local workers stop at once.

    Examples
    --------
    >>> out = []
    >>> run_tasks(divmod, [(7, 2), (9, 4)], out.append)
    >>> out
    [(3, 1), (2, 1)]
    """
    if int(jobs) < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    finished: list = []

    def keep(outcome) -> None:
        finished.append(outcome)
        done(outcome)

    try:
        with _signals_raise():
            _run(work, list(args), int(jobs), scheduler, keep, started or (lambda: None), died, start_method,
                 preload)
    except KeyboardInterrupt as exc:
        signum = exc.signum if isinstance(exc, BatchInterrupted) else int(signal.SIGINT)
        raise BatchInterrupted(signum, finished) from None


def _run(work: Callable, args: list[tuple], jobs: int, scheduler: str | None, done: Callable,
         started: Callable[[], None], died: Callable, start_method: str | None, preload: Sequence[str]) -> None:
    """Every task in this process, on ``jobs`` local processes, or on the Dask cluster at ``scheduler``."""
    if scheduler:
        client = connect(scheduler)  # before ``started``: an unreachable scheduler is the only output
        try:
            started()
            run_dask(client, work, args, done, died=died)
        finally:
            client.close()
        return
    started()
    if jobs == 1:
        for a in args:
            done(work(*a))
    else:
        run_local(work, args, jobs, done, died=died, start_method=start_method, preload=preload)


def _check_batch(preset: str, params: dict, fmt: str, jobs: int, device: str, in_process: bool) -> None:
    """Bad parameters, environment, format, job count or device fail before any work."""
    resolve_params(preset, **params)
    thread_count()
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}")
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    if device not in ("cpu", "cuda"):
        raise ValueError(f"device must be 'cpu' or 'cuda', got {device!r}")
    if device == "cuda" and in_process:
        # one clear error, not one per image; only in-process (a parent that touched the CUDA
        # driver would leave forked workers unable to use it)
        from ..gpu.input import require_cuda

        require_cuda()


class _signals_raise:
    """While active (main thread only), ``SIGTERM`` raises :class:`BatchInterrupted` like Ctrl-C."""

    def __enter__(self):
        self.old = None
        if threading.current_thread() is threading.main_thread():
            self.old = signal.signal(signal.SIGTERM, _raise_interrupted)
        return self

    def __exit__(self, *exc) -> None:
        if self.old is not None:
            signal.signal(signal.SIGTERM, self.old)


def _raise_interrupted(signum, _frame) -> None:
    raise BatchInterrupted(signum)
