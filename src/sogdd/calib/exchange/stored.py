"""A calibration as the exchange formats hold it: cameras (lens model, ``K``, distortion, image size)
and their poses in the rig's reference camera, nothing of the fit's diagnostics.

:class:`StoredCamera` is one camera, :class:`StoredRig` one or more (a single camera is a rig of
one). Every format reads into them and writes from them; :func:`stored_rig` makes one of
sogdd's results (:class:`~sogdd.calib.Calibration`, :class:`~sogdd.calib.rig.RigCalibration`).

Conventions are sogdd's throughout: pixel centres at integers (OpenCV's), the distortion in
OpenCV's order for the model (:data:`~sogdd.calib.cameras.MODELS`), a camera's pose
:math:`x_{cam} = R\\,x_{ref} + T` (the reference camera: identity and zero), ``T`` in the
unit of the calibration's square. A format that counts pixels or lengths otherwise converts in
its own module.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..cameras import lens, project
from ..result import Calibration
from ..rig.result import RigCalibration

__all__ = ["StoredCamera", "StoredRig", "stored_rig"]


def _matrix(value, shape: tuple[int, ...], what: str) -> np.ndarray:
    m = np.array(value, dtype=np.float64)
    if m.size != math.prod(shape) or not np.all(np.isfinite(m)):
        raise ValueError(f"{what} must be {' x '.join(map(str, shape))} finite numbers, got "
                         f"{np.ravel(m).tolist()}")
    m = m.reshape(shape)
    m.setflags(write=False)
    return m


@dataclass(frozen=True, eq=False)
class StoredCamera:
    """One camera: its name, lens model, intrinsics, image size and pose in its rig.

    Attributes
    ----------
    name : str
    model : str
        A registered lens model (:data:`~sogdd.calib.cameras.LENSES`).
    K : (3, 3) float64
        ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``, pixel centres at integers.
    dist : 1-D float64
        The model's coefficients in OpenCV's order, exactly as many as the model names.
    image_size : (width, height)
    R : (3, 3) float64
    T : (3,) float64
        The pose: :math:`x_{cam} = R\\,x_{ref} + T` (identity and zero for the reference). ``R`` is
        kept as given, orthonormal to 1e-6 (files print rotations to 6 to 17 digits).

    Compared by identity (``==`` on arrays has no single answer): compare the fields.

    Examples
    --------
    >>> K = [[500.0, 0, 320], [0, 500, 240], [0, 0, 1]]
    >>> cam = StoredCamera("left", "pinhole4", K, [0.0] * 4, (640, 480))
    >>> cam.project(np.array([[0.1, -0.2, 1.0]])).tolist()
    [[370.0, 140.0]]
    """

    name: str
    model: str
    K: np.ndarray
    dist: np.ndarray
    image_size: tuple[int, int]
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    T: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        record = lens(self.model)
        K = _matrix(self.K, (3, 3), "K")
        if K[0, 0] <= 0 or K[1, 1] <= 0 or K[1, 0] != 0 or K[2, 0] != 0 or K[2, 1] != 0 or K[2, 2] != 1:
            raise ValueError(f"K must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0, got "
                             f"{K.tolist()}")
        n = len(record.params)
        dist = _matrix(self.dist, (n,), f"a {self.model} camera's dist ({', '.join(record.params)})")
        try:
            w, h = (int(v) for v in self.image_size)
        except (TypeError, ValueError):
            raise ValueError(f"image_size must be (width, height), got {self.image_size!r}") from None
        if w < 1 or h < 1:
            raise ValueError(f"image_size must be (width, height) >= 1, got {self.image_size!r}")
        R = _matrix(self.R, (3, 3), "R")
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) <= 0:
            raise ValueError(f"R must be a rotation matrix, got {R.tolist()}")
        object.__setattr__(self, "name", str(self.name))
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "dist", dist)
        object.__setattr__(self, "image_size", (w, h))
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "T", _matrix(self.T, (3,), "T"))

    @property
    def skew(self) -> float:
        """``K[0, 1]``: 0 for every camera sogdd fits."""
        return float(self.K[0, 1])

    def coefficients(self) -> dict[str, float]:
        """The distortion coefficients by name, in OpenCV's order."""
        return dict(zip(lens(self.model).params, (float(v) for v in self.dist)))

    def project(self, points: np.ndarray, *, in_reference: bool = False) -> np.ndarray:
        """Pixels (N, 2) of points (N, 3) in this camera's frame, or in the rig's reference frame
        (``in_reference=True``: :math:`R x + T` first): :func:`~sogdd.calib.cameras.project`."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if in_reference:
            p = p @ self.R.T + self.T
        return project(p, self.K, self.dist, self.model)

    def with_pose(self, R: np.ndarray, T: np.ndarray, name: str | None = None) -> StoredCamera:
        """The same camera with another pose (and name)."""
        return StoredCamera(self.name if name is None else name, self.model, self.K, self.dist,
                            self.image_size, R, T)


@dataclass(frozen=True, eq=False)
class StoredRig:
    """Cameras calibrated together, the first the reference (a single camera is a rig of one).

    Examples
    --------
    >>> K = [[500.0, 0, 320], [0, 500, 240], [0, 0, 1]]
    >>> rig = StoredRig((StoredCamera("left", "pinhole4", K, [0.0] * 4, (640, 480)),
    ...                  StoredCamera("right", "pinhole4", K, [0.0] * 4, (640, 480), T=[-0.1, 0, 0])))
    >>> rig.names, rig.camera("right").T.tolist()
    (('left', 'right'), [-0.1, 0.0, 0.0])
    """

    cameras: tuple[StoredCamera, ...]

    def __post_init__(self) -> None:
        cams = tuple(self.cameras)
        if not cams or not all(isinstance(c, StoredCamera) for c in cams):
            raise ValueError("a rig needs one or more cameras (StoredCamera)")
        names = [c.name for c in cams]
        if len(set(names)) != len(names):
            raise ValueError(f"the cameras need distinct names, got {names}")
        object.__setattr__(self, "cameras", cams)

    @property
    def names(self) -> tuple[str, ...]:
        """The cameras' names, the reference first."""
        return tuple(c.name for c in self.cameras)

    def camera(self, name: str | None = None) -> StoredCamera:
        """The camera called ``name`` (the reference without one); ``KeyError`` naming the cameras."""
        if name is None:
            return self.cameras[0]
        for c in self.cameras:
            if c.name == name:
                return c
        raise KeyError(f"no camera {name!r}; there are {', '.join(self.names)}")

    def scaled(self, factor: float) -> StoredRig:
        """The rig with every translation multiplied by ``factor`` (another unit of length).

        Examples
        --------
        >>> K = [[500.0, 0, 320], [0, 500, 240], [0, 0, 1]]
        >>> rig = StoredRig((StoredCamera("a", "pinhole4", K, [0.0] * 4, (640, 480), T=[-120.0, 0, 0]),))
        >>> rig.scaled(0.001).cameras[0].T.tolist()
        [-0.12, 0.0, 0.0]
        """
        f = float(factor)
        if not math.isfinite(f) or f <= 0:
            raise ValueError(f"the scale must be a positive number, got {factor!r}")
        return StoredRig(tuple(c.with_pose(c.R, c.T * f) for c in self.cameras))

    def relative(self) -> StoredRig:
        """The rig re-expressed in its first camera's frame (that camera: identity and zero)."""
        R0, T0 = self.cameras[0].R, self.cameras[0].T
        return StoredRig(tuple(c.with_pose(c.R @ R0.T, c.T - c.R @ R0.T @ T0) for c in self.cameras))


def stored_rig(obj: StoredRig | StoredCamera | Calibration | RigCalibration, name: str = "camera") -> StoredRig:
    """One of sogdd's calibrations as a :class:`StoredRig`.

    A :class:`~sogdd.calib.Calibration` (one camera, called ``name``), a
    :class:`~sogdd.calib.rig.RigCalibration` (its cameras and poses), a :class:`StoredCamera`
    or a :class:`StoredRig` (as it is).

    Examples
    --------
    >>> from sogdd.calib.rig.demo import demo_rig
    >>> stored_rig(demo_rig()).names
    ('left', 'right')
    """
    if isinstance(obj, StoredRig):
        return obj
    if isinstance(obj, StoredCamera):
        return StoredRig((obj,))
    if isinstance(obj, Calibration):
        return StoredRig((StoredCamera(name, obj.model, obj.K, np.ravel(obj.dist), obj.image_size),))
    if isinstance(obj, RigCalibration):
        return StoredRig(tuple(StoredCamera(c.name, c.model, c.K, np.ravel(c.dist), c.image_size, c.R,
                                            np.ravel(c.T)) for c in obj.cameras))
    raise TypeError(f"not a calibration: {type(obj).__name__}")

