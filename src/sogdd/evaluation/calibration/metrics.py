"""Scores of one detection against the rendered truth: labels, positions, recall.

Label alignment
---------------
A detector's labels may differ from the truth's by one of the square lattice's
8 symmetries (a board of square cells reads the same turned by 90 degrees or
mirrored) and a translation (a partial board's labels are relative). Each
detected corner is paired with its nearest true corner when that lies within
half the local cell; the view's alignment ``L_true = A L_det + o`` (``A`` one of
the 8 signed permutation matrices, ``o`` an integer offset) is the one that
most pairs agree with. Under it every detected corner has an aligned label.

- A **wrong label** is a detected corner whose aligned label is not a true
  corner, or whose true corner lies half a cell or more away (it sits on
  another corner, or on none).
- The **corner error** of every other detected corner is its distance to the
  true corner of its aligned label.
- **Recall** counts the true corners inside the frame that a correctly
  labelled corner stands for.
- A view is **flipped** when the best alignment is a reflection (``det A = -1``):
  its labels are left-handed against the truth's.

Points-only methods (no labels) are paired one-to-one with the nearest true
corner inside the frame (``inside``) within half the local cell; their unpaired
points are not scored.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["ViewScore", "score_view", "local_cell", "align_labels", "error_stats", "SYMMETRIES"]

#: the 8 symmetries of the square lattice, as 2 x 2 integer matrices acting on (i, j)
SYMMETRIES: tuple[np.ndarray, ...] = tuple(
    np.array(m, dtype=np.int64) for m in (
        [[1, 0], [0, 1]], [[0, -1], [1, 0]], [[-1, 0], [0, -1]], [[0, 1], [-1, 0]],
        [[1, 0], [0, -1]], [[-1, 0], [0, 1]], [[0, 1], [1, 0]], [[0, -1], [-1, 0]]))


@dataclass
class ViewScore:
    """One view's score for one method (see the module doc)."""

    found: bool
    n_inside: int
    n_detected: int = 0
    n_correct: int = 0
    n_wrong: int = 0
    recalled: int = 0
    flipped: bool = False
    errors: np.ndarray = field(default_factory=lambda: np.zeros(0))


def local_cell(corners: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Each true corner's local cell size (px): the mean distance to its lattice neighbours in the frame.

    Examples
    --------
    >>> xy = np.array([[0.0, 0], [10, 0], [0, 12], [10, 12]])
    >>> local_cell(xy, np.array([[0, 0], [1, 0], [0, 1], [1, 1]])).tolist()
    [11.0, 11.0, 11.0, 11.0]
    """
    index = {tuple(lab): k for k, lab in enumerate(labels.tolist())}
    out = np.full(len(corners), np.nan)
    for k, (i, j) in enumerate(labels.tolist()):
        d = [np.linalg.norm(corners[n] - corners[k]) for n in
             (index.get((i + di, j + dj)) for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1))) if n is not None]
        d = [v for v in d if np.isfinite(v)]
        if d:
            out[k] = float(np.mean(d))
    fill = np.nanmedian(out) if np.isfinite(out).any() else 1.0
    return np.where(np.isfinite(out), out, fill)


def align_labels(det_labels: np.ndarray, true_labels: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """The alignment ``(A, o)`` that most pairs ``(det_labels[k], true_labels[k])`` agree with, and how many do.

    Examples
    --------
    >>> d = np.array([[0, 0], [1, 0], [0, 1]])
    >>> A, o, n = align_labels(d, d[:, ::-1] + 5)  # transposed and shifted
    >>> A.tolist(), o.tolist(), n
    ([[0, 1], [1, 0]], [5, 5], 3)
    """
    best = (SYMMETRIES[0], np.zeros(2, dtype=np.int64), 0)
    for A in SYMMETRIES:
        off = true_labels - det_labels @ A.T
        if len(off) == 0:
            continue
        vals, counts = np.unique(off, axis=0, return_counts=True)
        k = int(np.argmax(counts))
        if counts[k] > best[2]:
            best = (A, vals[k].astype(np.int64), int(counts[k]))
    return best


def score_view(points: np.ndarray, labels: np.ndarray | None, truth: np.ndarray, true_labels: np.ndarray,
               inside: np.ndarray) -> ViewScore:
    """Score one detection (module doc). ``labels`` None: a points-only method.

    Examples
    --------
    >>> truth = np.array([[0.0, 0], [10, 0], [0, 10], [10, 10]])
    >>> tl = np.array([[0, 0], [1, 0], [0, 1], [1, 1]])
    >>> s = score_view(truth + 0.1, tl[:, ::-1], truth, tl, np.ones(4, bool))
    >>> s.n_correct, s.n_wrong, s.flipped, round(float(s.errors.mean()), 4)
    (4, 0, True, 0.1414)
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    finite = np.all(np.isfinite(truth), axis=1)
    n_inside = int(inside.sum())
    if len(points) == 0 or not finite.any():
        return ViewScore(found=False, n_inside=n_inside)
    cell = local_cell(truth, true_labels)
    if labels is None:  # points only: stray points near the frame's edge would pair with cut corners
        finite = finite & inside
        if not finite.any():
            return ViewScore(found=False, n_inside=n_inside, n_detected=len(points))
    idx_f = np.flatnonzero(finite)
    dist, near = cKDTree(truth[idx_f]).query(points)
    near = idx_f[near]
    close = dist < 0.5 * cell[near]
    if labels is None:
        return _score_points(dist, near, close, inside, n_inside)
    labels = np.asarray(labels, dtype=np.int64).reshape(-1, 2)
    A, o, _ = align_labels(labels[close], true_labels[near[close]])
    aligned = labels @ A.T + o
    index = {tuple(lab): k for k, lab in enumerate(true_labels.tolist())}
    target = np.array([index.get(tuple(lab), -1) for lab in aligned.tolist()], dtype=np.int64)
    ok = target >= 0
    ok[ok] = finite[target[ok]]
    err = np.full(len(points), np.inf)
    err[ok] = np.linalg.norm(points[ok] - truth[target[ok]], axis=1)
    correct = ok & (err < 0.5 * cell[np.where(ok, target, 0)])
    recalled = len(set(target[correct & inside[np.where(ok, target, 0)]].tolist()))
    return ViewScore(found=True, n_inside=n_inside, n_detected=len(points), n_correct=int(correct.sum()),
                     n_wrong=int((~correct).sum()), recalled=recalled,
                     flipped=bool(round(np.linalg.det(A)) < 0), errors=err[correct])


def _score_points(dist, near, close, inside, n_inside) -> ViewScore:
    # one-to-one: of several points on one true corner, the nearest is kept
    order = np.argsort(dist)
    seen: set[int] = set()
    keep = np.zeros(len(dist), dtype=bool)
    for k in order:
        if close[k] and int(near[k]) not in seen:
            seen.add(int(near[k]))
            keep[k] = True
    recalled = int(np.sum(inside[near[keep]]))
    return ViewScore(found=False, n_inside=n_inside, n_detected=len(dist), n_correct=int(keep.sum()),
                     recalled=recalled, errors=dist[keep])


def error_stats(errors: np.ndarray) -> dict[str, float]:
    """Mean, RMS, 95th percentile and maximum of corner errors (px), and their count.

    Examples
    --------
    >>> error_stats(np.array([0.0, 0.1, 0.2]))["rms"]
    0.1291
    """
    e = np.asarray(errors, dtype=np.float64)
    if len(e) == 0:
        return {"n": 0, "mean": float("nan"), "rms": float("nan"), "p95": float("nan"), "max": float("nan")}
    rms = float(np.sqrt(np.mean(e * e)))
    return {"n": int(len(e)), "mean": round(float(e.mean()), 5), "rms": round(rms, 5),
            "p95": round(float(np.percentile(e, 95)), 4), "max": round(float(e.max()), 4)}
