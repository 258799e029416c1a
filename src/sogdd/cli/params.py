"""Detector parameters as command-line flags: every parameter, its name with dashes."""

from __future__ import annotations

import argparse

from ..params import PRESETS


def _opt_float(text: str) -> float | None:
    return None if text.lower() == "none" else float(text)


def _opt_int(text: str) -> int | None:
    return None if text.lower() == "none" else int(text)


def _subpixel(text: str) -> bool | str:
    t = text.lower()
    if t in ("on", "true", "yes", "1"):
        return True
    if t in ("off", "false", "no", "0"):
        return False
    return t  # validated by the detector


# flag -> (Params field, type, help)
_FLAGS = {
    "--sigma2": ("sigma2", float, "Gaussian scale sigma^2 (paper: 1.2)"),
    "--n-orientations": ("n_orientations", int, "number of filter orientations K"),
    "--window": ("window", int, "window size (odd)"),
    "--window-shape": ("window_shape", str, "square or disk"),
    "--threshold": ("threshold", _opt_float, "absolute threshold on Upsilon ('none' to disable)"),
    "--threshold-rel": ("threshold_rel", _opt_float, "threshold as a fraction of the max response"),
    "--quantile": ("quantile", _opt_float, "threshold at this quantile of positive responses"),
    "--nms-radius": ("nms_radius", int, "non-maximum suppression radius (1 = 3x3)"),
    "--max-corners": ("max_corners", _opt_int, "keep the strongest N corners"),
    "--subpixel": ("subpixel", _subpixel, "on|off|gradient|quadratic (default: on = gradient)"),
    "--border": ("border", int, "exclude corners this many pixels from the edge"),
    "--levels": ("levels", int, "pyramid levels (1 = single scale)"),
    "--scale-factor": ("scale_factor", float, "pyramid scale factor between levels"),
}


def add_detector_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--preset`` and one flag per detector parameter."""
    parser.add_argument("--preset", default="paper", choices=sorted(PRESETS), help="parameter preset")
    group = parser.add_argument_group("detector parameters (override the preset)")
    for flag, (dest, typ, text) in _FLAGS.items():
        group.add_argument(flag, dest=dest, type=typ, default=argparse.SUPPRESS, help=text)


def detector_overrides(args: argparse.Namespace) -> dict:
    """The parameters given on the command line, as keyword arguments."""
    return {dest: getattr(args, dest) for dest, _, _ in _FLAGS.values() if hasattr(args, dest)}
