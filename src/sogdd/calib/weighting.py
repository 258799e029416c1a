"""How much the fit trusts each corner: weights from the corners' measured precision, and smeared views.

A board's corners carry their measured 1-sigma precision
(``Board.precision``, :func:`sogdd.calib.targets.precision.with_precision`).
The set's typical corner is :func:`typical_precision`, the median over the
usable views of each view's median corner precision. The fit then minimises
whitened residuals (:func:`corner_weights`)

    sum_{v,c} w_vc^2 ||x_vc - pi(X_c)||^2,   w_vc = sigma_set / max(sigma_vc, sigma_floor),

``sigma_floor = FLOOR sigma_set``: a corner measured less precisely than the
typical one counts less (at 2x its sigma, a quarter as much in the cost), while
one measured more precisely counts at most ``1 / FLOOR^2`` times as much: what
the precision measures is the image's noise at the corner, while a corner's
error also holds what it does not measure (the lens model's misfit, the board's
print and flatness), which is no smaller at a sharper corner. Weights are
relative (the typical corner has weight 1), so that whitened residuals stay in
pixels of the typical corner.

A view whose median corner precision exceeds :data:`SMEARED` times the set's
is rejected before the fit (:func:`smeared_views`), the worst first, while more
than ``min_views`` remain: its corners would weigh at most ``1 / SMEARED^2`` (a
ninth) of a typical view's, so little is lost, and the smear that makes them
imprecise (the board or camera moving during the exposure, or out of focus)
comes with errors the precision does not measure and no weight removes: a
rolling shutter reads the moving board's rows at different times and skews its
whole image, a systematic error of the view's geometry, not noise of its
corners. Views within the rule stay, weighted corner by corner.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .targets.board import Board

__all__ = ["FLOOR", "SMEARED", "corner_weights", "smeared_reason", "smeared_views", "typical_precision",
           "view_precision"]

#: a view whose median corner precision exceeds this multiple of the set's is smeared (module doc)
SMEARED = 3.0
#: the precision below which a corner counts no more, as a fraction of the set's typical precision
FLOOR = 0.5


def view_precision(board: Board | None) -> float:
    """A view's median corner precision (px); NaN without a board or a measured precision.

    Examples
    --------
    >>> b = Board(np.zeros((3, 2)), np.array([[0, 0], [1, 0], [2, 0]]), precision=[0.1, 0.3, np.nan])
    >>> view_precision(b), view_precision(Board(np.zeros((1, 2)), np.zeros((1, 2))))
    (0.2, nan)
    """
    if board is None or board.precision is None:
        return float("nan")
    p = board.precision[np.isfinite(board.precision)]
    return float(np.median(p)) if len(p) else float("nan")


def typical_precision(boards: Sequence[Board | None], usable: np.ndarray | None = None) -> float:
    """The set's typical corner precision (px): the median over the ``usable`` views of their median.

    NaN when any usable view's board carries no precision (weights need every
    view's, or a view without one would count as if typical), or none is usable.
    A median of the views' medians counts each view once, whatever its corners,
    and a minority of smeared views does not move it.

    Examples
    --------
    >>> lab = np.array([[0, 0], [1, 0]])
    >>> bs = [Board(np.zeros((2, 2)), lab, precision=[s, s]) for s in (0.05, 0.07, 0.4)]
    >>> typical_precision(bs), typical_precision(bs + [Board(np.zeros((2, 2)), lab)])
    (0.07, nan)
    """
    ok = np.ones(len(boards), bool) if usable is None else np.asarray(usable, bool)
    per = np.array([view_precision(b) for b, u in zip(boards, ok) if u])
    if len(per) == 0 or not np.all(np.isfinite(per)) or not np.all(per > 0):
        return float("nan")
    return float(np.median(per))


def corner_weights(board: Board, typical: float) -> np.ndarray:
    """Each corner's weight in the fit, (N,): ``typical / max(sigma_k, FLOOR typical)`` (module doc).

    A corner whose precision is NaN (not measured) gets its view's median's
    weight; all ones when ``typical`` is NaN or the board carries no precision.

    Examples
    --------
    >>> lab = np.array([[0, 0], [1, 0], [2, 0], [3, 0]])
    >>> b = Board(np.zeros((4, 2)), lab, precision=[0.01, 0.1, 0.4, np.nan])
    >>> corner_weights(b, 0.1).round(3).tolist()
    [2.0, 1.0, 0.25, 1.0]
    """
    n = len(board)
    if board.precision is None or not (np.isfinite(typical) and typical > 0):
        return np.ones(n)
    sigma = board.precision.copy()
    med = view_precision(board)
    sigma[~np.isfinite(sigma)] = med if np.isfinite(med) else typical
    return typical / np.maximum(sigma, FLOOR * typical)


def smeared_reason(precision: float, typical: float) -> str:
    """The reason a smeared view is rejected, in words.

    Examples
    --------
    >>> smeared_reason(0.31, 0.074)
    "smeared: corners 4.2x less precise than the set's median (0.31 px against 0.074)"
    """
    return (f"smeared: corners {precision / typical:.1f}x less precise than the set's median "
            f"({precision:.2g} px against {typical:.2g})")


def smeared_views(boards: Sequence[Board | None], usable: np.ndarray, min_views: int) -> dict[int, str]:
    """The usable views to reject as smeared, ``{view: reason}`` (module doc).

    A view goes when its median corner precision (:func:`view_precision`)
    exceeds :data:`SMEARED` times the set's (:func:`typical_precision`), the
    worst first, while more than ``min_views`` usable views remain; nothing
    without a measured precision for every usable view.

    Examples
    --------
    >>> lab = np.array([[0, 0], [1, 0]])
    >>> bs = [Board(np.zeros((2, 2)), lab, precision=[s, s]) for s in (0.05, 0.06, 0.07, 0.31)]
    >>> smeared_views(bs, np.ones(4, bool), min_views=3)
    {3: "smeared: corners 4.8x less precise than the set's median (0.31 px against 0.065)"}
    >>> smeared_views(bs, np.ones(4, bool), min_views=4)
    {}
    """
    ok = np.asarray(usable, bool).copy()
    typical = typical_precision(boards, ok)
    if not np.isfinite(typical):
        return {}
    per = {v: view_precision(boards[v]) for v in np.flatnonzero(ok)}
    out: dict[int, str] = {}
    for v in sorted(per, key=lambda v: -per[v]):
        if per[v] <= SMEARED * typical or ok.sum() <= min_views:
            break
        ok[v] = False
        out[int(v)] = smeared_reason(per[v], typical)
    return out
