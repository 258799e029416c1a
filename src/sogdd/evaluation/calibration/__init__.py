"""Calibration-target evaluation: rendered views through an exactly known camera, and the protocol.

:mod:`.render` is the renderer (camera model, chessboard target, exact ground truth, random poses).
"""

from .render import Camera, ChessboardTarget, RenderedView, random_sequence, render_charuco, render_view

__all__ = ["Camera", "ChessboardTarget", "RenderedView", "random_sequence", "render_charuco", "render_view"]
