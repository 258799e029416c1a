"""A feature budget spread over the image: adaptive non-maximal suppression and bucketing.

Keeping the ``n`` strongest corners of a photo puts most of them where the
contrast is highest (a few textured patches); structure from motion and
homography estimation reward points spread over the whole image. Two classic
rules choose ``n`` points that are both strong and spread:

* :func:`anms_order`: adaptive non-maximal suppression (Brown, Szeliski and
  Winder, CVPR 2005). Each point's suppression radius is the distance to the
  nearest point that is clearly stronger (``response_j * robust > response_i``);
  the ``n`` points with the largest radii are kept.
* :func:`bucket_order`: a grid of cells, each cell given an equal share of the
  budget filled with its strongest points; the share a sparse cell cannot use
  goes to the strongest points left anywhere.

Both return indices into the input; the caller subsets its ``Corners``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["anms_order", "bucket_order", "suppression_radii"]


def suppression_radii(xy: np.ndarray, response: np.ndarray, robust: float = 0.9, k: int = 16) -> np.ndarray:
    """Brown et al.'s suppression radius of every point (``inf`` for the strongest).

    ``r_i = min |x_i - x_j|`` over the points with ``robust * response_j > response_i``.
    The ``k`` nearest neighbours (a k-d tree) answer most points; the few whose
    ``k`` neighbours hold no clearly stronger point are answered exactly against
    every stronger point.

    Examples
    --------
    >>> xy = np.array([[0.0, 0], [1, 0], [10, 0]])
    >>> suppression_radii(xy, np.array([3.0, 1.0, 2.0])).tolist()
    [inf, 1.0, 10.0]
    """
    from scipy.spatial import cKDTree

    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    resp = np.nan_to_num(np.asarray(response, dtype=np.float64), nan=-np.inf)
    n = len(xy)
    radii = np.full(n, np.inf)
    if n < 2:
        return radii
    kk = min(k + 1, n)
    dist, idx = cKDTree(xy).query(xy, kk)
    stronger = robust * resp[idx] > resp[:, None]
    has = stronger.any(axis=1)
    first = np.argmax(stronger, axis=1)  # neighbours come nearest first
    radii[has] = dist[has, first[has]]
    rest = np.flatnonzero(~has)
    for i in rest:  # rare: no clearly stronger point among the k nearest
        s = robust * resp > resp[i]
        if s.any():
            radii[i] = float(np.sqrt(np.min(np.sum((xy[s] - xy[i]) ** 2, axis=1))))
    return radii


def anms_order(xy: np.ndarray, response: np.ndarray, n: int, robust: float = 0.9) -> np.ndarray:
    """Indices of the ``n`` points with the largest suppression radii.

    Ties (the infinite radii of the points within ``1 - robust`` of the
    strongest) are ordered by the distance to the nearest stronger point, then
    by strength.

    Examples
    --------
    >>> xy = np.array([[0.0, 0], [1, 0], [10, 0], [11, 0]])
    >>> anms_order(xy, np.array([4.0, 3.0, 2.0, 1.0]), 2).tolist()
    [0, 2]
    """
    r = suppression_radii(xy, response, robust)
    resp = np.nan_to_num(np.asarray(response, dtype=np.float64), nan=-np.inf)
    # the points within 1 - robust of the strongest all have an infinite radius: among them the
    # distance to the nearest stronger point (robust = 1) puts the isolated ones first
    r1 = np.where(np.isinf(r), suppression_radii(xy, response, 1.0), 0.0) if robust < 1 else np.zeros(len(r))
    order = np.lexsort((-resp, -r1, -r))
    return order[: max(0, int(n))]


def bucket_order(xy: np.ndarray, response: np.ndarray, shape: tuple[int, int], n: int,
                 cell: float | None = None) -> np.ndarray:
    """Indices of ``n`` points: an equal share per grid cell, the unused share to the strongest left.

    ``cell`` is the cell side in pixels; by default the grid has about 64 cells
    of equal area over the image.

    Examples
    --------
    >>> xy = np.array([[1.0, 1], [2, 1], [3, 1], [90, 90]])
    >>> sorted(bucket_order(xy, np.array([4.0, 3.0, 2.0, 1.0]), (100, 100), 2, cell=50).tolist())
    [0, 3]
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    resp = np.nan_to_num(np.asarray(response, dtype=np.float64), nan=-np.inf)
    n = max(0, int(n))
    if len(xy) <= n:
        return np.argsort(-resp, kind="stable")
    h, w = shape[:2]
    side = float(cell) if cell else max(1.0, float(np.sqrt(h * w / 64.0)))
    cx = np.clip((xy[:, 0] // side).astype(np.int64), 0, None)
    cy = np.clip((xy[:, 1] // side).astype(np.int64), 0, None)
    cid = cy * (int(w // side) + 2) + cx
    n_cells = int(np.ceil(h / side) * np.ceil(w / side))
    quota = max(1, n // max(n_cells, 1))
    order = np.argsort(-resp, kind="stable")
    # rank of each point inside its cell, strongest first
    rank = np.empty(len(xy), np.int64)
    seen: dict[int, int] = {}
    for i in order:
        c = int(cid[i])
        rank[i] = seen.get(c, 0)
        seen[c] = rank[i] + 1
    first = order[rank[order] < quota]
    if len(first) >= n:
        return first[np.argsort(-resp[first], kind="stable")][:n]
    rest = order[rank[order] >= quota]
    return np.concatenate([first, rest[: n - len(first)]])
