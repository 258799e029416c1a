"""sogdd calibrate: a camera calibration from images of a chessboard or ChArUco board.

  sogdd calibrate 'frames/*.jpg' --board chessboard:9x6 --square 25 --out calib/

Boards (--board):
  chessboard:COLSxROWS          COLS x ROWS *inner* corners (OpenCV's patternSize:
                                a board of 10 x 7 squares is chessboard:9x6)
  chessboard:auto               a chessboard of unknown size (partial views welcome)
  charuco:COLSxROWS:MARKER:DICT a ChArUco board of COLS x ROWS *squares*, markers
                                MARKER times the square's side, OpenCV dictionary
                                DICT, e.g. charuco:5x7:0.7:DICT_5X5_100

Writes into --out: camera.yaml (OpenCV FileStorage), camera.json, views.csv (per
view: corners found, RMS, used or rejected and why), corners.csv
(view,i,j,x,y,residual,used) and report.html with its figures (report/). Corners
and views whose residuals lie far beyond the rest are rejected and reported.
An image that cannot be read is reported and the calibration uses the others
(exit code 2 all the same).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from ._common import print_json


def configure(p: argparse.ArgumentParser) -> None:
    p.description = __doc__
    p.add_argument("images", nargs="+", help="image files, folders or glob patterns (quoted)")
    p.add_argument("--board", default="chessboard:auto", metavar="SPEC",
                   help="chessboard:COLSxROWS (inner corners), chessboard:auto, or "
                        "charuco:COLSxROWS:MARKER:DICT (see above)")
    p.add_argument("--square", type=float, default=1.0, help="side of a board square, in your unit (e.g. mm)")
    p.add_argument("--model", choices=("pinhole", "rational", "fisheye"), default="pinhole",
                   help="camera model: k1,k2,p1,p2,k3; OpenCV's rational k1..k6,p1,p2; or OpenCV's "
                        "fisheye k1..k4")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (created if needed)")
    p.add_argument("--jobs", type=int, default=1, help="images detected in parallel (processes)")
    p.add_argument("--min-views", type=int, default=3, help="fewest views with a board to calibrate")
    p.add_argument("--no-reject", dest="reject", action="store_false",
                   help="keep every corner and view (by default outliers are rejected)")
    p.add_argument("--no-report", dest="report", action="store_false",
                   help="skip report.html and its figures (written by default)")
    p.add_argument("-r", "--recursive", action="store_true", help="folders: include their sub-folders")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.add_argument("--quiet", "--no-progress", dest="quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def _check_out(out: Path, given: list[str], paths: list[Path]) -> None:
    """The output folder must be neither an input file nor a folder of inputs."""
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out}: exists and is not a folder")
    real = os.path.realpath(out)
    for g in given:
        if os.path.isdir(g) and os.path.realpath(g) == real:
            raise ValueError(f"--out {out}: is an input folder; choose another folder for the outputs")
    if any(os.path.realpath(p) == real for p in paths):
        raise ValueError(f"--out {out}: is an input")
    folder = out if out.exists() else out.parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not os.access(folder, os.W_OK):
        raise ValueError(f"--out {out}: folder {folder} is not writable")


def _views(results):
    """The calibration's views: one per board (an image with several boards gives ``name#2``, ...)."""
    from ..collection import relative_names

    names = relative_names([r.path for r in results])
    boards, vnames, files = [], [], []
    for r, n in zip(results, names):
        if r.error:
            continue
        for k, b in enumerate(r.boards or (None,)):
            boards.append(b)
            vnames.append(n if k == 0 else f"{n}#{k + 1}")
            files.append(r.path)
    return boards, vnames, files


def _image_size(results) -> tuple[int, int]:
    sizes = {}
    for r in results:
        if r.size is not None:
            sizes.setdefault(r.size, r.path)
    if len(sizes) > 1:
        (s1, p1), (s2, p2) = list(sizes.items())[:2]
        raise ValueError(f"images of different sizes: {p1} is {s1[0]}x{s1[1]} but {p2} is {s2[0]}x{s2[1]}; "
                         "a calibration is for one camera at one resolution")
    return next(iter(sizes))


def _no_board(results, spec) -> None:
    """Raise the one-line error for a run where no image shows a usable board."""
    good = [r for r in results if not r.error]
    others = [r for r in good if r.other_size is not None]
    if spec.pattern is not None and others:
        s = others[0].other_size
        raise ValueError(f"--board {spec} contradicts the images: {len(others)} of {len(good)} show a board of "
                         f"{s[0]}x{s[1]} inner corners (e.g. {others[0].path}); give --board "
                         f"chessboard:{s[0]}x{s[1]} (inner corners, not squares)")
    seen = "; ".join(f"{r.path}: {r.seen or 'no board'}" for r in good[:3])
    more = f"; and {len(good) - 3} more" if len(good) > 3 else ""
    raise ValueError(f"no board ({spec}) in any of the {len(good)} image(s): {seen}{more}")


def _check_smaller(results, spec) -> None:
    """Every board a whole grid of one same size, smaller than --board: the size was miscounted
    (partial views of a larger board would not all show the same whole rectangle)."""
    from ..calib.targets.spec import grid_dims

    boards = [b for r in results for b in r.boards]
    if spec.pattern is None or len(boards) < 3 or any(b.size is not None for b in boards):
        return
    dims = {grid_dims(b) for b in boards}
    if len(dims) == 1 and None not in dims:
        w, h = dims.pop()
        raise ValueError(f"--board {spec} contradicts the images: all {len(boards)} boards show exactly "
                         f"{w}x{h} inner corners; give --board chessboard:{w}x{h} (inner corners, not squares)")


def run(args: argparse.Namespace) -> int:
    from ..calib.detection import check_detector, detect_files
    from ..calib.files import FILES, write_calibration
    from ..calib.fit import calibrate
    from ..calib.targets.spec import parse_board
    from ..collection import expand_inputs

    try:
        spec = parse_board(args.board)  # bad syntax fails before any work
    except ValueError as exc:
        raise ValueError(f"--{exc}") from None
    if not (args.square > 0 and args.square < float("inf")):
        raise ValueError(f"--square must be a positive size, got {args.square}")
    if args.jobs < 1:
        raise ValueError(f"--jobs must be >= 1, got {args.jobs}")
    if args.min_views < 1:
        raise ValueError(f"--min-views must be >= 1, got {args.min_views}")
    paths = expand_inputs(args.images, recursive=args.recursive)
    if not paths:
        raise ValueError("no input images")
    out = Path(args.out)
    _check_out(out, args.images, paths)
    check_detector(spec)
    results = detect_files(paths, spec, jobs=args.jobs, progress=not args.quiet)
    failed = [r for r in results if r.error]
    for r in failed:
        print(f"sogdd: error: {r.error}", file=sys.stderr)
    if len(failed) == len(results):
        raise ValueError(f"none of the {len(results)} image(s) could be read")
    if not any(r.boards for r in results):
        _no_board(results, spec)
    _check_smaller(results, spec)
    boards, names, files = _views(results)
    size = _image_size(results)
    cal = calibrate(boards, size, square=args.square, model=args.model, names=names, reject=args.reject,
                    min_views=args.min_views)
    written = write_calibration(cal, out, inputs=paths)
    page = None
    if args.report:
        from ..calib.report import write_report

        page = write_report(cal, out, images=files, title=f"Camera calibration: {len(files)} views, {spec}")
    _summary(args, cal, out, [FILES[0]] + ([page.name] if page else []), written, failed)
    return 2 if failed else 0


def _summary(args, cal, out: Path, main_files: list[str], written, failed) -> None:
    from ..calib.report import verdict

    K = cal.K
    cv = cal.cross_validation
    findings = verdict(cal)
    if args.json:
        print_json({"out": str(out), "files": sorted(str(p) for p in written.values()), "model": cal.model,
                    "fx": K[0, 0], "fy": K[1, 1], "cx": K[0, 2], "cy": K[1, 2], "dist": cal.dist.tolist(),
                    "rms": cal.rms, "views_used": cal.n_used, "views": len(cal.names),
                    "cross_validation_mean": None if cv is None else cv.mean,
                    "cross_validation_mean_within": None if cv is None else cv.mean_within,
                    "verdict": [{"level": lv, "text": t} for lv, t in findings],
                    "rejected": {n: r for n, r, u in zip(cal.names, cal.reasons, cal.view_used) if not u},
                    "unreadable": [r.path for r in failed]})
        return
    lines = [f"{cal.model}: fx {K[0, 0]:.2f} fy {K[1, 1]:.2f} cx {K[0, 2]:.2f} cy {K[1, 2]:.2f}, "
             f"RMS {cal.rms:.4f} px, {cal.n_used} of {len(cal.names)} views used"
             + (f", cross-validation {cv.mean_within:.3f} px inside the corners ({cv.mean:.3g} over the frame)"
                if cv is not None else "")]
    lines += [f"  {lv}: {t}" for lv, t in findings]
    rejected = [(n, r) for n, r, u in zip(cal.names, cal.reasons, cal.view_used) if not u]
    lines += [f"  rejected {n}: {r}" for n, r in rejected[:5]]
    if len(rejected) > 5:
        lines.append(f"  ... and {len(rejected) - 5} more rejected views (views.csv)")
    n_bad = sum(len(d) for d, u in zip(cal.corner_reasons, cal.view_used) if u)
    if n_bad:
        lines.append(f"  {n_bad} corner(s) rejected in the used views (corners.csv, used = 0)")
    lines.append(f"written to {out}/: {', '.join(main_files)} ...")
    sys.stdout.write("\n".join(lines) + "\n")
