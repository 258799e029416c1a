"""What a calibration is worth, in plain words: where its corners fell, and :func:`verdict`.

The analysis behind the report (:mod:`.report` draws it) and the command's summary.
"""

from __future__ import annotations

import weakref

import cv2
import numpy as np

from .cameras import LENSES, MODELS, lens, project
from .model_selection import fix_flags, higher_terms
from .result import Calibration
from .uncertainty import uncertainty_finding

__all__ = ["board_normals", "coverage", "cv_inside", "radial_map", "used_points", "verdict"]

# the verdict's limits, each stated where it is used
_FEW_VIEWS = 10            # fewer used views than this is "few"
_RMS_HIGH, _RMS_FAIR = 0.5, 0.2  # px
_CV_LARGE, _CV_FAIR = 2.0, 0.5   # px, mean cross-validation difference
_EDGE_BAND = 0.15          # the frame's outer band, as a fraction of each side
_EDGE_CELLS = 0.5          # share of the band's cells that should hold a corner
_TILT_MIN = 15.0           # degrees: some view should tilt the board at least this much
_GRID = (8, 6)             # coverage cells across and down
_ASPECT_REL = 0.01         # fx and fy may differ by 1 % (see verdict) ...
_ASPECT_SIGMAS = 3.0       # ... and by 3 standard deviations of their difference
_CANCEL_RATIO = 8.0        # distortion terms whose magnitudes add up to 8 times their net ...
_CANCEL_PX = 20.0          # ... and to more than 20 px at the frame's corner are fitted noise


def used_points(cal: Calibration) -> np.ndarray:
    """Every corner the calibration used, (N, 2)."""
    pts = [b.image_points[u] for b, u in zip(cal.boards, cal.corner_used) if b is not None and u is not None]
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def coverage(cal: Calibration, grid: tuple[int, int] = _GRID) -> tuple[np.ndarray, float, float]:
    """Where the used corners fell: counts per cell and the shares of cells (all, outer ring) covered.

    The frame is cut into ``grid`` = (columns, rows) equal cells; the outer ring
    is every cell on the border of that grid.

    Returns
    -------
    counts : (rows, columns) int
    covered : float
        Share of cells with at least one used corner.
    edge_covered : float
        Share of the outer ring's cells with at least one used corner.

    Examples
    --------
    >>> from sogdd.calib.demo import demo_calibration
    >>> counts, covered, edge = coverage(demo_calibration())
    >>> counts.shape, 0 < edge <= covered <= 1
    ((6, 8), True)
    """
    gx, gy = grid
    w, h = cal.image_size
    p = used_points(cal)
    cx = np.clip((p[:, 0] + 0.5) / w * gx, 0, gx - 1e-9).astype(int)
    cy = np.clip((p[:, 1] + 0.5) / h * gy, 0, gy - 1e-9).astype(int)
    counts = np.zeros((gy, gx), int)
    np.add.at(counts, (cy, cx), 1)
    ring = np.ones((gy, gx), bool)
    ring[1:-1, 1:-1] = False
    return counts, float(np.mean(counts > 0)), float(np.mean(counts[ring] > 0))


def board_normals(cal: Calibration) -> np.ndarray:
    """Each used view's board normal in the camera's frame, :math:`n = R e_z` (``R`` from its ``rvec``), (V, 3).

    Examples
    --------
    >>> from sogdd.calib.demo import demo_calibration
    >>> n = board_normals(demo_calibration())
    >>> n.shape, bool(np.allclose(np.linalg.norm(n, axis=1), 1))
    ((8, 3), True)
    """
    return np.array([cv2.Rodrigues(np.asarray(cal.rvecs[v], np.float64))[0][:, 2]
                     for v in np.flatnonzero(cal.view_used)]).reshape(-1, 3)


def _tilts(cal: Calibration) -> np.ndarray:
    """Angle (degrees) between each used view's board normal and the optical axis: a board
    parallel to the image plane maps to it by an affine map, which says nothing of the focal length."""
    return np.degrees(np.arccos(np.minimum(1.0, np.abs(board_normals(cal)[:, 2]))))


def verdict(cal: Calibration) -> list[tuple[str, str]]:
    """Plain-words findings on a calibration, each ``(level, text)`` with level "ok", "warn" or "bad".

    The rules: fewer than 10 used views is few; RMS above 0.5 px is high (0.2
    px: fair); a mean cross-validation difference inside the corners' hull
    above 2 px is large (0.5 px: fair), and outside it a difference above
    both 2 px and 3 times the largest inside is extrapolation; corners in
    fewer than half of the outer ring of an 8 x 6 grid of the frame cover
    "only the centre"; no view tilting the board 15 degrees or
    more leaves the focal length weak; any view rejected as smeared
    (:func:`~sogdd.calib.weighting.smeared_views`) and more than a fifth of the
    views rejected are reported; with ``model="auto"``, how the model was chosen (a "warn" when
    too few views left the choice to the simplest model). Without a "warn" or
    "bad" finding it opens with an "ok" saying the calibration looks sound.

    On the parameters, each "bad":

    - standard deviations that are NaN, with ``Calibration.std_note``'s
      reason (one view; a degenerate fit), or of ``fx, fy, cx, cy`` larger than
      the value. A distortion coefficient's own deviation is not judged: one
      the lens does not need (a mild lens's k3, the tangential terms) is zero
      within it, and the rational model's numerator and denominator terms
      trade off against each other (k1 = 11 +- 76 on a sound fit); the map as
      a whole is judged instead, below;
    - :math:`|f_x - f_y| > 3 \\sqrt{\\sigma_{f_x}^2 + \\sigma_{f_y}^2}` and
      :math:`|f_x - f_y| > 0.01 (f_x + f_y) / 2`: pixels are square on nearly
      every camera, and a sound fit finds them square to a fraction of a per
      cent; beyond both its uncertainty and 1 %, the views did not pin the
      aspect down (without deviations, 1 % alone decides);
    - a radial map :math:`\\rho(\\theta)` (:func:`radial_map`) that stops
      increasing along the rays out to the frame's farthest corner: inside the
      corners' largest ray it is "bad", beyond them a "warn" (pixels farther
      out have no ray);
    - for the series models (pinhole k1, k2[, k3]; fisheye k1..k4), terms
      :math:`f |k_i| x^{2i+1}` at the frame's corner (``x`` its ray: ``r`` or
      ``theta``) that add up to more than 20 px and to more than 8 times their
      sum: a lens's series is led by its first term (on the test lenses the
      terms add up to at most 5 times their net, a fisheye model fitted to a
      rectilinear lens included), while coefficients fitted to noise cancel
      (five views in the centre gave a fisheye k3 = 7.2, k4 = -21, 257 px of
      terms for 22 px of net). Raw coefficient sizes are not compared: a
      rational k4 of 5 can be a sound lens.

    The far-point projection uncertainty (:meth:`Calibration.projection_uncertainty
    <sogdd.calib.result.Calibration.projection_uncertainty>`) at the image's centre
    and its worst over a 16 x 12 grid, 1 sigma: worse than 1 px somewhere is
    "warn" (boards did not reach there), as for each camera of a rig
    (:func:`~sogdd.calib.uncertainty.uncertainty_finding`). None without a
    covariance (a rig's camera: the rig's verdict gives it).

    Examples
    --------
    >>> from sogdd.calib.demo import demo_calibration
    >>> [level for level, text in verdict(demo_calibration())][:1]
    ['warn']
    """
    out: list[tuple[str, str]] = []
    n, total = cal.n_used, len(cal.names)
    if n < _FEW_VIEWS:
        out.append(("warn", f"few views ({n} used): calibrate with 10-20 views, the board tilted "
                            "differently and placed over the whole frame"))
    if cal.rms > _RMS_HIGH:
        out.append(("bad", f"high RMS reprojection error ({cal.rms:.2f} px): check blur and focus, motion, "
                           "a board that is not flat, or a lens the model does not fit"))
    elif cal.rms > _RMS_FAIR:
        out.append(("warn", f"fair RMS reprojection error ({cal.rms:.2f} px): sharp, well-lit views do better"))
    out += _std_findings(cal)
    out += _aspect_findings(cal)
    out += _distortion_findings(cal)
    out += _coverage_findings(cal)
    out += _uncertainty_findings(cal)
    out += _cross_validation_findings(cal)
    out += _selection_findings(cal)
    smeared = sum(r.startswith("smeared") for r in cal.reasons)
    if smeared:
        out.append(("warn", f"{smeared} of {total} views rejected as smeared (views.csv): their corners far "
                            "less precise than the set's, from motion or focus blur; hold the board still"))
    missing = sum(r == "no board" for r in cal.reasons)
    unreadable = sum(r.startswith("unreadable") for r in cal.reasons)  # a rig frame whose image failed
    rejected = total - n - missing - unreadable
    if rejected > 0.2 * total:
        out.append(("warn", f"{rejected} of {total} views rejected (see views.csv): check those images"))
    if unreadable:
        out.append(("warn", f"{unreadable} of {total} views could not be read (views.csv)"))
    if missing:
        out.append(("warn" if missing > 0.2 * total else "ok", f"no board found in {missing} of {total} views"))
    if not any(level != "ok" for level, _ in out):
        cv = cal.cross_validation
        out.insert(0, ("ok", f"the calibration looks sound: {n} views, RMS {cal.rms:.3f} px"
                             + (f", halves agree to {cv_inside(cv)[0]:.2f} px" if cv is not None else "")))
    return out


def _coverage_findings(cal: Calibration) -> list[tuple[str, str]]:
    out = []
    _, covered, edge = coverage(cal)
    if edge < _EDGE_CELLS:
        out.append(("bad" if edge < 0.25 else "warn",
                    f"the corners cover only the centre ({edge:.0%} of the frame's border cells, "
                    f"{covered:.0%} of all cells): add views with the board near the edges and corners of "
                    "the frame"))
    tilts = _tilts(cal)
    if len(tilts) and tilts.max() < _TILT_MIN:
        out.append(("warn", f"the board faces the camera in every view (largest tilt {tilts.max():.0f} deg): "
                            "tilt it 20-45 deg in some views to pin down the focal length"))
    return out


def _cross_validation_findings(cal: Calibration) -> list[tuple[str, str]]:
    cv = cal.cross_validation
    if cv is None:
        note = next((n for n in cal.notes if n.startswith("no cross-validation")), "no cross-validation")
        return [("warn", note + ": the calibration's stability is unknown")]
    mean, mx = cv_inside(cv)
    out = []
    if mean > _CV_LARGE:
        out.append(("bad", f"large cross-validation difference ({mean:.2f} px mean, {mx:.2f} max where the "
                           "corners are): the two halves of the views disagree; the model may not fit the lens "
                           "(try the rational or fisheye model) or more views are needed"))
    elif mean > _CV_FAIR:
        out.append(("warn", f"fair cross-validation difference ({mean:.2f} px mean, {mx:.2f} max where the "
                            "corners are): more views, tilted and near the edges, would pin the camera down"))
    if np.isfinite(cv.max) and cv.max > max(_CV_LARGE, 3 * mx):
        out.append(("warn", f"outside the corners the halves differ by up to {cv.max:.3g} px: the model "
                            "extrapolates there; do not trust it beyond the area the boards covered"))
    return out


def _selection_findings(cal: Calibration) -> list[tuple[str, str]]:
    """How ``model="auto"`` chose the model, in plain words (nothing for a model given)."""
    sel = cal.model_selection
    if sel is None:
        return []
    coef = ", ".join(MODELS[sel.chosen])
    if not sel.folds:
        return [("warn", f"the lens model ({sel.chosen}: {coef}) was not chosen by the data: too few views to "
                         "compare the models; calibrate with more views")]
    row = sel.row(sel.chosen)
    others = [r for r in sel.table if r.model != sel.chosen]
    no_better = [r.model for r in others if r.within_noise]
    worse = [r.model for r in others if not r.within_noise and np.isfinite(r.cv_rms)]
    failed = [r.model for r in others if not np.isfinite(r.cv_rms)]
    text = (f"lens model {sel.chosen} ({coef}) chosen by {len(sel.folds)}-fold cross-validation: it predicts "
            f"the corners of views it did not see to {row.cv_rms:.3f} px RMS")
    if no_better:
        text += f"; {', '.join(no_better)} did no better beyond the noise"
    if worse:
        text += f"; {', '.join(worse)} predicted worse"
    if failed:
        text += f"; {', '.join(failed)} could not be fitted"
    return [("ok", text)]


def cv_inside(cv) -> tuple[float, float]:
    """The cross-validation's mean and max inside the corners' hull (whole image without one)."""
    if np.isfinite(cv.mean_within):
        return cv.mean_within, cv.max_within
    return cv.mean, cv.max


# --------------------------------------------------------------------------------------------------
# the parameters: their uncertainties, the aspect ratio, the distortion


def _uncertainty_findings(cal: Calibration) -> list[tuple[str, str]]:
    """The far-point projection uncertainty at the centre and at worst (none without a covariance)."""
    centre, worst = cal.projection_uncertainty()
    return [uncertainty_finding(centre, worst)] if np.isfinite(worst) else []


def _std_findings(cal: Calibration) -> list[tuple[str, str]]:
    """NaN standard deviations (with ``std_note``'s reason), and intrinsics whose deviation exceeds them."""
    if any(not np.isfinite(v) for v in cal.std.values()):
        return [("bad", "no standard deviations of the parameters: "
                        + (cal.std_note or "the fit gave none") + "; the calibration cannot be trusted")]
    values = dict(zip(("fx", "fy", "cx", "cy"), (cal.K[0, 0], cal.K[1, 1], cal.K[0, 2], cal.K[1, 2])))
    loose = [f"{n} = {v:.4g} +- {cal.std[n]:.3g}" for n, v in values.items() if cal.std[n] > abs(v)]
    if not loose:
        return []
    return [("bad", f"undetermined intrinsics ({', '.join(loose)}: a standard deviation larger than the "
                    "value): the views do not pin the camera down; add views, tilted and over the whole frame")]


def _aspect_findings(cal: Calibration) -> list[tuple[str, str]]:
    """fx and fy further apart than both 1 % and 3 standard deviations of their difference."""
    fx, fy = float(cal.K[0, 0]), float(cal.K[1, 1])
    d = abs(fx - fy)
    sd = float(np.hypot(cal.std.get("fx", np.nan), cal.std.get("fy", np.nan)))
    sd = sd if np.isfinite(sd) else 0.0  # without an uncertainty, the tolerance alone decides
    if d <= _ASPECT_REL * 0.5 * (fx + fy) or d <= _ASPECT_SIGMAS * sd:
        return []
    return [("bad", f"fx and fy differ by {d / (0.5 * (fx + fy)):.1%} ({fx:.2f} and {fy:.2f} px"
                    + (f", {d / sd:.0f} standard deviations" if sd > 0 else "")
                    + "): pixels are square on nearly every camera, so the fit is likely wrong (too few views, "
                      "or views too alike); unless the pixels really are not square, recalibrate")]


def _largest_ray(cal: Calibration) -> float:
    """The largest ``|(X/Z, Y/Z)|`` of the used corners, from the fitted poses (the undistorted rays)."""
    out = 0.0
    for v in np.flatnonzero(cal.view_used):
        R, _ = cv2.Rodrigues(cal.rvecs[v])
        X = cal.boards[v].object_points(cal.square)[cal.corner_used[v]] @ R.T + cal.tvecs[v]
        if len(X):
            out = max(out, float(np.max(np.hypot(X[:, 0], X[:, 1]) / X[:, 2])))
    return out


def _frame_radius(cal: Calibration) -> float:
    """The farthest frame corner's distorted normalised radius (where the frame ends, in the model's terms)."""
    w, h = cal.image_size
    K = cal.K
    u, v = np.array([-0.5, w - 0.5, -0.5, w - 0.5]), np.array([-0.5, -0.5, h - 0.5, h - 0.5])
    yd = (v - K[1, 2]) / K[1, 1]
    xd = (u - K[0, 2] - K[0, 1] * yd) / K[0, 0]
    return float(np.max(np.hypot(xd, yd)))


def radial_map(cal: Calibration, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distorted normalised radius of rays at angles ``theta`` from the axis, and the rational denominator.

    Pinhole and rational: :math:`\\rho = r \\frac{1 + k_1 r^2 + k_2 r^4 + k_3 r^6}{1 + k_4 r^2 + k_5 r^4
    + k_6 r^6}` with :math:`r = \\tan\\theta`; fisheye:
    :math:`\\rho = \\theta_d = \\theta (1 + k_1 \\theta^2 + \\dots + k_4 \\theta^8)` (denominator 1);
    any other registered model: :math:`\\rho = x_d` of its projection of the ray
    :math:`(\\sin\\theta, 0, \\cos\\theta)` (denominator 1).
    Tangential terms are left out: they shift points, they do not fold the map.

    Examples
    --------
    >>> from sogdd.calib.demo import demo_calibration
    >>> rho, den = radial_map(demo_calibration(), np.array([0.0, np.arctan(0.5)]))
    >>> np.round(rho, 2).tolist(), den.tolist()
    ([0.0, 0.48], [1.0, 1.0])
    """
    d = dict(zip(MODELS[cal.model], np.asarray(cal.dist, float)))
    start = lens(cal.model).start
    if start not in ("calibrateCamera", "fisheye.calibrate"):
        # any other model: the radius its projection gives a ray at theta, tangential terms left out
        dist = np.array([0.0 if n in ("p1", "p2") else v for n, v in d.items()])
        rays = np.c_[np.sin(theta), np.zeros(len(theta)), np.cos(theta)]
        return project(rays, np.eye(3), dist, cal.model)[:, 0], np.ones(len(theta))
    if start == "fisheye.calibrate":
        t2 = theta * theta
        rho = theta * (1 + t2 * (d["k1"] + t2 * (d["k2"] + t2 * (d["k3"] + t2 * d["k4"]))))
        return rho, np.ones(len(theta))
    r = np.tan(theta)
    r2 = r * r
    num = 1 + r2 * (d["k1"] + r2 * (d["k2"] + r2 * d.get("k3", 0.0)))
    den = 1 + r2 * (d.get("k4", 0.0) + r2 * (d.get("k5", 0.0) + r2 * d.get("k6", 0.0)))
    with np.errstate(divide="ignore", invalid="ignore"):
        return r * num / den, den


def _fold(cal: Calibration) -> tuple[float, float, float]:
    """``(theta_F, rho_max, rho_frame)``: the ray angle where the radial map first stops increasing (or
    reaches the frame's farthest corner, whichever comes first), the largest radius it reached before,
    and the frame's radius.

    A rational model's numerator and denominator often vanish at nearly the same ray: the map spikes
    there over a sliver of rays and goes on as before, so a step next to a sign change of the
    denominator is skipped; a pole the numerator does not cancel leaves the map negative beyond it,
    which is a fold.
    """
    theta = np.linspace(0.0, np.radians(89.9), 4000)
    rho, den = radial_map(cal, theta)
    rho_frame = _frame_radius(cal)
    pole = np.flatnonzero(np.diff(np.sign(den)) != 0)
    near = np.zeros(len(theta) - 1, bool)
    for i in pole:
        near[max(0, i - 2): i + 3] = True
    with np.errstate(invalid="ignore"):
        good = ((np.diff(rho) > 0) & (rho[1:] > 0)) | near
    bad = np.flatnonzero(~good)
    stop = int(bad[0]) if len(bad) else len(theta) - 1
    smooth = rho[: stop + 1].copy()
    smooth[1:][near[:stop]] = np.nan  # the spike's samples reach nothing
    reached = np.flatnonzero(smooth >= rho_frame)
    end = int(reached[0]) if len(reached) else stop
    return float(theta[end]), float(np.nanmax(smooth[: end + 1])), rho_frame


def _distortion_findings(cal: Calibration) -> list[tuple[str, str]]:
    """A distortion that folds over (no ray, or two, for a pixel) or whose terms cancel each other."""
    f = 0.5 * float(cal.K[0, 0] + cal.K[1, 1])
    theta_f, rho_max, rho_frame = _fold(cal)
    theta_data = float(np.arctan(_largest_ray(cal)))
    out = []
    if rho_max < rho_frame:
        where = "inside the corners" if theta_f <= theta_data else "beyond the corners"
        text = (f"the distortion folds over {rho_max * f:.0f} px from the principal point, {where} "
                f"(the frame reaches {rho_frame * f:.0f} px): pixels farther out have no ray")
        if theta_f <= theta_data:  # where the data are: no lens maps two of its rays to one pixel
            out.append(("bad", text + "; the distortion coefficients are not those of a lens (try a simpler "
                                      "model or more views)"))
        else:  # beyond them the fit is an extrapolation, sound or not where the boards were
            out.append(("warn", text + " under the model: use it only where the boards were (views with the "
                                       "board nearer the frame's corners would extend it)"))
    series = lens(cal.model).radial_terms  # (coefficient, power) of each radial term; () skips the check
    if series:
        x = theta_f if lens(cal.model).fisheye else float(np.tan(theta_f))
        terms = np.array([cal.dist[i] * x ** p for i, p in series]) * f
        total, net = float(np.sum(np.abs(terms))), abs(float(np.sum(terms)))
        if total > _CANCEL_PX and total > _CANCEL_RATIO * net:
            out.append(_cancelling_terms(cal, terms, total, net))
    return out


def _cancelling_terms(cal: Calibration, terms: np.ndarray, total: float, net: float) -> tuple[str, str]:
    """Radial terms that all but cancel at the frame's corner (``terms``: each one's move there, px),
    judged by whether held-out corners need them (:func:`~sogdd.calib.model_selection.higher_terms`):
    "bad" when those that fit noise carry half the total or more, else "ok"."""
    coef = ", ".join(f"{n} = {v:.3g}" for n, v in cal.coefficients().items() if not n.startswith("p"))
    head = (f"distortion ({coef}): at the frame's corner its terms move a point by {total:.0f} px in all but "
            f"cancel to {net:.1f} px")
    test = _higher_terms(cal)
    if test is None:  # nothing measured: the terms' sizes alone
        top = MODELS[cal.model][lens(cal.model).radial_terms[-1][0]]
        how = _how_to_fix(cal.model, (top,))
        return ("bad", f"implausible {head}, which is how coefficients fitted to noise look (too few views to "
                       "test them by cross-validation); the model diverges beyond the data; add views near the "
                       f"frame's edges and corners, or hold the top term at 0 ({how})")
    fixed = ", ".join(test.fixed)
    scores = (f"{test.fixed_rms:.3f} px RMS against {test.free_rms:.3f} px, {test.folds}-fold "
              "cross-validation over the views")
    series = [MODELS[cal.model][i] for i, _ in lens(cal.model).radial_terms]
    noise = float(sum(abs(t) for n, t in zip(series, terms) if n in test.fixed))
    if test.noise and noise < 0.5 * total:
        return ("ok", f"{head}, and they are the lens's but {fixed} ({noise:.0f} px of them), which fit noise: "
                      f"with {fixed} held at 0 the model predicts the corners of views it did not see as well "
                      f"({scores}); {fixed} may be held at 0 ({_how_to_fix(cal.model, test.fixed)})")
    if test.noise:
        return ("bad", f"implausible {head}, and they fit noise: with {fixed} held at 0 the model predicts the "
                       f"corners of views it did not see as well ({scores}); it diverges beyond the data: hold "
                       f"{fixed} at 0 ({_how_to_fix(cal.model, test.fixed)}), or add views near the frame's "
                       "edges and corners")
    return ("ok", f"{head}, but they are the lens's: without {fixed} the model predicts the corners of views "
                  f"it did not see worse ({scores})")


#: each calibration's higher_terms while it lives (the summary, the report and the files each ask for the
#: verdict; a fisheye's test costs seconds): id -> (weak reference, result)
_TESTED: dict[int, tuple[weakref.ref, object]] = {}


def _higher_terms(cal: Calibration):
    """:func:`~sogdd.calib.model_selection.higher_terms` of ``cal``'s used corners, once per calibration."""
    key = id(cal)
    hit = _TESTED.get(key)
    if hit is not None and hit[0]() is cal:
        return hit[1]
    test = higher_terms(cal.boards, cal.corner_used, np.flatnonzero(cal.view_used), cal.image_size, cal.model)
    _TESTED[key] = (weakref.ref(cal, lambda _, k=key: _TESTED.pop(k, None)), test)
    return test


def _how_to_fix(model: str, terms: tuple[str, ...]) -> str:
    """How to hold ``terms`` of ``model`` at 0, in OpenCV's flags (and the model that does it, if one does)."""
    flags = fix_flags(model, terms)[1]
    mine = set(MODELS[model])
    held = [m for m, rec in LENSES.items()
            if rec.start == lens(model).start and set(MODELS[m]) < mine and mine - set(MODELS[m]) == set(terms)]
    return f"model {held[0]}, {flags}" if held else flags
