"""Calibration-target evaluation: rendered views through an exactly known camera, and the protocol.

:mod:`.render` is the renderer (camera model, chessboard target, exact ground truth, random poses).
"""

from .render import (
                     Camera,
                     ChessboardTarget,
                     RenderedView,
                     add_noise,
                     random_sequence,
                     render_charuco,
                     render_scene,
                     render_view,
)

__all__ = ["Camera", "ChessboardTarget", "RenderedView", "add_noise", "random_sequence", "render_charuco",
           "render_scene", "render_view"]
