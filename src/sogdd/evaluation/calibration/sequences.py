"""The named calibration sequences: an exactly known camera, a board, and how its views are made.

Every sequence's camera is a pinhole with ``k1, k2, p1, p2`` (``k3 = 0``), its
views come from :func:`.render.random_sequence` (tilts up to 40 degrees) and are
rendered with 4 x 4 supersampling, blur, illumination falloff and noise. The
boards are square (``n x n`` inner corners) so that mrgingham, which reads only
square grids, runs on every sequence.

=========  ===========  ===========  ==========  =====  =====  =======  =====
name       image        board        cells (px)  blur   noise  partial  views
=========  ===========  ===========  ==========  =====  =====  =======  =====
sharp      1280 x 960   10 x 10      33-60       0.8    2      0        15
dense      1280 x 960   20 x 20      7-10        0.8    2      0        15
6mp        3000 x 2000  20 x 20      22-28       1.2    3      0        12
blur       1280 x 960   10 x 10      33-60       2.5    4      0        15
partial    1280 x 960   10 x 10      40-70       1.0    2      0.4      15
=========  ===========  ===========  ==========  =====  =====  =======  =====

(the ``partial`` sequence's last 6 views are cut by the frame, 30-75 % of their
corners inside). The quick set (``--quick``) is two small sequences for tests
and CI: 640 x 480, a 7 x 7 board, 3 views each, one of them partial.

Run by name only (not in the default set): ``stress``
(:class:`.stress.StressSequence`: 3 views of each of :mod:`.stress`' scenes, 640 x 480:
outer squares cut by the paper's edge, a small second board in the background, an
equidistant fisheye of 193 degrees, dot codes in the white squares, JPEG at quality 75).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .render import Camera, ChessboardTarget, camera_for, random_sequence

__all__ = ["Sequence", "SEQUENCES", "QUICK", "BY_NAME", "sequences", "camera_for"]

@dataclass(frozen=True)
class Sequence:
    """One calibration sequence: camera, board, and the views' rendering."""

    name: str
    camera: Camera
    target: ChessboardTarget
    n_views: int
    cell_px: tuple[float, float]
    blur: float
    noise: float
    falloff: float = 0.3
    partial: float = 0.0
    tilt_max: float = 40.0
    seed: int = 0
    note: str = ""

    def poses(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The views' board poses (deterministic in ``seed``)."""
        return random_sequence(self.camera, self.target, self.n_views, tilt_max=self.tilt_max, seed=self.seed,
                               partial=self.partial, cell_px=self.cell_px)


def _seq(name, size, n, cells, blur, noise, views, partial=0.0, seed=0, note=""):
    return Sequence(name, camera_for(*size), ChessboardTarget(n, n, 0.02), views, cells, blur, noise,
                    partial=partial, seed=seed, note=note)


#: the full evaluation's sequences, by name
SEQUENCES: dict[str, Sequence] = {s.name: s for s in (
    _seq("sharp", (1280, 960), 10, (33.0, 60.0), 0.8, 2.0, 15, seed=11,
         note="cells 33-60 px, blur 0.8, noise 2"),
    _seq("dense", (1280, 960), 20, (7.0, 10.0), 0.8, 2.0, 15, seed=12, note="cells 7-10 px"),
    _seq("6mp", (3000, 2000), 20, (22.0, 28.0), 1.2, 3.0, 12, seed=13,
         note="3000x2000, cells ~25 px, blur 1.2, noise 3"),
    _seq("blur", (1280, 960), 10, (33.0, 60.0), 2.5, 4.0, 15, seed=14, note="blur 2.5 px, noise 4"),
    _seq("partial", (1280, 960), 10, (40.0, 70.0), 1.0, 2.0, 15, partial=0.4, seed=15,
         note="6 of 15 views cut by the frame"),
)}

#: the quick set: small, for tests and CI
QUICK: dict[str, Sequence] = {s.name: s for s in (
    _seq("sharp", (640, 480), 7, (28.0, 40.0), 0.8, 2.0, 3, seed=21, note="quick: 640x480, cells 28-40 px"),
    _seq("partial", (640, 480), 7, (30.0, 45.0), 1.0, 2.0, 3, partial=0.34, seed=22,
         note="quick: 1 of 3 views cut by the frame"),
)}


def _by_name() -> dict:
    from .stress import StressSequence

    return {"stress": StressSequence()}


#: sequences run only when named (``--sequences stress``): not in the default set
BY_NAME: tuple[str, ...] = ("stress",)


def sequences(names: list[str] | None = None, *, quick: bool = False) -> list:
    """The sequences to run: ``names`` of :data:`SEQUENCES` or :data:`BY_NAME` (None: all of
    :data:`SEQUENCES`), or the quick set.

    Raises ``ValueError`` naming the known sequences for an unknown name.

    Examples
    --------
    >>> [s.name for s in sequences(["sharp", "blur"])]
    ['sharp', 'blur']
    >>> [s.n_views for s in sequences(quick=True)]
    [3, 3]
    >>> [(s.name, s.n_views) for s in sequences(["stress"])]
    [('stress', 15)]
    """
    table = QUICK if quick else SEQUENCES
    if names is None:
        return list(table.values())
    if not quick and any(n in BY_NAME for n in names):
        table = {**table, **_by_name()}
    bad = [n for n in names if n not in table]
    if bad:
        known = list(table) + ([n for n in BY_NAME if n not in table] if not quick else [])
        raise ValueError(f"unknown sequence(s) {', '.join(bad)}; known: {', '.join(known)}")
    return [table[n] for n in names]
