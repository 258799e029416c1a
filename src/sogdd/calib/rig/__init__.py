"""Camera rigs: several cameras calibrated together, each camera's pose in the first one's frame.

:mod:`.result`: :class:`RigCalibration` and :class:`RigCamera`, the result with its uncertainties.
"""

from .result import RigCalibration, RigCamera

__all__ = ["RigCalibration", "RigCamera"]
