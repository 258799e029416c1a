"""Reading, writing and converting calibrations in any registered format (:mod:`.registry`).

:func:`read_calibration` gives a :class:`~.stored.StoredRig` of a file or folder in any format,
:func:`write_calibration_as` writes one of sogdd's calibrations in a format, and :func:`convert`
does both (``sogdd convert IN OUT --to FORMAT``). Translations can change unit on the way
(``scale``: sogdd's are in the unit of the calibration's square, Kalibr's and ROS's in metres).
"""

from __future__ import annotations

import os
from pathlib import Path

from ..result import Calibration
from ..rig.result import RigCalibration
from .registry import detect, exchange_format
from .stored import StoredCamera, StoredRig, stored_rig

__all__ = ["convert", "read_calibration", "write_calibration_as"]


def read_calibration(path: str | os.PathLike, fmt: str | None = None) -> StoredRig:
    """The calibration in the file or folder ``path``, in the format ``fmt`` (recognised when None).

    Raises
    ------
    ValueError
        One line: no such file, an unknown format, or a file that is not a calibration in it.

    Examples
    --------
    >>> import tempfile
    >>> from sogdd.calib.rig.demo import demo_rig
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = write_calibration_as(demo_rig(), d / "rig", "mrcal")
    >>> read_calibration(d / "rig").names
    ('left', 'right')
    """
    p = Path(path)
    record = detect(p) if fmt is None else exchange_format(fmt)
    if not p.exists():
        raise ValueError(f"{p}: no such file or folder")
    return record.read(p)


def write_calibration_as(calibration: StoredRig | StoredCamera | Calibration | RigCalibration,
                         path: str | os.PathLike, fmt: str, *, scale: float = 1.0,
                         inputs=()) -> list[Path]:
    """Write a calibration (one of sogdd's, or a :class:`~.stored.StoredRig`) in the format ``fmt``.

    Parameters
    ----------
    calibration : StoredRig, StoredCamera, Calibration or RigCalibration
    path : path
        A file or a folder, as the format's module says (a ``.yaml`` file, a folder of ``left.yaml``
        and ``right.yaml``, ...).
    fmt : str
        A registered format (:data:`~.registry.FORMATS`).
    scale : float
        Every translation is multiplied by it (``0.001``: millimetres to metres).
    inputs : paths
        Files never to overwrite (a conversion's input).

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    ValueError
        A model or rig the format cannot hold (why, in one line), before anything is written.
    """
    record = exchange_format(fmt)
    rig = stored_rig(calibration)
    if scale != 1.0:
        rig = rig.scaled(scale)
    return record.write(rig, Path(path), inputs=inputs)


def convert(source: str | os.PathLike, out: str | os.PathLike, to: str, *, source_format: str | None = None,
            scale: float = 1.0) -> tuple[StoredRig, list[Path]]:
    """Read the calibration ``source`` (any format, or ``source_format``) and write it to ``out`` in ``to``.

    No file of ``source`` is overwritten (a target that is one is refused before anything is
    written). Returns the calibration read and the files written.

    Examples
    --------
    >>> import tempfile
    >>> from sogdd.calib.demo import demo_calibration
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = write_calibration_as(demo_calibration(), d / "camera.yaml", "sogdd")
    >>> rig, files = convert(d / "camera.yaml", d / "ros.yaml", "ros")
    >>> [f.name for f in files], rig.cameras[0].model
    (['ros.yaml'], 'pinhole')
    """
    src = Path(source)
    rig = read_calibration(src, source_format)
    inputs = [p for p in src.iterdir() if p.is_file()] if src.is_dir() else [src]
    return rig, write_calibration_as(rig, out, to, scale=scale, inputs=inputs)
