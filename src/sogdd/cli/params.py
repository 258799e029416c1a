"""Detector parameters as command-line flags: every parameter, its name with dashes.

The choices of text-valued parameters come from :data:`sogdd.params.CHOICES`,
the list the parameters are validated against, so ``--help`` can never omit one.
"""

from __future__ import annotations

import argparse

import numpy as np

from ..params import CHOICES, PRESETS


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def _integer(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None


def _opt_float(text: str) -> float | None:
    if text.lower() == "none":
        return None
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number or 'none', got {text!r}") from None


def _opt_int(text: str) -> int | None:
    if text.lower() == "none":
        return None
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer or 'none', got {text!r}") from None


def _value_range(text: str) -> tuple[float, float]:
    parts = text.split(",")
    try:
        lo, hi = (float(v) for v in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected LO,HI (two numbers), got {text!r}") from None
    return lo, hi


def _subpixel(text: str) -> bool | str:
    t = text.lower()
    if t in ("on", "true", "yes", "1"):
        return True
    if t in ("off", "false", "no", "0"):
        return False
    return t  # validated by the detector


def _choices(name: str) -> str:
    return "|".join(CHOICES[name])


# flag -> (Params field, type, help, extra add_argument keywords)
_FLAGS = {
    "--sigma2": ("sigma2", _number, "Gaussian scale sigma^2 (paper: 1.2)", {}),
    "--n-orientations": ("n_orientations", _integer, "number of filter orientations K", {}),
    "--window": ("window", _integer, "window size (odd)", {}),
    "--window-shape": ("window_shape", str, "shape of the window", {"choices": CHOICES["window_shape"]}),
    "--threshold": ("threshold", _opt_float, "absolute threshold, in --threshold-units ('none' to disable)",
                    {}),
    "--threshold-units": ("threshold_units", str, "measure: on Upsilon itself; grey: in grey levels of "
                          "corner contrast (a right-angle corner of contrast T has strength T)",
                          {"choices": CHOICES["threshold_units"]}),
    "--threshold-rel": ("threshold_rel", _opt_float, "threshold as a fraction of the max response", {}),
    "--quantile": ("quantile", _opt_float, "threshold at this quantile of positive responses", {}),
    "--nms-radius": ("nms_radius", _integer, "non-maximum suppression radius (1 = 3x3)", {}),
    "--max-corners": ("max_corners", _opt_int, "keep the strongest N corners", {}),
    "--subpixel": ("subpixel", _subpixel, f"on|off|{_choices('subpixel')} (on = gradient, off = none)",
                   {"metavar": "MODE"}),
    "--x-junctions": ("x_junctions", None, "report each X-junction once, on its saddle point (needs "
                      "--threshold-units grey)", {"action": argparse.BooleanOptionalAction}),
    "--border": ("border", _integer, "exclude corners this many pixels from the edge", {}),
    "--levels": ("levels", _integer, "pyramid levels (1 = single scale)", {}),
    "--scale-factor": ("scale_factor", _number, "pyramid scale factor between levels", {}),
    "--value-range": ("value_range", _value_range,
                      "LO,HI: input values mapped onto 0-255 (e.g. 0,4095 for 12-bit data in uint16)", {}),
}


#: parameters that choose points from the map (not the map itself)
SELECTION = frozenset({"threshold", "threshold_units", "threshold_rel", "quantile", "nms_radius", "max_corners",
                       "subpixel", "x_junctions", "border", "levels", "scale_factor"})


def add_detector_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--preset`` and one flag per detector parameter."""
    parser.add_argument("--preset", default="paper", choices=sorted(PRESETS), help="parameter preset")
    group = parser.add_argument_group("detector parameters (override the preset)")
    for flag, (dest, typ, text, extra) in _FLAGS.items():
        kw = {"type": typ} if typ is not None else {}
        group.add_argument(flag, dest=dest, default=argparse.SUPPRESS, help=text, **kw, **extra)


def detector_overrides(args: argparse.Namespace) -> dict:
    """The parameters given on the command line, as keyword arguments."""
    return {dest: getattr(args, dest) for dest, *_ in _FLAGS.values() if hasattr(args, dest)}


def add_mask_argument(parser: argparse.ArgumentParser) -> None:
    """``--mask PATH``: an image file whose non-zero pixels are where corners may be."""
    parser.add_argument("--mask", metavar="PATH", help="image file of the images' size: corners only where "
                        "it is non-zero (any channel)")


def read_mask(path: str | None, reading: dict) -> np.ndarray | None:
    """The ``--mask`` file as a bool array (non-zero in any channel = keep), read like the images."""
    if path is None:
        return None
    from ..image.files import read_image

    try:
        m = read_image(path, **reading)
    except ValueError as exc:
        raise ValueError(f"--mask: {exc}") from None
    return np.any(m != 0, axis=2) if m.ndim == 3 else m != 0


def add_read_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of :func:`sogdd.read_image`: pixel limit, corrupt data, EXIF orientation."""
    g = parser.add_argument_group("reading images")
    g.add_argument("--max-pixels", type=_integer, default=None, metavar="N",
                   help="refuse images larger than N pixels, from the file header before decoding "
                   "[default: $SOGDD_MAX_PIXELS or 2^27 = 134 Mpx]")
    g.add_argument("--allow-corrupt", action="store_true",
                   help="use images whose decoder reports corrupt or truncated data")
    g.add_argument("--ignore-orientation", action="store_true",
                   help="ignore the EXIF orientation (default: applied, as cv2.imread does)")


def read_options(args: argparse.Namespace) -> dict:
    """The keyword arguments of :func:`sogdd.read_image` given on the command line (checked now)."""
    from ..image.files import max_pixels_limit

    max_pixels_limit(args.max_pixels)  # a bad limit (or $SOGDD_MAX_PIXELS) fails before any work
    return {"max_pixels": args.max_pixels, "allow_corrupt": args.allow_corrupt,
            "ignore_orientation": args.ignore_orientation}
