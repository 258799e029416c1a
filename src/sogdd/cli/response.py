"""sogdd response: the corner measure map of an image (eq. 25), saved as .npy."""

from __future__ import annotations

import argparse

import numpy as np

from ..detector import corner_response
from ..io import read_image
from .params import add_detector_arguments, detector_overrides


def run(args: argparse.Namespace) -> int:
    if not args.output.endswith(".npy"):
        raise ValueError("--output must be a .npy file")
    resp = corner_response(read_image(args.image), preset=args.preset, device=args.device,
                           **detector_overrides(args))
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
    p.add_argument("--output", "-o", required=True, metavar="R.npy", help="the map, float64 (H, W)")
    p.set_defaults(func=run)
