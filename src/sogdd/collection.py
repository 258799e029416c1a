"""Detection over image collections: one feature file per image, resumable, in
local processes or on a Dask cluster; every good result is kept.

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
that dies (``SIGKILL`` from the out-of-memory killer) takes down the process
pool, and with it every image in flight: those are retried, each alone in a
fresh single-worker pool, and an image whose worker dies again is recorded as
failed; the pool is replaced and the rest of the batch continues.

Signals. ``SIGINT`` (Ctrl-C) or ``SIGTERM`` stops the batch within a fraction of a
second: workers are killed, their partial files removed, finished files kept,
and :class:`BatchInterrupted` is raised (a ``KeyboardInterrupt`` carrying the
signal number and the finished items). Workers die with their parent (Linux
``PR_SET_PDEATHSIG``), so killing the parent never leaves orphans.
"""

from __future__ import annotations

import ctypes
import glob
import os
import signal
import socket
import sys
import threading
from collections import deque
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from ._jit import thread_count
from ._version import __version__
from .detector import detect_corners
from .formats.features import (
    FORMATS,
    check_name,
    make_record,
    params_dict,
    read_features,
    remove_stale_temporaries,
    source_stamp,
    write_features,
)
from .image.files import list_images, opencv_message, read_image
from .image.validate import check_mask
from .params import resolve_params

__all__ = [
    "BatchInterrupted", "BatchItem", "expand_inputs", "feature_path", "relative_names", "run_batch",
]

_DIED = "worker process died (killed by the system, e.g. out of memory)"


class BatchInterrupted(KeyboardInterrupt):
    """A batch stopped by a signal; ``signum`` says which, ``items`` holds what finished."""

    def __init__(self, signum: int, items: list | None = None):
        super().__init__(f"interrupted by {signal.Signals(signum).name}")
        self.signum = int(signum)
        self.items = list(items or [])


def expand_inputs(items: Iterable[str], *, recursive: bool = False) -> list[Path]:
    """Files as given; folders expand to their image files (``recursive``: and their
    sub-folders'); glob patterns expand (sorted). The same path twice is kept once."""
    out: list[Path] = []
    for item in items:
        p = Path(item)
        if p.is_dir():
            out.extend(list_images(p, recursive=recursive))
        elif not os.path.lexists(p) and any(ch in item for ch in "*?["):
            matches = sorted(Path(m) for m in glob.glob(item, recursive=True))
            matches = [m for m in matches if m.is_file()]
            if not matches and not _is_frame(item):
                raise ValueError(f"{item}: no files match")
            out.extend(matches or [p])
        else:
            out.append(p)
    seen: set[str] = set()
    unique = []
    for p in out:
        key = os.path.realpath(p) if os.path.lexists(p) else str(p)
        if key not in seen:
            seen.add(key)
            unique.append(p)
    return unique


def _is_frame(item: str) -> bool:
    """``photo.tif[2]``: a frame of an existing file, not a glob pattern."""
    base, _, rest = item.rpartition("[")
    return bool(base) and rest[:-1].isdigit() and rest.endswith("]") and os.path.isfile(base)


def relative_names(paths: list[str | os.PathLike]) -> list[str]:
    """Each path relative to the folder common to all of them, as a POSIX string.

    Raises ``ValueError`` naming both files if two of them still map to the same name.

    Examples
    --------
    >>> relative_names(["/data/a/0001.jpg", "/data/b/0001.jpg"])
    ['a/0001.jpg', 'b/0001.jpg']
    >>> relative_names(["/data/a/0001.jpg"])
    ['0001.jpg']
    """
    absolute = [os.path.abspath(os.fspath(p)) for p in paths]
    if not absolute:
        return []
    root = os.path.commonpath([os.path.dirname(a) for a in absolute])
    names = [Path(os.path.relpath(a, root)).as_posix() for a in absolute]
    first: dict[str, int] = {}
    for i, n in enumerate(names):
        j = first.setdefault(n.lower(), i)  # lower: case-insensitive file systems collide too
        if j != i:
            raise ValueError(f"{paths[j]} and {paths[i]} would both be written as {n!r}")
    return names


def feature_path(out_dir: str | os.PathLike, name: str, fmt: str) -> Path:
    """``out_dir/<name>.<fmt>``, ``name`` from :func:`relative_names`."""
    return Path(out_dir) / f"{name}.{fmt}"


@dataclass(frozen=True)
class BatchItem:
    """The outcome for one image: ``status`` is "done", "skipped" or "failed"."""

    image: str
    status: str
    n: int = 0
    message: str = ""


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
    applies to every image; an image of another size fails. Returns one
    :class:`BatchItem` per image, in input order. Raises :class:`BatchInterrupted` on ``SIGINT``/``SIGTERM``.
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
        with _signals_raise():
            if scheduler:
                _run_dask(args, scheduler, done)
            elif jobs == 1:
                for a in args:
                    done(detect_to_file(*a))
            else:
                _run_local(args, jobs, done)
    except KeyboardInterrupt as exc:
        remove_stale_temporaries(out)
        signum = exc.signum if isinstance(exc, BatchInterrupted) else int(signal.SIGINT)
        raise BatchInterrupted(signum, [results[n] for n in names if n in results]) from None
    return [results[n] for n in names]


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
        from .gpu.input import require_cuda

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


def _run_local(args: list[tuple], jobs: int, done: Callable[[BatchItem], None]) -> None:
    """``jobs`` worker processes, at most ``jobs`` images in flight; a broken pool is replaced."""
    pending = deque(args)
    while pending:
        lost = _run_pool(pending, jobs, done)
        for a in lost:  # each alone: only an image that kills its own worker fails
            if _run_pool(deque([a]), 1, done):
                done(BatchItem(a[0], "failed", message=f"{a[0]}: {_DIED}"))


def _run_pool(queue: deque, width: int, done: Callable[[BatchItem], None]) -> list[tuple]:
    """Run tasks from ``queue`` until it is empty or the pool breaks; return the tasks lost in a break."""
    pool = ProcessPoolExecutor(width, initializer=_worker_init, initargs=(os.getpid(),))
    inflight: dict = {}
    lost: list[tuple] = []
    try:
        while queue or inflight:
            while queue and len(inflight) < width and not lost:
                a = queue.popleft()
                inflight[pool.submit(detect_to_file, *a)] = a
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
        _kill_workers(pool)
        raise
    return lost


def _kill_workers(pool: ProcessPoolExecutor) -> None:
    for proc in list((getattr(pool, "_processes", None) or {}).values()):
        try:
            proc.kill()
        except (OSError, ValueError, AttributeError):
            pass
    pool.shutdown(wait=True, cancel_futures=True)


def _worker_init(parent: int) -> None:
    # the parent handles Ctrl-C (and kills the workers); a worker must not die on it mid-write
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        try:  # die with the parent: PR_SET_PDEATHSIG = 1
            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)
        except (OSError, AttributeError):  # pragma: no cover
            pass
    if os.getppid() != parent:  # the parent died before prctl took effect
        os._exit(1)
    # the processes already fill the cores; threads inside each would oversubscribe them
    os.environ["SOGDD_NUM_THREADS"] = "1"


def _run_dask(args: list[tuple], scheduler: str, done: Callable[[BatchItem], None]) -> None:
    try:
        from distributed import Client, as_completed
    except ImportError as exc:
        raise ValueError("--scheduler needs Dask: pip install 'sogdd[distributed]'") from exc
    _probe_scheduler(scheduler)
    try:
        client = Client(scheduler, timeout="10s")
    except OSError as exc:
        raise ValueError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from exc
    try:
        futures = [client.submit(detect_to_file, *a, pure=False) for a in args]
        for f in as_completed(futures):
            done(f.result())
    finally:
        client.close()


def _probe_scheduler(address: str) -> None:
    """Fail at once when nothing listens at a ``tcp://host:port`` scheduler (Dask would retry for 10 s).

    Only a refused or unresolvable address fails here; one that does not answer
    within a second is left to Dask's own timeout.
    """
    scheme, _, rest = address.rpartition("://")
    if scheme not in ("", "tcp"):
        return  # tls://, ucx://, inproc://: Dask's business
    host, _, port = rest.rpartition(":")
    if not host or not port.isdigit():
        return
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=1.0).close()
    except (ConnectionRefusedError, socket.gaierror) as exc:
        raise ValueError(f"cannot reach the Dask scheduler at {address}: "
                         f"{exc.strerror or exc} (is it running?)") from None
    except OSError:
        pass  # a timeout or an unreachable network: Dask's timeout decides
