"""Detection over image collections: one feature file per image, resumable, in
local processes or on a Dask cluster.

Feature files are named ``<image file name>.<format>`` (``0001.jpg.npz``) so
images that differ only in extension never collide, and are written atomically
(a temporary file in the same folder, then ``os.replace``), so an interrupted
run never leaves a half-written file that ``resume`` would mistake for done.

Formats (coordinates: x = column, y = row, pixel centres at integers):

- ``npz``: arrays ``xy`` (N, 2), ``response`` (N,), ``size`` (N,), ``level`` (N,)
  and ``image_shape`` (2,);
- ``csv``: ``x,y,response,size``;
- ``json``: ``{"image", "n", "x", "y", "response", "size"}``.
"""

from __future__ import annotations

import glob
import io
import json
import os
import tempfile
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .corners import Corners
from .detector import detect_corners, resolve_params
from .io import read_image

__all__ = ["IMAGE_SUFFIXES", "BatchItem", "expand_inputs", "feature_path", "run_batch", "write_features"]

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".ppm", ".pgm", ".pbm", ".tif", ".tiff", ".webp"}


def expand_inputs(items: Iterable[str]) -> list[Path]:
    """Files as given; folders expand to their image files; glob patterns expand (sorted)."""
    out: list[Path] = []
    for item in items:
        p = Path(item)
        if p.is_dir():
            out.extend(sorted(q for q in p.iterdir() if q.suffix.lower() in IMAGE_SUFFIXES))
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


def csv_rows(c: Corners, prefix: str = "") -> list[str]:
    """``x,y,response,size`` rows (no header), each optionally prefixed (``"image,"``)."""
    return [f"{prefix}{x:.4f},{y:.4f},{r:.9g},{s:.4g}" for (x, y), r, s in zip(c.xy, c.response, c.size)]


def json_object(c: Corners, image: str) -> dict:
    """The JSON form of one image's corners."""
    return {"image": image, "n": len(c), "x": c.xy[:, 0].round(4).tolist(),
            "y": c.xy[:, 1].round(4).tolist(), "response": c.response.tolist(),
            "size": c.size.tolist()}


def _encode(c: Corners, fmt: str, image: str, shape: tuple[int, ...]) -> bytes:
    if fmt == "npz":
        buf = io.BytesIO()
        np.savez(buf, xy=c.xy, response=c.response, size=c.size, level=c.level,
                 image_shape=np.asarray(shape[:2]))
        return buf.getvalue()
    if fmt == "csv":
        return ("\n".join(["x,y,response,size", *csv_rows(c)]) + "\n").encode()
    if fmt == "json":
        return json.dumps(json_object(c, image)).encode()
    raise ValueError(f"unknown format {fmt!r}")


def write_features(path: Path, c: Corners, fmt: str, image: str, shape: tuple[int, ...]) -> None:
    """Write one feature file atomically."""
    data = _encode(c, fmt, image, shape)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


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
    if fmt not in ("npz", "csv", "json"):
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
