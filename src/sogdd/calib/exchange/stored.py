"""A stored calibration: cameras (lens model, ``K``, distortion, image size) and their poses in the
rig's reference camera, with the uncertainties a file may hold, nothing else of the fit's diagnostics.

:class:`StoredCamera` is one camera, :class:`StoredRig` one or more (a single camera is a rig of
one). Every format reads into them and writes from them; :func:`stored_rig` makes one of
sogdd's results (:class:`~sogdd.calib.Calibration`, :class:`~sogdd.calib.rig.RigCalibration`).
The uncertainties (``std``, ``rms``, ``pose_std``; :attr:`StoredRig.square`) are optional, NaN or
None where unknown: sogdd's own files and results hold them (:mod:`.native` reads them back), the
other formats ignore them. :mod:`~sogdd.calib.drift` checks new views against them.

Conventions are sogdd's throughout: pixel centres at integers (OpenCV's), the distortion in
OpenCV's order for the model (:data:`~sogdd.calib.cameras.MODELS`), a camera's pose
:math:`x_{cam} = R\\,x_{ref} + T` (the reference camera: identity and zero), ``T`` in the
unit of the calibration's square. A format that counts pixels or lengths otherwise converts in
its own module.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..cameras import lens, project
from ..result import Calibration
from ..rig.result import RigCalibration

__all__ = ["INTRINSICS", "POSE_STD", "StoredCamera", "StoredRig", "check_scale", "stored_rig"]

#: the intrinsics whose standard deviations a camera carries (``std``), in OpenCV's order
INTRINSICS = ("fx", "fy", "cx", "cy")
#: the standard deviations of a camera's pose in its rig (``pose_std``): the rotation's (degrees) and
#: the baseline's (the unit of ``T``)
POSE_STD = ("rotation_deg", "baseline")
_NAN = float("nan")


def _number(v) -> float:
    """A float, NaN for None or what is no number."""
    try:
        return _NAN if v is None else float(v)
    except (TypeError, ValueError):
        return _NAN


def _stds(given: Mapping | Sequence | np.ndarray | None, names: tuple[str, ...]) -> dict[str, float]:
    """``names``' standard deviations from a dict by name or a vector in ``names``' order (OpenCV's
    ``std_intrinsics``): NaN where missing, and where not positive (0: a parameter the fit held)."""
    if isinstance(given, Mapping):
        vals = [_number(given.get(n)) for n in names]
    else:
        flat = [] if given is None else np.ravel(np.asarray(given, dtype=np.float64))
        vals = [float(flat[k]) if k < len(flat) else _NAN for k in range(len(names))]
    return {n: v if math.isfinite(v) and v > 0 else _NAN for n, v in zip(names, vals)}


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
    std : dict of str to float
        The standard deviations of :data:`INTRINSICS` (px), NaN where unknown; given as a dict by name
        or a vector in that order (camera.yaml's ``std_intrinsics``). Not positive counts as unknown.
    rms : float
        The fit's RMS reprojection error (px), NaN unknown.
    pose_std : dict of str to float
        The pose's standard deviations, :data:`POSE_STD`, NaN unknown.

    The uncertainties default to unknown; the formats that do not hold them ignore them.
    Compared by identity (``==`` on arrays has no single answer): compare the fields.

    Examples
    --------
    >>> K = [[500.0, 0, 320], [0, 500, 240], [0, 0, 1]]
    >>> cam = StoredCamera("left", "pinhole4", K, [0.0] * 4, (640, 480))
    >>> cam.project(np.array([[0.1, -0.2, 1.0]])).tolist()
    [[370.0, 140.0]]
    >>> cam.intrinsics, cam.std["fx"], cam.rms
    ({'fx': 500.0, 'fy': 500.0, 'cx': 320.0, 'cy': 240.0}, nan, nan)
    """

    name: str
    model: str
    K: np.ndarray
    dist: np.ndarray
    image_size: tuple[int, int]
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    T: np.ndarray = field(default_factory=lambda: np.zeros(3))
    std: dict[str, float] = field(default_factory=dict)
    rms: float = _NAN
    pose_std: dict[str, float] = field(default_factory=dict)

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
        object.__setattr__(self, "std", _stds(self.std, INTRINSICS))
        object.__setattr__(self, "rms", _number(self.rms))
        object.__setattr__(self, "pose_std", _stds(self.pose_std, POSE_STD))

    @property
    def intrinsics(self) -> dict[str, float]:
        """:data:`INTRINSICS` by name: ``fx, fy, cx, cy`` from ``K``."""
        K = self.K
        return {"fx": float(K[0, 0]), "fy": float(K[1, 1]), "cx": float(K[0, 2]), "cy": float(K[1, 2])}

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
        """The same camera with another pose (and name): ``std`` and ``rms`` kept, ``pose_std`` only
        where the pose is the same (another pose's uncertainty is unknown)."""
        same = np.array_equal(np.asarray(R, dtype=np.float64), self.R) and \
            np.array_equal(np.ravel(np.asarray(T, dtype=np.float64)), self.T)
        return replace(self, name=self.name if name is None else name, R=R, T=T,
                       pose_std=self.pose_std if same else {})


@dataclass(frozen=True, eq=False)
class StoredRig:
    """Cameras calibrated together, the first the reference (a single camera is a rig of one).

    ``square`` is the board square's length in the unit of the cameras' ``T`` where known (sogdd's
    own files and results: what the board's corners are placed with), else None.

    Examples
    --------
    >>> K = [[500.0, 0, 320], [0, 500, 240], [0, 0, 1]]
    >>> rig = StoredRig((StoredCamera("left", "pinhole4", K, [0.0] * 4, (640, 480)),
    ...                  StoredCamera("right", "pinhole4", K, [0.0] * 4, (640, 480), T=[-0.1, 0, 0])))
    >>> rig.names, rig.camera("right").T.tolist()
    (('left', 'right'), [-0.1, 0.0, 0.0])
    """

    cameras: tuple[StoredCamera, ...]
    square: float | None = None

    def __post_init__(self) -> None:
        if self.square is not None:
            sq = _number(self.square)
            if not math.isfinite(sq) or sq <= 0:
                raise ValueError(f"square must be a positive number or None, got {self.square!r}")
            object.__setattr__(self, "square", sq)
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
        """The rig with every translation (and ``square``, and the baselines' standard deviations)
        multiplied by ``factor`` (another unit of length).

        Examples
        --------
        >>> K = [[500.0, 0, 320], [0, 500, 240], [0, 0, 1]]
        >>> rig = StoredRig((StoredCamera("a", "pinhole4", K, [0.0] * 4, (640, 480), T=[-120.0, 0, 0]),))
        >>> rig.scaled(0.001).cameras[0].T.tolist()
        [-0.12, 0.0, 0.0]
        """
        f = check_scale(factor)
        cams = tuple(replace(c, T=c.T * f, pose_std={**c.pose_std, "baseline": c.pose_std["baseline"] * f})
                     for c in self.cameras)
        return StoredRig(cams, None if self.square is None else self.square * f)

    def relative(self) -> StoredRig:
        """The rig re-expressed in its first camera's frame (that camera: identity and zero)."""
        R0, T0 = self.cameras[0].R, self.cameras[0].T
        return StoredRig(tuple(c.with_pose(c.R @ R0.T, c.T - c.R @ R0.T @ T0) for c in self.cameras),
                         self.square)


def check_scale(factor: float) -> float:
    """``factor`` as a float: a unit of length's multiplier, finite and positive; else a one-line
    ``ValueError``.

    Examples
    --------
    >>> check_scale(0.001)
    0.001
    >>> check_scale(float("nan"))
    Traceback (most recent call last):
    ...
    ValueError: the scale must be a positive number, got nan
    """
    try:
        f = float(factor)
    except (TypeError, ValueError):
        f = math.nan
    if not math.isfinite(f) or f <= 0:
        raise ValueError(f"the scale must be a positive number, got {factor!r}")
    return f


def stored_rig(obj: StoredRig | StoredCamera | Calibration | RigCalibration, name: str = "camera") -> StoredRig:
    """One of sogdd's calibrations as a :class:`StoredRig`.

    A :class:`~sogdd.calib.Calibration` (one camera, called ``name``), a
    :class:`~sogdd.calib.rig.RigCalibration` (its cameras and poses), each with its standard
    deviations, RMS and square; a :class:`StoredCamera` or a :class:`StoredRig` (as it is).

    Examples
    --------
    >>> from sogdd.calib.rig.demo import demo_rig
    >>> rig = stored_rig(demo_rig())
    >>> rig.names, bool(rig.cameras[1].pose_std["baseline"] > 0), rig.square
    (('left', 'right'), True, 1.0)
    """
    if isinstance(obj, StoredRig):
        return obj
    if isinstance(obj, StoredCamera):
        return StoredRig((obj,))
    if isinstance(obj, Calibration):
        return StoredRig((StoredCamera(name, obj.model, obj.K, np.ravel(obj.dist), obj.image_size,
                                       std=obj.std, rms=obj.rms),), float(obj.square))
    if isinstance(obj, RigCalibration):
        return StoredRig(tuple(StoredCamera(c.name, c.model, c.K, np.ravel(c.dist), c.image_size, c.R,
                                            np.ravel(c.T), c.std, c.calibration.rms, c.std)
                               for c in obj.cameras), float(obj.square))
    raise TypeError(f"not a calibration: {type(obj).__name__}")

