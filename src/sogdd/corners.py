"""The ``Corners`` result type shared by the detector and every baseline."""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

__all__ = ["Corners"]


def _col(a, n: int, fill: float, dtype) -> np.ndarray:
    if a is None:
        return np.full(n, fill, dtype=dtype)
    out = np.asarray(a, dtype=dtype).reshape(-1)
    if out.shape[0] != n:
        raise ValueError(f"expected {n} values, got {out.shape[0]}")
    return out


@dataclass(frozen=True)
class Corners:
    """Detected corners.

    Attributes
    ----------
    xy : (N, 2) float64
        ``x`` (column) and ``y`` (row), pixel centres at integer coordinates
        (OpenCV's convention).
    response : (N,) float64
        What the detector ranks by, strongest first. For SOGDD it depends on
        ``threshold_units``: ``"measure"`` (``paper``, ``authors``) holds the
        response Upsilon itself (eq. 25); ``"grey"`` (``hr``) holds the
        *strength*, Upsilon in grey levels of corner contrast
        (:func:`sogdd.measure.units.grey_strength`; an X-junction's saddle
        strength on the same scale). Baselines hold their own measure.
    size : (N,) float64
        Diameter of the meaningful neighbourhood in pixels (OpenCV ``KeyPoint.size``).
    level : (N,) int64
        Pyramid level the point was found on (0 = full resolution).

    Examples
    --------
    >>> c = Corners(np.array([[10.0, 20.0], [3.5, 4.25]]), response=[5e9, 2e9])
    >>> len(c), c.x.tolist(), c.size.tolist()
    (2, [10.0, 3.5], [7.0, 7.0])
    >>> c.rc().tolist()  # (row, col) for scikit-image
    [[20.0, 10.0], [4.25, 3.5]]
    >>> kp = c.to_keypoints()[0]
    >>> kp.pt, kp.response
    ((10.0, 20.0), 5000000000.0)
    >>> len(c.subset(c.response > 3e9))
    1
    """

    xy: np.ndarray
    response: np.ndarray = field(default=None)  # type: ignore[assignment]
    size: np.ndarray = field(default=None)  # type: ignore[assignment]
    level: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        xy = np.asarray(self.xy, dtype=np.float64).reshape(-1, 2)
        n = xy.shape[0]
        object.__setattr__(self, "xy", xy)
        object.__setattr__(self, "response", _col(self.response, n, np.nan, np.float64))
        object.__setattr__(self, "size", _col(self.size, n, 7.0, np.float64))
        object.__setattr__(self, "level", _col(self.level, n, 0, np.int64))

    def __len__(self) -> int:
        return self.xy.shape[0]

    def __repr__(self) -> str:
        return f"Corners(n={len(self)})"

    @property
    def x(self) -> np.ndarray:
        return self.xy[:, 0]

    @property
    def y(self) -> np.ndarray:
        return self.xy[:, 1]

    def rc(self) -> np.ndarray:
        """(N, 2) ``(row, col)`` coordinates, for scikit-image users."""
        return self.xy[:, ::-1].copy()

    def to_keypoints(self) -> tuple[cv2.KeyPoint, ...]:
        """The corners as ``cv2.KeyPoint`` objects (angle -1: not assigned)."""
        return tuple(
            cv2.KeyPoint(float(x), float(y), float(s), -1.0, float(r), int(o))
            for (x, y), s, r, o in zip(self.xy, self.size, self.response, self.level)
        )

    def subset(self, index) -> Corners:
        """A new ``Corners`` holding the points selected by ``index`` (mask or indices)."""
        return Corners(self.xy[index], self.response[index], self.size[index], self.level[index])

    @staticmethod
    def empty() -> Corners:
        return Corners(np.zeros((0, 2)))

    @staticmethod
    def concatenate(parts: list[Corners]) -> Corners:
        if not parts:
            return Corners.empty()
        return Corners(
            np.concatenate([p.xy for p in parts]),
            np.concatenate([p.response for p in parts]),
            np.concatenate([p.size for p in parts]),
            np.concatenate([p.level for p in parts]),
        )

    @staticmethod
    def from_keypoints(keypoints) -> Corners:
        """Build from a sequence of ``cv2.KeyPoint``."""
        kps = list(keypoints)
        if not kps:
            return Corners.empty()
        return Corners(
            np.array([k.pt for k in kps], dtype=np.float64),
            np.array([k.response for k in kps]),
            np.array([k.size for k in kps]),
            np.array([max(k.octave, 0) & 0xFF for k in kps]),
        )
