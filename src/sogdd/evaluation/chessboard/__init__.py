"""Dense checkerboards: X-corners a few pixels apart (calibration targets, ChArUco).

* :mod:`.scenes`: rendered boards with exact sub-pixel inner corners
  (cells 3-16 px, phases, rotations, Gaussian PSF, noise).
* :mod:`.metrics`: recall at 1 px, false detections, error of located corners.
* :mod:`.rows`: the detectors (registry specs, GFTT + cornerSubPix,
  findChessboardCornersSB, any callable).
* :mod:`.protocol`: :func:`run_benchmark` and the one-detector :func:`evaluate`.
* :mod:`.calibration`: the real check on the shared calibration photos.
* :mod:`.plot`: the figure.
"""

from .protocol import ChessboardReport, evaluate, run_benchmark
from .rows import DEFAULT_ROWS, Row, make_row, make_rows
from .scenes import CELLS, BoardScene, RenderedBoard, render_board, scene_grid

__all__ = ["ChessboardReport", "evaluate", "run_benchmark", "DEFAULT_ROWS", "Row", "make_row",
           "make_rows", "CELLS", "BoardScene", "RenderedBoard", "render_board", "scene_grid"]
