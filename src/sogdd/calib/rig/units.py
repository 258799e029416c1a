"""A rig fitted in squares, in the square's unit: :func:`in_unit`.

:func:`~sogdd.calib.rig.calibrate_rig` fits with the board's points in squares, :math:`X = (i, j, 0)`, so that
its intrinsics cannot depend on the unit of ``square`` (:func:`sogdd.calib.fit.check_square`); the
translations are scaled to that unit at the end, here.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .result import RigCalibration

__all__ = ["in_unit"]


def in_unit(rig: RigCalibration, s: float) -> RigCalibration:
    """A rig fitted in squares, its translations in the square's unit.

    Every translation :math:`t` (a camera's ``T``, a frame's board pose, each
    camera's own board poses) becomes :math:`s\\,t`, its standard deviation
    :math:`s\\,\\sigma_t`, and the covariance :math:`D \\Sigma D`, :math:`D` the
    diagonal matrix of 1 and of ``s`` on the translations of the layout's poses.
    """
    d = np.ones(len(rig.covariance))
    for key, sl in rig.layout.items():
        if key.endswith(".pose"):
            d[sl.start + 3:sl.stop] = s
    cams = []
    for c in rig.cameras:
        std = dict(c.std, T=[s * v for v in c.std["T"]], baseline=s * c.std["baseline"])
        cal = replace(c.calibration, tvecs=c.calibration.tvecs * s, square=s)
        cams.append(replace(c, calibration=cal, T=c.T * s, std=std))
    cov = rig.covariance * d[:, None] * d[None, :] if rig.covariance.size else rig.covariance
    return replace(rig, cameras=tuple(cams), tvecs=rig.tvecs * s, covariance=cov, square=s)
