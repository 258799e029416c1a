"""sogdd detect: corners of one or many images, as CSV, JSON or NPZ.

Without --out all results go to one output (stdout by default). With --out DIR
each image gets its own feature file (the schema of sogdd.formats.features), written by
local worker processes or a Dask cluster, resumable.

A CSV file FILE.csv gets its provenance in FILE.csv.json beside it; CSV on
stdout is the header and the rows only. Writing stdout: a full disk (or any
write error) is one error line and exit 2; a reader that stops early (| head)
ends the command quietly with exit 141, as SIGPIPE ends cat or seq.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from .._jit import thread_count
from ..collection import BatchInterrupted, expand_inputs, relative_names, run_batch
from ..detector import detect_corners
from ..formats.features import (
    FeatureRecord,
    check_name,
    encode_features,
    make_record,
    sidecar_path,
    source_stamp,
    write_features,
)
from ..image.files import opencv_message, read_image
from ..image.validate import intensity_hint
from ..params import resolve_params
from ._common import check_input_files, check_not_inputs, output_folder, write_stdout
from .overlay import check_overlay_path, save_overlay
from .params import (
    add_detector_arguments,
    add_mask_argument,
    add_read_arguments,
    detector_overrides,
    read_mask,
    read_options,
)

# fewer corners than this from a threshold on a structured image earns a hint; with a relative threshold,
# also fewer than one per this many pixels (18 corners on a 6 Mpx photo: one outlier set the bar)
_FEW = 5
_PIXELS_PER_CORNER = 100_000


def write_results(records: list[FeatureRecord], fmt: str, output: str) -> None:
    """All images' records into one output (stdout as ``-``), in the schema of :mod:`sogdd.formats.features`."""
    if output == "-":
        write_stdout(encode_features(records, fmt))
    else:
        write_features(output, records, fmt)


def _check_options(args: argparse.Namespace, n_images: int) -> str:
    """Refuse option combinations that cannot work, before any image is read; return the format."""
    if args.out and args.output != "-":
        raise ValueError("--out DIR (one file per image) and --output FILE (one file) exclude each other")
    if not args.out and (args.resume or args.jobs != 1 or args.scheduler):
        raise ValueError("--resume, --jobs and --scheduler need --out DIR")
    if args.jobs < 1:
        raise ValueError(f"--jobs must be >= 1, got {args.jobs}")
    fmt = args.format or ("npz" if args.out else "csv")
    if fmt == "npz" and not args.out and args.output == "-":
        raise ValueError("--format npz needs --output FILE (binary output does not go to stdout)")
    if args.output != "-" and not args.out:
        suffix = Path(args.output).suffix.lower().lstrip(".")
        if suffix != fmt and not (args.format is None and suffix in ("csv", "json", "npz")):
            raise ValueError(f"--output {args.output}: the file name should end in .{fmt}")
        if args.format is None and suffix in ("csv", "json", "npz"):
            fmt = suffix
        _check_writable(Path(args.output))
    if args.overlay:
        if n_images != 1 or args.out:
            raise ValueError("--overlay draws one image: give a single image (without --out)")
        check_overlay_path(args.overlay)
    return fmt


def _outputs(args: argparse.Namespace, fmt: str) -> list[tuple[str, str | None]]:
    """The files one run writes (besides ``--out DIR``'s), with their flags."""
    single = None if args.out or args.output == "-" else args.output
    side = str(sidecar_path(single)) if single and fmt == "csv" else None
    return [("--output", single), ("--output (its sidecar)", side), ("--overlay", args.overlay)]


def _check_writable(path: Path) -> None:
    if path.is_dir():
        raise ValueError(f"--output {path}: is a folder; give a file name (--out DIR: a file per image)")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise ValueError(f"{path}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise ValueError(f"{path}: folder {folder} is not writable")


def _hint_few(img: np.ndarray, corners, params) -> str | None:
    """A one-time hint when a threshold leaves (almost) nothing on a structured image: the paper's
    absolute one, or a relative one that a single very strong corner sets."""
    n = len(corners)
    if params.quantile is not None:
        return None
    if params.threshold_rel is not None:
        if n >= max(_FEW, img.shape[0] * img.shape[1] / _PIXELS_PER_CORNER) or _flat(img):
            return None
        return _hint_relative(img, corners, params.threshold_rel)
    if n >= _FEW or params.threshold is None:
        return None
    hint = intensity_hint(img)
    if hint:
        return hint
    if _flat(img):
        return None  # nothing to find
    return (f"the absolute threshold {params.threshold:g} left {n} corner(s); for a relative selection try "
            "--threshold none --max-corners N")


def _hint_relative(img: np.ndarray, corners, rel: float) -> str:
    r = np.sort(np.asarray(corners.response, dtype=np.float64))[::-1]
    why = ""
    if len(r) >= 2 and r[1] > 0:
        why = f"; the strongest response is {r[0] / r[1]:.3g}x the next, so it sets the bar"
    return (f"--threshold-rel {rel:g} keeps responses above {rel:g} x the strongest: {len(r)} corner(s) on "
            f"{img.shape[1]}x{img.shape[0]} px{why}; for a number of corners use --max-corners N (with "
            "--threshold none), or a smaller --threshold-rel")


def _flat(img: np.ndarray) -> bool:
    """An image without structure (its subsampled grey levels hardly vary): no corners is right."""
    sub = img[:: max(1, img.shape[0] // 256), :: max(1, img.shape[1] // 256)]
    return float(np.std(sub)) < 1e-3 * _scale(img)


def _scale(img: np.ndarray) -> float:
    return {"uint8": 255.0, "uint16": 65535.0, "bool": 1.0}.get(img.dtype.name, 1.0)


def run(args: argparse.Namespace) -> int:
    params = detector_overrides(args)
    p = resolve_params(args.preset, **params)  # bad parameters fail before any work
    thread_count()  # and a bad SOGDD_NUM_THREADS
    reading = read_options(args)
    check_input_files([args.mask] if args.mask else [])
    mask = read_mask(args.mask, reading)
    paths = expand_inputs(args.images, recursive=args.recursive)
    if not paths:
        raise ValueError("no input images")
    check_input_files(paths)  # a device or a FIFO would be read (and hashed) for ever
    fmt = _check_options(args, len(paths))
    check_not_inputs(_outputs(args, fmt), [*paths, args.mask])
    names = relative_names(paths)  # collisions fail before any work
    if args.out:
        return _run_folder(args, paths, params, fmt, reading, mask)
    many = len(paths) > 1 or Path(args.images[0]).is_dir()
    records: list[FeatureRecord] = []
    failures, hinted = 0, False
    try:
        for path, name in tqdm(list(zip(paths, names)), desc="detect", unit="img", file=sys.stderr,
                               disable=not many):
            rec, hint = _detect_one(path, name if many else str(path), args, params, p, reading, mask)
            if rec is None:
                failures += 1
                continue
            records.append(rec)
            if hint and not hinted:
                _say(f"sogdd: note: {path}: {hint}")  # above the progress bar, never into its line
                hinted = True
    except KeyboardInterrupt:
        print(f"sogdd: interrupted after {len(records)} image(s); nothing written", file=sys.stderr)
        raise
    if records or not failures:
        write_results(records, fmt, args.output)
    if many:
        print(f"sogdd: {len(records)} image(s) done, {failures} failed", file=sys.stderr)
    return 2 if failures else 0


def _say(line: str) -> None:
    tqdm.write(line, file=sys.stderr)


def _detect_one(path: Path, name: str, args, params: dict, p, reading: dict, mask
                ) -> tuple[FeatureRecord | None, str | None]:
    """One image's record (named ``name``) and hint; a failure is reported on stderr and gives
    ``(None, None)``."""
    try:
        check_name(name)  # a name no output can hold fails this image alone, before any work
    except ValueError as exc:
        _say(f"sogdd: error: {exc}")
        return None, None
    try:
        source = source_stamp(path)
        img = read_image(path, **reading)
        c = detect_corners(img, preset=args.preset, mask=mask, device=args.device, **params)
    except (ValueError, OSError, MemoryError, cv2.error) as exc:
        text = "out of memory" if isinstance(exc, MemoryError) else \
            opencv_message(exc) if isinstance(exc, cv2.error) else str(exc)
        _say(f"sogdd: error: {text if str(path) in text else f'{path}: {text}'}")
        return None, None
    if args.overlay:
        save_overlay(img, c, args.overlay, label=f"preset {args.preset}")
    rec = make_record(path, c, img.shape, args.preset, p, source, mask=mask)
    return dataclasses.replace(rec, image=name), _hint_few(img, c, p)


def _run_folder(args: argparse.Namespace, paths: list[Path], params: dict, fmt: str, reading: dict,
                mask) -> int:
    """One feature file per image in ``--out``; resumable; processes or Dask."""
    bars: list[tqdm] = []  # opened when the work starts: an error before it (a Dask connection) comes alone

    def started() -> None:
        bars.append(tqdm(total=len(paths), desc="detect", unit="img", file=sys.stderr))

    def progress(item) -> None:
        bars[0].update(1)
        if item.status == "failed":
            tqdm.write(f"sogdd: error: {item.message}", file=sys.stderr)

    try:
        items = run_batch(
            paths, args.out, fmt=fmt, preset=args.preset, params=params, resume=args.resume,
            jobs=args.jobs, scheduler=args.scheduler, progress=progress, started=started,
            read_options=reading, device=args.device, mask=mask,
        )
    except BatchInterrupted as exc:
        for bar in bars:
            bar.close()
        done = sum(i.status == "done" for i in exc.items)
        print(f"sogdd: interrupted ({signal_name(exc.signum)}); {done} finished feature file(s) kept in "
              f"{args.out}; --resume continues", file=sys.stderr)
        raise
    finally:
        for bar in bars:
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


def signal_name(signum: int) -> str:
    import signal

    return signal.Signals(signum).name


def configure(p: argparse.ArgumentParser) -> None:
    """The ``detect`` command's arguments."""
    p.description = __doc__
    p.add_argument("images", nargs="+", help="image files, folders or glob patterns")
    add_detector_arguments(p)
    add_mask_argument(p)
    p.add_argument("--device", choices=["cpu", "cuda"], default="cpu",
                   help="cuda: run on an NVIDIA GPU (pip install 'sogdd[gpu]')")
    add_read_arguments(p)
    p.add_argument("--output", "-o", default="-", help="one output file for all images, or - for stdout")
    p.add_argument("--format", choices=["csv", "json", "npz"], default=None,
                   help="csv, json or npz [default: csv; npz with --out]")
    p.add_argument("--overlay", metavar="PNG", help="write an overlay image (single image only)")
    g = p.add_argument_group("image collections")
    g.add_argument("--recursive", "-r", action="store_true", help="folders: include their sub-folders")
    g.add_argument("--out", metavar="DIR", type=output_folder, help="write one feature file per image "
                   "into DIR, named by its path relative to the inputs' common folder")
    g.add_argument("--resume", action="store_true", help="skip images whose feature file is complete and "
                   "was made from the same image file with the same parameters and sogdd version")
    g.add_argument("--jobs", type=int, default=1, help="local worker processes")
    g.add_argument("--scheduler", metavar="ADDRESS", help="run on a Dask distributed scheduler")
    p.set_defaults(func=run)
