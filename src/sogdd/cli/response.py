"""sogdd response: the corner measure map of an image (eq. 25), saved as .npy."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..detector import corner_response
from ..image.files import read_image
from ._common import check_input_files, check_not_inputs
from .params import SELECTION, add_detector_arguments, add_read_arguments, detector_overrides, read_options


def run(args: argparse.Namespace) -> int:
    if not args.output.endswith(".npy"):
        raise ValueError("--output must be a .npy file")
    out = Path(args.output)
    if out.is_dir():  # found now, not after the map has been computed
        raise ValueError(f"--output {out}: is a folder; give a file name")
    if not (out.parent if str(out.parent) else Path(".")).is_dir():
        raise ValueError(f"--output {out}: folder {out.parent} does not exist")
    check_input_files([args.image])
    check_not_inputs([("--output", out)], [args.image])
    params = detector_overrides(args)
    unused = [name for name in params if name in SELECTION]
    if unused:  # they choose points; the map does not depend on them
        flags = ", ".join("--" + n.replace("_", "-") for n in unused)
        raise ValueError(f"{flags}: point selection, does not apply to sogdd response (use sogdd detect)")
    reading = read_options(args)
    resp = corner_response(read_image(args.image, **reading), preset=args.preset, device=args.device, **params)
    np.save(args.output, resp)
    print(f"wrote {args.output}: {resp.shape[0]}x{resp.shape[1]} float64, max {resp.max():.4g}")
    return 0


def configure(p: argparse.ArgumentParser) -> None:
    """The ``response`` command's arguments."""
    p.description = __doc__
    p.add_argument("image", help="image file")
    add_detector_arguments(p)
    p.add_argument("--device", choices=["cpu", "cuda"], default="cpu",
                   help="cuda: run on an NVIDIA GPU (pip install 'sogdd[gpu]')")
    add_read_arguments(p)
    p.add_argument("--output", "-o", required=True, metavar="R.npy", help="the map, float64 (H, W)")
    p.set_defaults(func=run)
