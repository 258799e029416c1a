"""sogdd calibrate: a camera calibration from images or a video of a chessboard, ChArUco, AprilGrid; or a rig's.

  sogdd calibrate 'frames/*.jpg' --board chessboard:9x6 --square 25 --out calib/
  sogdd calibrate --camera left 'left/*.jpg' --camera right 'right/*.jpg' --board chessboard:9x6 --out rig/
  sogdd calibrate take1.mp4 --board chessboard:9x6 --square 25 --max-views 40 --out calib/
  sogdd calibrate --camera left left.mp4 --camera right right.mp4 --board chessboard:9x6 --out rig/

Boards (--board):
  chessboard:COLSxROWS          COLS x ROWS *inner* corners (OpenCV's patternSize:
                                a board of 10 x 7 squares is chessboard:9x6)
  chessboard:auto               a chessboard of unknown size (partial views welcome)
  charuco:COLSxROWS:MARKER:DICT a ChArUco board of COLS x ROWS *squares*, markers
                                MARKER times the square's side, OpenCV dictionary
                                DICT, e.g. charuco:5x7:0.7:DICT_5X5_100
  aprilgrid:COLSxROWS:SIZE:SPACING  Kalibr's AprilGrid: COLS x ROWS 36h11 tags of side
                                SIZE (the poses' unit), SPACING the gap over the side,
                                e.g. aprilgrid:6x6:0.088:0.3

An image is one view: the board that matches --board best (complete, then most
corners, then largest cells). Other boards in it are rows of views.csv with
status "ignored", their corners and cell size in the reason; --boards all makes
each of them a view (NAME#2, ...) for a scene built with several targets. A
board whose cells are under a third of the image's largest board's (a screen, a
reflection or a pattern in the background) is never a view.

Writes into --out: camera.yaml (OpenCV FileStorage), camera.json, views.csv (per
input: corners found, RMS, used or not and why; an image that could not be read
too), corners.csv (view,i,j,x,y,residual,used,sigma_px) and report.html with its figures
(report/). Corners and views whose residuals lie far beyond the rest are
rejected and reported. The folder ends complete or as it was: a new or empty
folder, or a previous output of sogdd calibrate, which is replaced whole; a
folder holding other files, or any input, is refused.
An image that cannot be read is reported and the calibration uses the others
(exit code 2 all the same); a file name that is not valid UTF-8 is refused before
any work. Exit codes: 0 done; 2 an error (nothing written) or an unreadable input;
3 the verdict is bad (the outputs written all the same; --json: verdict_level);
130 Ctrl-C and 143 SIGTERM, --out left as it was.

A video (.mp4, .avi, .mov, .mkv, ...: one file, alone) is read with OpenCV, every
--video-step-th frame searched, and at most --max-views frames chosen as views:
sharp (corner precision within 2x of the video's best), at a pose far from every
frame taken, the most new coverage of the frame first; views.csv names each
frame (take1.mp4#frame000123) and its reasons. A rig of videos: --camera NAME
VIDEO once per camera, one video each (below).

A rig (one or more cameras): --camera NAME PATTERN... once per camera instead
of the images; how its frames are matched and what it writes is below.
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from ..calib.cameras import LENSES
from ._common import print_json, run_calibration, verdict_level
from .calibrate_rig import RIG_HELP, RIG_WORDS, add_rig_arguments, camera_inputs, rig_summary
from .params import add_read_arguments, read_options

if TYPE_CHECKING:  # the command imports the library when it runs (sogdd --help stays fast)
    from ..calib import BoardSpec

#: the library's words for its parameters (:class:`sogdd.calib.session.ParameterError`), as this command
#: names them: its errors say what the library's say, with the flags
WORDS = {"board": "--board", "boards": "--boards", "square": "--square", "jobs": "--jobs",
         "min_views": "--min-views", "max_views": "--max-views", "video_step": "--video-step",
         "allow_missing": "--allow-missing-frames", **RIG_WORDS}


def configure(p: argparse.ArgumentParser) -> None:
    p.description = __doc__ + "\n" + RIG_HELP
    p.add_argument("images", nargs="*", help="image files, folders or glob patterns (quoted); or, for a rig, "
                   "--camera NAME PATTERN... per camera")
    p.add_argument("--board", default="chessboard:auto", metavar="SPEC",
                   help="chessboard:COLSxROWS (inner corners), chessboard:auto, "
                        "charuco:COLSxROWS:MARKER:DICT or aprilgrid:COLSxROWS:SIZE:SPACING (see above)")
    p.add_argument("--boards", choices=("best", "all"), default="best",
                   help="boards per image: the best match of --board (the others ignored, in views.csv), or "
                        "all of them (several targets; small copies of the board are still ignored)")
    p.add_argument("--square", type=float, default=1.0, help="side of a board square, in your unit (e.g. mm)")
    p.add_argument("--model", choices=("auto", *LENSES), default="auto",
                   help="camera model: auto (chosen by cross-validation over the views: the simplest that "
                        "predicts unseen views as well as the best; the table in camera.json and the report); "
                        + "; ".join(f"{n}: {m.summary} ({', '.join(m.params)})" for n, m in LENSES.items()))
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (created if needed; a previous "
                   "output is replaced)")
    p.add_argument("--jobs", type=int, default=1, help="images detected in parallel (processes)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="detect on a Dask distributed scheduler "
                   "(pip install 'sogdd[distributed]')")
    p.add_argument("--min-views", type=int, default=3, help="fewest views with a board to calibrate")
    p.add_argument("--max-views", type=int, default=40, help="a video: most frames taken as views (default 40)")
    p.add_argument("--video-step", type=int, default=None, metavar="K",
                   help="a video: search every K-th frame (default: at most 400 frames searched)")
    p.add_argument("--no-reject", dest="reject", action="store_false",
                   help="keep every corner and view (by default outliers are rejected)")
    p.add_argument("--no-report", dest="report", action="store_false",
                   help="skip report.html and its figures (written by default)")
    p.add_argument("-r", "--recursive", action="store_true", help="folders: include their sub-folders")
    add_rig_arguments(p)
    add_read_arguments(p)
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.add_argument("--quiet", "--no-progress", dest="quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def _board(text: str) -> BoardSpec:
    """``--board``'s specification, parsed (bad syntax fails before any work, naming the flag)."""
    from ..calib import parse_board

    try:
        return parse_board(text)
    except ValueError as exc:
        raise ValueError(f"--{exc}") from None


def run(args: argparse.Namespace) -> int:
    from ..calib.session import ParameterError

    try:
        return _run(args)
    except ParameterError as exc:  # the library's checks, in this command's words
        raise ValueError(exc.worded(**WORDS)) from None


def _run(args: argparse.Namespace) -> int:
    from ..calib.inputs import calibrate_inputs_into
    from ..calib.rig.session import RigImageCalibration

    spec, reading = _board(args.board), read_options(args)
    if args.cameras and args.images:
        raise ValueError("give the images of one camera, or --camera NAME PATTERN... for each camera of a rig, "
                         "not both")
    if not args.cameras and not args.images:
        raise ValueError("no images: give the image files, or --camera NAME PATTERN... per camera of a rig")
    inputs = camera_inputs(args.cameras) if args.cameras else args.images
    return run_calibration(
        args.out,
        lambda: calibrate_inputs_into(inputs, args.out, spec, boards=args.boards, square=args.square,
                                      model=args.model, jobs=args.jobs, scheduler=args.scheduler,
                                      min_views=args.min_views, reject=args.reject, recursive=args.recursive,
                                      allow_missing=args.allow_missing_frames, read_options=reading,
                                      max_views=args.max_views, video_step=args.video_step, report=args.report,
                                      progress=not args.quiet),
        lambda result, written: (rig_summary if isinstance(result, RigImageCalibration) else _summary)(
            args, result, written))


def _summary(args: argparse.Namespace, result, written: dict) -> list[tuple[str, str]]:
    """Print the summary (text, or one JSON object); return the verdict's findings."""
    from ..calib.files import selection_dict
    from ..calib.guidance import guidance
    from ..calib.verdict import verdict

    cal = result.calibration
    K = cal.K
    cv = cal.cross_validation
    findings = verdict(cal)
    not_used = [(v.name, v.status, v.reason) for v in result.views if v.status != "used"]
    if args.json:
        print_json({"out": args.out, "files": sorted(str(p) for p in written.values()), "model": cal.model,
                    "fx": K[0, 0], "fy": K[1, 1], "cx": K[0, 2], "cy": K[1, 2], "dist": cal.dist.tolist(),
                    "rms": cal.rms, "views_used": cal.n_used, "views": len(cal.names),
                    "pixel_grid": cal.pixel_grid,
                    "cross_validation_mean": None if cv is None else cv.mean,
                    "cross_validation_mean_within": None if cv is None else cv.mean_within,
                    "model_selection": selection_dict(cal.model_selection),
                    "verdict": [{"level": lv, "text": t} for lv, t in findings],
                    "verdict_level": verdict_level(findings),
                    "guidance": guidance(cal).as_dict(),
                    "rejected": {n: r for n, s, r in not_used if s == "rejected"},
                    "not_used": [{"view": n, "status": s, "reason": r} for n, s, r in not_used],
                    "unreadable": [v.file for v in result.unreadable]})
        return findings
    lines = [f"{cal.model}: fx {K[0, 0]:.2f} fy {K[1, 1]:.2f} cx {K[0, 2]:.2f} cy {K[1, 2]:.2f}, "
             f"RMS {cal.rms:.4f} px, {cal.n_used} of {len(cal.names)} views used"
             + (f", cross-validation {cv.mean_within:.3f} px inside the corners ({cv.mean:.3g} over the frame)"
                if cv is not None else "")]
    if cal.pixel_grid == "sensor":  # the images' EXIF orientations differed: the note says which
        lines += [f"  note: {n}" for n in cal.notes if n.startswith("calibrated on the sensor's pixel grid")]
    sel = cal.model_selection
    if sel is not None and sel.folds:
        lines.append("  models (cross-validated RMS px): " + ", ".join(
            f"{r.model} {r.cv_rms:.4f}" + (" (chosen)" if r.model == sel.chosen else "") for r in sel.table))
    lines += [f"  {lv}: {t}" for lv, t in findings]
    lines += [f"  {s} {n}: {r}" for n, s, r in not_used[:5]]
    if len(not_used) > 5:
        lines.append(f"  ... and {len(not_used) - 5} more views not used (views.csv)")
    n_bad = sum(len(d) for d, u in zip(cal.corner_reasons, cal.view_used) if u)
    if n_bad:
        lines.append(f"  {n_bad} corner(s) rejected in the used views (corners.csv, used = 0)")
    main = [n for n in ("camera.yaml", "report.html") if n in written]
    lines.append(f"written to {args.out}/: {', '.join(main)} ...")
    sys.stdout.write("\n".join(lines) + "\n")
    return findings
