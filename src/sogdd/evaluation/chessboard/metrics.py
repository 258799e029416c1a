"""Scoring detections against a board's inner corners.

For one image with inner corners ``C`` (cell size ``c``), the scored region
``Q`` (the inner corners' rectangle grown by ``c / 2`` in board coordinates)
and detections ``D``:

* **recall** counts the inner corners with a detection within ``r = 1`` px
  (one to one, nearest pairs first: :func:`sogdd.evaluation.matching.match_points`;
  with ``c >= 3`` no detection is within 1 px of two corners, so this is also
  "has a detection within 1 px").
* **false** counts the detections inside ``Q`` that lie farther than ``r``
  from every inner corner. Outside ``Q`` (the board's outer half cell with its
  L- and T-junctions, the paper, the image border) nothing is counted: those
  are real corners or border effects that are not inner corners.
* **duplicates** counts the detections within ``r`` of an inner corner beyond
  the one that hit it: a detector that reports one X-corner as 2-4 coincident
  points is not penalised by ``false`` but shows here.
* **located** corners are matched one to one within the capture radius
  ``c / 2`` (halfway to the next corner, so the assignment is unambiguous).
  **mean_error** and **p95_error** are the mean and 95th percentile of their
  distances: how far a detector puts each corner it finds at all. A detector
  whose peaks sit 2 px off the X-corners has recall near 0 but a finite error.

Pooled over the images of one cell size: ``recall = sum(hits) / sum(|C|)``,
``false = sum(false detections) / sum(|C|)`` (false detections per inner
corner, comparable across cell sizes), ``duplicates`` likewise, ``located = sum(located) / sum(|C|)``,
and the error statistics over all located corners.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..points import match_points

__all__ = ["ImageScore", "CellScore", "score_image", "pool", "inside_convex"]

#: recall / false radius (px)
RADIUS = 1.0


def inside_convex(poly: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Which points lie inside (or on) a convex polygon given in either orientation.

    Examples
    --------
    >>> sq = np.array([[0, 0], [2, 0], [2, 2], [0, 2]], float)
    >>> inside_convex(sq, np.array([[1, 1], [3, 1], [2, 2]], float)).tolist()
    [True, False, True]
    """
    poly = np.asarray(poly, dtype=np.float64)
    pts = np.asarray(pts, dtype=np.float64).reshape(-1, 2)
    e = np.roll(poly, -1, axis=0) - poly
    rel = pts[:, None, :] - poly[None, :, :]
    cross = e[None, :, 0] * rel[..., 1] - e[None, :, 1] * rel[..., 0]
    return np.all(cross >= -1e-9, axis=1) | np.all(cross <= 1e-9, axis=1)


@dataclass(frozen=True)
class ImageScore:
    """Counts for one image (module doc)."""

    n_corners: int
    hits: int
    false: int
    located: np.ndarray  # distances of the corners located within c / 2
    duplicates: int = 0


def score_image(corners: np.ndarray, region: np.ndarray, det_xy: np.ndarray, cell: float,
                radius: float = RADIUS) -> ImageScore:
    """Score detections ``det_xy`` (N, 2) against ``corners`` (module doc).

    Examples
    --------
    >>> c = np.array([[10.0, 10.0], [15.0, 10.0]])
    >>> q = np.array([[7.5, 7.5], [17.5, 7.5], [17.5, 12.5], [7.5, 12.5]])
    >>> s = score_image(c, q, np.array([[10.5, 10.0], [13.0, 10.0], [30.0, 30.0]]), cell=5)
    >>> s.hits, s.false, s.duplicates, s.located.tolist()
    (1, 1, 0, [0.5, 2.0])
    """
    corners = np.asarray(corners, dtype=np.float64).reshape(-1, 2)
    det = np.asarray(det_xy, dtype=np.float64).reshape(-1, 2)
    det = det[np.all(np.isfinite(det), axis=1)]
    hits = len(match_points(corners, det, radius))
    near = np.zeros(len(det), dtype=bool)
    if len(det) and len(corners):
        from scipy.spatial import cKDTree

        d, _ = cKDTree(corners).query(det)
        near = d <= radius
    false = int(np.sum(~near & inside_convex(region, det))) if len(det) else 0
    loc = match_points(corners, det, cell / 2)
    return ImageScore(len(corners), hits, false, np.asarray(loc.dist, dtype=np.float64),
                      int(near.sum()) - hits)


@dataclass
class CellScore:
    """Pooled scores of one detector at one cell size."""

    n_images: int = 0
    n_corners: int = 0
    hits: int = 0
    false: int = 0
    duplicates: int = 0
    errors: list = field(default_factory=list)

    def add(self, s: ImageScore) -> None:
        self.n_images += 1
        self.n_corners += s.n_corners
        self.hits += s.hits
        self.false += s.false
        self.duplicates += s.duplicates
        self.errors.append(s.located)

    def as_dict(self) -> dict:
        """``mean_error, p95_error, recall, false`` (the JSON row) plus the raw counts.

        Errors are ``None`` when no corner was located.
        """
        err = np.concatenate(self.errors) if self.errors else np.zeros(0)
        n = max(self.n_corners, 1)
        return {
            "mean_error": float(err.mean()) if len(err) else None,
            "p95_error": float(np.percentile(err, 95)) if len(err) else None,
            "recall": self.hits / n,
            "false": self.false / n,
            "duplicates": self.duplicates / n,
            "located": len(err) / n,
            "n_images": self.n_images,
            "n_corners": self.n_corners,
            "n_false": self.false,
        }


def pool(scores: list[ImageScore]) -> dict:
    """Pool image scores into the JSON row (:meth:`CellScore.as_dict`).

    Examples
    --------
    >>> a = ImageScore(4, 3, 1, np.array([0.1, 0.2, 0.3]))
    >>> b = ImageScore(4, 1, 0, np.array([0.5]))
    >>> r = pool([a, b])
    >>> r["recall"], r["false"], round(r["mean_error"], 6)
    (0.5, 0.125, 0.275)
    """
    c = CellScore()
    for s in scores:
        c.add(s)
    return c.as_dict()

