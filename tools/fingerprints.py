"""Fingerprint the detector's output on every shared 8-bit image, to compare two versions bit for bit.

For each image file under the data folder (``$SOGDD_DATA`` or ``--data``) that
:func:`sogdd.read_image` decodes to 8-bit grey, and each preset, the script runs
:func:`sogdd.detect_corners` and hashes the raw bytes of its four columns
(``xy``, ``response``, ``size``, ``level``, in that order) with SHA-256. A
refactoring that claims "same output" must give the same JSON; ``--compare``
lists the (image, preset) pairs whose hash or count differ.

Run from the repository root (the ``sogdd`` imported is the one installed in the
interpreter that runs the script; the JSON records its path)::

    python tools/fingerprints.py --out fp_new.json
    python tools/fingerprints.py --compare fp_old.json fp_new.json
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

PRESETS = ("paper", "authors", "hr")
SUFFIXES = {".png", ".jpg", ".jpeg", ".ppm", ".pgm", ".bmp", ".tif", ".tiff", ".gif"}


def image_files(root: Path) -> list[Path]:
    """Every file under ``root`` with an image suffix, sorted by path."""
    return sorted(p for p in root.rglob("*") if p.is_file() and p.suffix.lower() in SUFFIXES)


def fingerprint(corners) -> dict:
    """The count and the SHA-256 of the corners' columns' bytes."""
    h = hashlib.sha256()
    for col, dtype in ((corners.xy, np.float64), (corners.response, np.float64),
                       (corners.size, np.float64), (corners.level, np.int64)):
        h.update(np.ascontiguousarray(col, dtype=dtype).tobytes())
    return {"n": len(corners), "sha256": h.hexdigest()}


def run(root: Path, presets: tuple[str, ...]) -> dict:
    import sogdd

    out: dict = {"sogdd": str(Path(sogdd.__file__).resolve().parent), "presets": list(presets), "images": {}}
    t0 = time.perf_counter()
    for path in image_files(root):
        img = sogdd.read_image(path)
        if img.dtype != np.uint8:
            continue
        rel = path.relative_to(root).as_posix()
        out["images"][rel] = {p: fingerprint(sogdd.detect_corners(img, preset=p)) for p in presets}
        print(f"{time.perf_counter() - t0:7.1f} s  {rel}", file=sys.stderr, flush=True)
    out["seconds"] = round(time.perf_counter() - t0, 1)
    return out


def compare(a: dict, b: dict) -> list[str]:
    """One line per (image, preset) whose fingerprint differs or is missing on one side."""
    lines = []
    for name in sorted(set(a["images"]) | set(b["images"])):
        fa, fb = a["images"].get(name), b["images"].get(name)
        if fa is None or fb is None:
            lines.append(f"{name}: only in {'the second' if fa is None else 'the first'}")
            continue
        for p in sorted(set(fa) | set(fb)):
            if fa.get(p) != fb.get(p):
                na, nb = (f.get(p, {}).get("n") for f in (fa, fb))
                lines.append(f"{name} [{p}]: n {na} -> {nb}, hash differs")
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=os.environ.get("SOGDD_DATA"), help="the shared data folder")
    ap.add_argument("--presets", default=",".join(PRESETS))
    ap.add_argument("--out", type=Path, help="write the fingerprints here (JSON)")
    ap.add_argument("--compare", nargs=2, type=Path, metavar=("OLD", "NEW"), help="compare two JSON files")
    args = ap.parse_args(argv)
    if args.compare:
        a, b = (json.loads(p.read_text()) for p in args.compare)
        diff = compare(a, b)
        print("\n".join(diff) if diff else f"identical: {len(a['images'])} images x {a['presets']}")
        return 1 if diff else 0
    if not args.data or not Path(args.data).is_dir():
        ap.error("give --data or set SOGDD_DATA to the shared data folder")
    if args.out is None:
        ap.error("give --out")
    res = run(Path(args.data), tuple(args.presets.split(",")))
    args.out.write_text(json.dumps(res, indent=1) + "\n")
    print(f"{len(res['images'])} images x {len(res['presets'])} presets in {res['seconds']} s -> {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
