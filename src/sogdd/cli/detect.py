"""sogdd detect: corners of one or many images, as CSV, JSON or NPZ.

Without --out all results go to one output (stdout by default). With --out DIR
each image gets its own feature file (the schema of sogdd.features), written by
local worker processes or a Dask cluster, resumable.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

from ..collection import expand_inputs, run_batch
from ..corners import Corners
from ..detector import detect_corners
from ..features import csv_rows, json_object
from ..io import read_image
from ..params import resolve_params
from .overlay import save_overlay
from .params import add_detector_arguments, detector_overrides


def corners_table(c: Corners) -> np.ndarray:
    return np.column_stack([c.xy, c.response, c.size]) if len(c) else np.zeros((0, 4))


def _csv(results: list[tuple[str, Corners]], with_image: bool) -> str:
    lines = [("image," if with_image else "") + "x,y,response,size"]
    for name, c in results:
        lines += csv_rows(c, f"{name}," if with_image else "")
    return "\n".join(lines) + "\n"


def _json(results: list[tuple[str, Corners]]) -> str:
    objs = [json_object(c, name) for name, c in results]
    return json.dumps(objs[0] if len(objs) == 1 else objs)


def write_results(results: list[tuple[str, Corners]], fmt: str, output: str, many: bool) -> None:
    if fmt == "npz":
        if output == "-":
            raise ValueError("--format npz needs --output FILE")
        arrays = {}
        for name, c in results:
            key = Path(name).name if many else "corners"
            arrays[key] = corners_table(c)
        np.savez(output, **arrays)
        return
    text = _csv(results, many) if fmt == "csv" else _json(results) + "\n"
    if output == "-":
        sys.stdout.write(text)
    else:
        Path(output).write_text(text)


def run(args: argparse.Namespace) -> int:
    params = detector_overrides(args)
    resolve_params(args.preset, **params)  # bad parameters fail before any work
    paths = expand_inputs(args.images)
    if not paths:
        raise ValueError("no input images")
    if args.out and args.device != "cpu":
        raise ValueError("--device cuda works without --out DIR for now")
    if args.out:
        return _run_folder(args, paths, params)
    if args.resume or args.jobs != 1 or args.scheduler:
        raise ValueError("--resume, --jobs and --scheduler need --out DIR")
    fmt = args.format or "csv"
    many = len(paths) > 1 or Path(args.images[0]).is_dir()
    results: list[tuple[str, Corners]] = []
    failures = 0
    for path in tqdm(paths, desc="detect", unit="img", file=sys.stderr, disable=not many):
        try:
            img = read_image(path)
            c = detect_corners(img, preset=args.preset, device=args.device, **params)
        except (ValueError, OSError) as exc:
            failures += 1
            msg = str(exc) if str(path) in str(exc) else f"{path}: {exc}"
            print(f"sogdd: error: {msg}", file=sys.stderr)
            continue
        results.append((str(path), c))
        if args.overlay and not many:
            save_overlay(img, c, args.overlay)
    if results or not failures:
        write_results(results, fmt, args.output, many)
    if many:
        print(f"sogdd: {len(results)} image(s) done, {failures} failed", file=sys.stderr)
    return 2 if failures else 0


def _run_folder(args: argparse.Namespace, paths: list[Path], params: dict) -> int:
    """One feature file per image in ``--out``; resumable; processes or Dask."""
    bar = tqdm(total=len(paths), desc="detect", unit="img", file=sys.stderr)

    def progress(item) -> None:
        bar.update(1)
        if item.status == "failed":
            tqdm.write(f"sogdd: error: {item.message}", file=sys.stderr)

    try:
        items = run_batch(
            paths, args.out, fmt=args.format or "npz", preset=args.preset, params=params,
            resume=args.resume, jobs=args.jobs, scheduler=args.scheduler, progress=progress,
        )
    finally:
        bar.close()
    counts = {s: sum(i.status == s for i in items) for s in ("done", "skipped", "failed")}
    print(
        f"sogdd: {counts['done']} done, {counts['skipped']} skipped (already there), "
        f"{counts['failed']} failed; features in {args.out}",
        file=sys.stderr,
    )
    for item in items:
        if item.status == "failed":
            print(f"  failed: {item.message}", file=sys.stderr)
    return 2 if counts["failed"] else 0


def configure(p: argparse.ArgumentParser) -> None:
    """The ``detect`` command's arguments."""
    p.description = __doc__
    p.add_argument("images", nargs="+", help="image files, folders or glob patterns")
    add_detector_arguments(p)
    p.add_argument("--device", choices=["cpu", "cuda"], default="cpu",
                   help="cuda: run on an NVIDIA GPU (pip install 'sogdd[gpu]')")
    p.add_argument("--output", "-o", default="-", help="one output file for all images, or - for stdout")
    p.add_argument("--format", choices=["csv", "json", "npz"], default=None,
                   help="csv, json or npz [default: csv; npz with --out]")
    p.add_argument("--overlay", metavar="PNG", help="write an overlay image (single image only)")
    g = p.add_argument_group("image collections")
    g.add_argument("--out", metavar="DIR", help="write one feature file per image into DIR")
    g.add_argument("--resume", action="store_true", help="skip images whose feature file exists")
    g.add_argument("--jobs", type=int, default=1, help="local worker processes")
    g.add_argument("--scheduler", metavar="ADDRESS", help="run on a Dask distributed scheduler")
    p.set_defaults(func=run)
