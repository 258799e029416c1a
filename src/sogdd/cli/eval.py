"""sogdd eval: the paper's evaluations on any detector of the registry.

Corner level: gt (Table 1's protocol), repeatability (Fig. 9's), resolution
(adjacent corners). Downstream: matching (Fig. 10's MMA), sfm (Table 2).
Detectors are specs NAME or NAME:key=value (sogdd:subpixel=false), space- or
comma-separated; 'all' means every registry name. Data paths default to
$SOGDD_DATA or ../shared/data.
"""

from __future__ import annotations

import argparse
import sys

from . import eval_corners, eval_downstream
from .eval_calibration import register_calibration
from .eval_chessboard import register_chessboard

__all__ = ["configure"]


def configure(p: argparse.ArgumentParser) -> None:
    """The ``eval`` command: one sub-command per evaluation."""
    p.description = __doc__
    sub = p.add_subparsers(dest="eval_command", metavar="EVALUATION")
    p.set_defaults(func=lambda _args: (p.print_help(sys.stderr), 2)[1])
    eval_corners.register(sub)
    eval_downstream.register(sub)
    register_chessboard(sub)
    register_calibration(sub)
