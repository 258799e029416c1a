"""``sogdd detect``: corners of one or many images, as CSV, JSON or NPZ."""

from __future__ import annotations

import argparse
import io
import json
import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

from ..corners import Corners
from ..detector import detect_corners, resolve_params
from ..io import read_image
from .overlay import save_overlay
from .params import add_detector_arguments, detector_overrides

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".ppm", ".pgm", ".pbm", ".tif", ".tiff", ".webp"}


def expand_inputs(items: list[str]) -> list[Path]:
    """Files as given; folders expand to their image files (sorted)."""
    out: list[Path] = []
    for item in items:
        p = Path(item)
        if p.is_dir():
            out.extend(sorted(q for q in p.iterdir() if q.suffix.lower() in IMAGE_SUFFIXES))
        else:
            out.append(p)
    return out


def corners_table(c: Corners) -> np.ndarray:
    return np.column_stack([c.xy, c.response, c.size]) if len(c) else np.zeros((0, 4))


def _csv(results: list[tuple[str, Corners]], with_image: bool) -> str:
    buf = io.StringIO()
    buf.write(("image," if with_image else "") + "x,y,response,size\n")
    for name, c in results:
        for x, y, r, s in corners_table(c):
            prefix = f"{name}," if with_image else ""
            buf.write(f"{prefix}{x:.4f},{y:.4f},{r:.9g},{s:.4g}\n")
    return buf.getvalue()


def _json(results: list[tuple[str, Corners]]) -> str:
    objs = [
        {
            "image": name,
            "n": len(c),
            "x": c.xy[:, 0].round(4).tolist(),
            "y": c.xy[:, 1].round(4).tolist(),
            "response": c.response.tolist(),
            "size": c.size.tolist(),
        }
        for name, c in results
    ]
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
    many = len(paths) > 1 or Path(args.images[0]).is_dir()
    results: list[tuple[str, Corners]] = []
    failures = 0
    for path in tqdm(paths, desc="detect", unit="img", file=sys.stderr, disable=not many):
        try:
            img = read_image(path)
            c = detect_corners(img, preset=args.preset, **params)
        except (ValueError, OSError) as exc:
            failures += 1
            msg = str(exc) if str(path) in str(exc) else f"{path}: {exc}"
            print(f"sogdd: error: {msg}", file=sys.stderr)
            continue
        results.append((str(path), c))
        if args.overlay and not many:
            save_overlay(img, c, args.overlay)
    if results or not failures:
        write_results(results, args.format, args.output, many)
    if many:
        print(f"sogdd: {len(results)} image(s) done, {failures} failed", file=sys.stderr)
    return 2 if failures else 0


def register(sub) -> None:
    p = sub.add_parser("detect", help="detect corners in images", description=__doc__)
    p.add_argument("images", nargs="+", help="image files or folders")
    add_detector_arguments(p)
    p.add_argument("--output", "-o", default="-", help="output file, or - for stdout (default)")
    p.add_argument("--format", choices=["csv", "json", "npz"], default="csv")
    p.add_argument("--overlay", metavar="PNG", help="write an overlay image (single image only)")
    p.set_defaults(func=run)
