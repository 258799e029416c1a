"""What a rig calibration is worth, in plain words: each camera's verdict, the poses and their uncertainty.

The findings of :func:`rig_verdict` are ``(level, text)`` pairs, as the one-camera
:func:`sogdd.calib.verdict.verdict`'s, which gives each camera's own (prefixed by its
name); the rig adds what only a rig has: how well each camera's pose is known, how
many frames tie each camera to the reference, and how far the projection of a
distant point can be trusted over each camera's frame.
"""

from __future__ import annotations

import numpy as np

from ..uncertainty import centre_and_worst, uncertainty_finding
from ..verdict import verdict
from .result import RigCalibration, cameras_text
from .uncertainty import projection_uncertainty

__all__ = ["rig_verdict", "shared_frames", "uncertainty_summary"]

_FEW_SHARED = 5         # fewer frames seen by a camera and the reference than this tie its pose weakly
_RMS_APART = 2.0        # a camera whose RMS is this many times the rig's median RMS stands out


def shared_frames(rig: RigCalibration) -> dict[str, int]:
    """Per camera, the number of used frames in which both it and the reference camera used a board."""
    used = {c.name: np.asarray(c.calibration.view_used, bool) for c in rig.cameras}
    first = used[rig.cameras[0].name]
    return {n: int(np.sum(u & first & rig.frame_used)) for n, u in used.items()}


def uncertainty_summary(rig: RigCalibration, name: str,
                        grid: tuple[int, int] = (16, 12)) -> tuple[float, float]:
    """The 1-sigma projection uncertainty of a far point (px): at the frame's centre, and its worst.

    From :func:`~sogdd.calib.rig.uncertainty.projection_uncertainty` on a ``grid``
    of pixels; NaN where the fit gives no covariance.
    """
    try:
        pixels, sigma = projection_uncertainty(rig, name, grid=grid)
    except ValueError:
        return float("nan"), float("nan")
    return centre_and_worst(pixels, sigma, rig.camera(name).image_size)


def _pose_findings(cam, first: str, n: int) -> list[tuple[str, str]]:
    """A camera's pose against the reference ``first``: how well known, and how it is tied (``n`` frames
    seen by both)."""
    out: list[tuple[str, str]] = []
    b, sb = cam.baseline, cam.std.get("baseline", float("nan"))
    rot = cam.std.get("rotation_deg", float("nan"))
    good = np.isfinite(sb) and sb < 0.01 * b
    out.append(("ok" if good else "warn",
                f"{cam.name}: the baseline to {first} is {b:.4g} ± {sb:.2g} (the square's unit) and "
                f"the rotation {cam.rotation_deg:.2f} ± {rot:.2g} degrees"
                + ("" if good else "; the pose is loosely known: more frames seen by both cameras, "
                                   "the board tilted and spread over both frames")))
    if not np.isfinite(cam.T).all():
        out.append(("bad", f"{cam.name}: no frame in which it and another camera both used a board; "
                           "its pose is not measured"))
    elif 0 < n < _FEW_SHARED:  # n = 0: tied through the cameras between them (a ring), its std says how well
        out.append(("warn", f"{cam.name}: only {n} frame(s) seen by it and {first} together tie "
                            "its pose; take 10 or more"))
    return out


def rig_verdict(rig: RigCalibration) -> list[tuple[str, str]]:
    """Plain-words findings on a rig, each ``(level, text)`` with level "ok", "warn" or "bad".

    The rules, beyond each camera's own verdict (:func:`sogdd.calib.verdict.verdict`,
    prefixed by the camera's name; its "looks sound" line dropped where the rig
    says it, and its missing cross-validation too: a rig camera's stability is
    its standard deviations from the joint covariance):

    - each camera's pose relative to the reference: its baseline
      :math:`\\lVert T \\rVert` and rotation angle with their standard deviations
      (the square's unit and degrees), "ok" when the baseline's is under 1 % of
      it, else "warn";
    - fewer than 5 frames in which a camera and the reference both used a board
      ties its pose weakly ("warn"; none at all: "bad", the pose then rests on
      the prior of the start alone);
    - a camera whose RMS is more than twice the median of the rig's stands out
      ("warn": its focus, its blur or its model);
    - the far-point projection uncertainty (:func:`uncertainty_summary`) at each
      camera's centre and its worst over the frame; worse than 1 px somewhere is
      "warn": boards did not reach there.

    Examples
    --------
    >>> from sogdd.calib.rig.demo import demo_rig
    >>> levels = [level for level, _ in rig_verdict(demo_rig())]
    >>> set(levels) <= {"ok", "warn", "bad"}, len(levels) > 0
    (True, True)
    """
    out: list[tuple[str, str]] = []
    first = rig.cameras[0].name
    shared = shared_frames(rig)
    rms = np.array([c.calibration.rms for c in rig.cameras])
    typical = float(np.median(rms))
    for cam in rig.cameras:
        for level, text in verdict(cam.calibration):
            # the rig's covariance, not the halves' cross-validation, says how stable each camera is
            if not text.startswith(("the calibration looks sound", "no cross-validation")):
                out.append((level, f"{cam.name}: {text}"))
        if cam.name != first:
            out += _pose_findings(cam, first, shared[cam.name])
        if typical > 0 and cam.calibration.rms > _RMS_APART * typical and len(rig.cameras) > 2:
            out.append(("warn", f"{cam.name}: RMS {cam.calibration.rms:.3f} px, more than twice the rig's "
                                f"median ({typical:.3f}): check its focus, blur or lens model"))
        centre, worst = uncertainty_summary(rig, cam.name)
        if np.isfinite(worst):
            level, text = uncertainty_finding(centre, worst)
            out.append((level, f"{cam.name}: {text}"))
    if not any(level != "ok" for level, _ in out):
        out.insert(0, ("ok", f"the rig looks sound: {cameras_text(len(rig.cameras))}, "
                             f"{int(np.sum(rig.frame_used))} frames, RMS {rig.rms:.3f} px"))
    return out
