"""Detection over image collections: one feature file per image, resumable, in
local processes or on a Dask cluster.

Feature files are named ``<image file name>.<format>`` (``0001.jpg.npz``) so
images that differ only in extension never collide, and are written atomically
(a temporary file in the same folder, then ``os.replace``), so an interrupted
run never leaves a half-written file that ``resume`` would mistake for done.

The file formats are those of :mod:`sogdd.features`.
"""

from __future__ import annotations

import glob
import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

from .detector import detect_corners
from .features import FORMATS, write_features
from .io import list_images, read_image
from .params import resolve_params

__all__ = ["BatchItem", "expand_inputs", "feature_path", "run_batch"]


def expand_inputs(items: Iterable[str]) -> list[Path]:
    """Files as given; folders expand to their image files; glob patterns expand (sorted)."""
    out: list[Path] = []
    for item in items:
        p = Path(item)
        if p.is_dir():
            out.extend(list_images(p))
        elif not p.exists() and any(ch in item for ch in "*?["):
            matches = sorted(Path(m) for m in glob.glob(item, recursive=True))
            if not matches:
                raise ValueError(f"{item}: no files match")
            out.extend(m for m in matches if m.is_file())
        else:
            out.append(p)
    return out


def feature_path(out_dir: str | os.PathLike, image: str | os.PathLike, fmt: str) -> Path:
    return Path(out_dir) / f"{Path(image).name}.{fmt}"


@dataclass(frozen=True)
class BatchItem:
    """The outcome for one image: ``status`` is "done", "skipped" or "failed"."""

    image: str
    status: str
    n: int = 0
    message: str = ""


def detect_to_file(image: str, out_dir: str, fmt: str, preset: str, params: dict, resume: bool) -> BatchItem:
    """Detect on one image and write its feature file (the unit of work, picklable)."""
    target = feature_path(out_dir, image, fmt)
    if resume and target.exists():
        return BatchItem(image, "skipped")
    try:
        img = read_image(image)
        c = detect_corners(img, preset=preset, **params)
        write_features(target, c, fmt, image, img.shape)
    except (ValueError, OSError) as exc:
        msg = str(exc) if str(image) in str(exc) else f"{image}: {exc}"
        return BatchItem(image, "failed", message=msg)
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
) -> list[BatchItem]:
    """Detect on every image, one feature file each; a bad image never stops the others.

    ``jobs`` local processes (the default path), or a Dask distributed cluster at
    ``scheduler`` (``pip install 'sogdd[distributed]'``). Returns one
    :class:`BatchItem` per image, in input order.
    """
    params = dict(params or {})
    resolve_params(preset, **params)  # bad parameters fail before any work
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}")
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    names = [str(p) for p in images]
    args = [(n, str(out), fmt, preset, params, resume) for n in names]
    results: dict[str, BatchItem] = {}

    def done(item: BatchItem) -> None:
        results[item.image] = item
        if progress:
            progress(item)

    if scheduler:
        _run_dask(args, scheduler, done)
    elif jobs == 1:
        for a in args:
            done(detect_to_file(*a))
    else:
        from concurrent.futures import ProcessPoolExecutor, as_completed

        with ProcessPoolExecutor(max_workers=jobs, initializer=_one_thread_per_worker) as pool:
            futures = [pool.submit(detect_to_file, *a) for a in args]
            for f in as_completed(futures):
                done(f.result())
    return [results[n] for n in names]


def _one_thread_per_worker() -> None:
    # the processes already fill the cores; threads inside each would oversubscribe them
    os.environ["SOGDD_NUM_THREADS"] = "1"


def _run_dask(args: list[tuple], scheduler: str, done: Callable[[BatchItem], None]) -> None:
    try:
        from distributed import Client, as_completed
    except ImportError as exc:
        raise ValueError("--scheduler needs Dask: pip install 'sogdd[distributed]'") from exc
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
