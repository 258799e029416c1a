"""sogdd check: do new views of a board agree with a stored calibration? pass, warn or fail, and why.

  sogdd check calib/camera.yaml 'today/*.png' --board chessboard:9x6
  sogdd check rig/rig.yaml --camera left 'today/l*.png' --camera right 'today/r*.png' --board chessboard:9x6

CAMERA_OR_RIG is what sogdd calibrate wrote: camera.yaml or camera.json (one camera), rig.yaml or
rig.json (a rig: each camera's images with --camera NAME PATTERN..., matched into frames by the
numbers in their names), or the output folder holding them. A handful of views is enough (5 take
about a second): each board's pose is fitted with the stored camera, and fx, fy, cx, cy are fitted
again with the stored distortion.
The verdict:
  fail  fx, fy, cx or cy moved beyond 5 standard deviations (the stored and the new fit's
        combined) and beyond 0.5 % of fx; or the residual RMS under the stored camera beyond
        4 times the stored RMS and 0.5 px; for a rig, a camera's pose relative to the first
        moved beyond 5 sigma and 0.3 degrees, or 1 % of the baseline
  warn  the same beyond 3 sigma and 0.2 % (2 times and 0.25 px; 0.1 degrees, 0.5 %)
  pass  otherwise
The first line printed is the verdict and its reason; --json prints one JSON object.

Exit codes: 0 pass; 4 warn; 3 fail; 2 an error (a missing or unreadable file, no board in any
view, images of another size than the camera's, a rig without --camera): one line, nothing
checked; also 2 for a pass with an image that could not be read (named on stderr, the others
checked); 130 Ctrl-C, 143 SIGTERM.
"""

from __future__ import annotations

import argparse
import math
import sys

from ._common import print_json
from .params import add_read_arguments, read_options

#: the exit code of each verdict (2 stays the code of an error; 1 is Python's own for a crash)
EXIT_CODES = {"pass": 0, "warn": 4, "fail": 3}


def configure(p: argparse.ArgumentParser) -> None:
    p.description = __doc__
    p.add_argument("stored", metavar="CAMERA_OR_RIG",
                   help="camera.yaml, camera.json, rig.yaml or rig.json, or the output folder holding one")
    p.add_argument("images", nargs="*", help="the new views: image files, folders or glob patterns (quoted); "
                   "for a rig, --camera NAME PATTERN... per camera instead")
    p.add_argument("--camera", dest="cameras", action="append", nargs="+", metavar=("NAME", "PATTERN"),
                   help="a camera of the stored rig: its name, then its new images; once per camera checked")
    p.add_argument("--board", default="chessboard:auto", metavar="SPEC",
                   help="the board: chessboard:COLSxROWS (inner corners), chessboard:auto or "
                        "charuco:COLSxROWS:MARKER:DICT, as for sogdd calibrate (a rig's needs the size)")
    p.add_argument("--jobs", type=int, default=1, help="images detected in parallel (processes)")
    p.add_argument("-r", "--recursive", action="store_true", help="folders: include their sub-folders")
    add_read_arguments(p)
    p.add_argument("--json", action="store_true", help="print the check as one JSON object")
    p.add_argument("--quiet", "--no-progress", dest="quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def _inputs(args: argparse.Namespace):
    """The images (one camera) or ``{name: patterns}`` (a rig's --camera options)."""
    if args.cameras and args.images:
        raise ValueError("give the images of one camera, or --camera NAME PATTERN... for cameras of a rig, not "
                         "both")
    if not args.cameras:
        if not args.images:
            raise ValueError("no images: give the new views to check")
        return args.images
    out: dict[str, list[str]] = {}
    for name, *patterns in args.cameras:
        if not patterns:
            raise ValueError(f"--camera {name}: give the camera's images after its name")
        if name in out:
            raise ValueError(f"--camera {name}: given twice; give each camera once, with all its images")
        out[name] = patterns
    return out


def run(args: argparse.Namespace) -> int:
    from ..calib import parse_board
    from ..calib.drift import check_calibration

    if args.jobs < 1:
        raise ValueError(f"--jobs must be >= 1, got {args.jobs}")
    try:
        spec = parse_board(args.board)
    except ValueError as exc:
        raise ValueError(f"--{exc}") from None
    given = _inputs(args)
    check = check_calibration(args.stored, given, board=spec, jobs=args.jobs, read_options=read_options(args),
                              recursive=args.recursive, progress=not args.quiet)
    for why in check.unreadable:
        print(f"sogdd: error: {why}", file=sys.stderr)
    if args.json:
        print_json(check.as_dict())
    else:
        sys.stdout.write("\n".join(summary(check)) + "\n")
    return 2 if check.verdict == "pass" and check.unreadable else EXIT_CODES[check.verdict]


def _num(v: float, fmt: str) -> str:
    return format(v, fmt) if math.isfinite(v) else "-"


def summary(check) -> list[str]:
    """The text summary of a :class:`~sogdd.calib.drift.DriftCheck`: the verdict and its reason first."""
    lines = [f"{check.verdict}: {check.reason}"]
    lines += [f"  {lv}: {t}" for lv, t in check.findings if lv != "pass" and t != check.reason]
    for c in check.cameras:
        stored_rms = f" (stored {c.stored_rms:.3f})" if math.isfinite(c.stored_rms) else ""
        lines.append(f"{c.name}: {len(c.views)} views, {c.corners} corners, residual RMS {c.rms:.3f} px"
                     f"{stored_rms}")
        lines.append(f"  {'':4}{'stored':>10}{'new':>10}{'change':>9}{'% of fx':>9}{'sigma':>7}")
        for n in ("fx", "fy", "cx", "cy"):
            new = c.fresh[n] if c.fresh else float("nan")
            lines.append(f"  {n:4}{c.stored[n]:10.2f}{_num(new, '10.2f')}{_num(c.difference[n], '+9.2f')}"
                         f"{_num(c.difference_pct[n], '+9.3f')}{_num(c.sigmas[n], '+7.1f')}")
        lines.append("  views (RMS px): " + ", ".join(f"{n} {r:.3f}" for n, r in zip(c.views, c.view_rms)))
        lines += [f"  not checked {n}: {why}" for n, why in c.skipped.items()]
    for p in check.poses:
        lines.append(f"{p.name} relative to the first camera, over {p.frames} frames: rotation "
                     f"{p.rotation_deg:.3f} degrees ({_num(p.rotation_sigmas, '.1f')} sigma), position "
                     f"{p.translation:.4g} ({_num(p.translation_pct, '.2f')} % of the baseline, "
                     f"{_num(p.translation_sigmas, '.1f')} sigma)")
    return lines
