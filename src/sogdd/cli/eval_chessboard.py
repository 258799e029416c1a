"""``sogdd eval chessboard``: dense checkerboards, rendered and real.

Rendered boards with exact inner corners (cells 3-16 px, sub-pixel phases,
rotations, PSF 0/0.7/1.5 px, noise 0/2/5 grey levels); per cell size and
detector: recall (a detection within 1 px), false detections per inner corner
(inside the inner corners' area), mean and p95 error of the corners located
within half a cell. Where the calibration photos are found (``--data`` or
``$SOGDD_DATA/calibration``) they are scored too, after removing one global
label offset per data set (reported). Protocol: :mod:`sogdd.evaluation.chessboard`.

Detectors: registry specs ``NAME[:key=value...]``, ``gftt+subpix`` (GFTT +
cornerSubPix (5,5)), ``chessboard-sb`` (findChessboardCornersSB), ``all``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ._common import output_folder

__all__ = ["register_chessboard", "run_chessboard"]


def _cells(text: str) -> list[float]:
    out = []
    for t in text.split(","):
        t = t.strip()
        if not t:
            continue
        try:
            out.append(float(t))
        except ValueError:
            raise ValueError(f"--cells: {t!r} is not a number") from None
    if not out:
        raise ValueError("--cells: no cell sizes given")
    return out


def run_chessboard(args) -> int:
    from ..evaluation.chessboard import CELLS, run_benchmark
    from ..evaluation.chessboard.calibration import calibration_root, evaluate_calibration
    from ..evaluation.chessboard.protocol import clean_json

    cells = _cells(args.cells) if args.cells else list(CELLS)
    real_root = None if args.no_real else calibration_root(args.data)
    rep = run_benchmark(args.detectors, cells=cells, quick=args.quick, seed=args.seed,
                        progress=not args.no_progress)
    obj = rep.to_json()
    real = evaluate_calibration(args.detectors, real_root) if real_root is not None else None
    obj["real"] = real
    if args.out:
        rep.write(args.out)
        from ..report.chessboard_plot import chessboard_figure  # matplotlib only when a figure is asked for

        chessboard_figure(rep, Path(args.out) / "chessboard.png")
        if real is not None:
            (Path(args.out) / "chessboard_real.json").write_text(json.dumps(clean_json(real), indent=1))
    if args.json:
        sys.stdout.write(json.dumps(clean_json(obj)) + "\n")
    else:
        sys.stdout.write(rep.table())
        if real is not None:
            sys.stdout.write("\n" + real_table(real))
    return 0


def real_table(real: dict) -> str:
    """The real check as text: offset per data set, then recall / mean error per detector."""
    lines = [f"real calibration photos; label offset removed ({real['offset_method']}):"]
    for ds, off in real["offset"].items():
        lines.append(f"  {ds}: dx = {off[0]:+.3f}, dy = {off[1]:+.3f} px")
    for ds, rows in real["datasets"].items():
        lines += ["", f"| {ds} | recall (1 px) | mean error | p95 error | false/corner | residual offset |",
                  "|---|---|---|---|---|---|"]
        for lab, r in rows.items():
            a = r["all"]
            me = "n/a" if a["mean_error"] is None else f"{a['mean_error']:.2f}"
            p9 = "n/a" if a["p95_error"] is None else f"{a['p95_error']:.2f}"
            ro = r["residual_offset"]
            ros = "n/a" if ro is None else f"({ro[0]:+.2f}, {ro[1]:+.2f})"
            lines.append(f"| {lab} | {a['recall']:.2f} | {me} | {p9} | {a['false']:.2f} | {ros} |")
    return "\n".join(lines) + "\n"


def register_chessboard(eval_subparsers) -> None:
    """Add ``chessboard`` to ``sogdd eval``."""
    c = eval_subparsers.add_parser(
        "chessboard", help="dense checkerboards: X-corners 3-16 px apart (rendered and real)",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    c.add_argument("--cells", metavar="C,D", help="cell sizes in px [3,4,5,6,8,12,16]")
    c.add_argument("--quick", action="store_true", help="a small grid (one phase, PSF 0.7, noise 2)")
    c.add_argument("--detectors", metavar="A,B,...",
                   help="detector specs, comma-separated; 'all' = registry + pipelines "
                        "[sogdd,sogdd-authors,harris,shi-tomasi,fast,gftt+subpix,chessboard-sb]")
    c.add_argument("--data", metavar="DIR", help="calibration photos [$SOGDD_DATA/calibration]")
    c.add_argument("--no-real", action="store_true", help="skip the real calibration photos")
    c.add_argument("--seed", type=int, default=0, help="phases and noise seed [0]")
    c.add_argument("--out", metavar="DIR", type=output_folder,
                   help="write chessboard.json/.md/.png (and chessboard_real.json)")
    c.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    c.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    c.set_defaults(func=run_chessboard)
