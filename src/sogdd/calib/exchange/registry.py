"""The registry of exchange formats: one row per format, each format's record in its own module.

:data:`FORMATS` maps a format's name to its :class:`~.format.ExchangeFormat`, in the order an
input's format is recognised (:func:`detect`: the first whose ``sniff`` takes it). To add a
format, write its module (its record ``FORMAT``, see :mod:`.format`) and add its row here.
"""

from __future__ import annotations

import os
from pathlib import Path

from . import colmap, kalibr, mrcal, native, ros
from .format import ExchangeFormat

__all__ = ["FORMATS", "detect", "exchange_format"]

#: format name -> its record
FORMATS: dict[str, ExchangeFormat] = {f.name: f for f in (
    native.FORMAT,
    ros.FORMAT,
    kalibr.FORMAT,
    mrcal.FORMAT,
    colmap.FORMAT,
)}


def exchange_format(name: str) -> ExchangeFormat:
    """The record of the format ``name``; a one-line ``ValueError`` naming the choices if there is none.

    Examples
    --------
    >>> exchange_format("kalibr").name, exchange_format("colmap").needs
    ('kalibr', 'pycolmap')
    """
    try:
        return FORMATS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown format {name!r}; choose one of {', '.join(FORMATS)}") from None


def detect(path: str | os.PathLike) -> ExchangeFormat:
    """The format of the file or folder ``path``: the first record whose ``sniff`` takes it.

    Raises
    ------
    ValueError
        ``path`` does not exist, or no format takes it (one line, naming the formats).
    """
    p = Path(path)
    if not p.exists():
        raise ValueError(f"{p}: no such file or folder")
    for f in FORMATS.values():
        if f.sniff(p):
            return f
    raise ValueError(f"{p}: not a calibration in a format sogdd reads ({', '.join(FORMATS)}); name it with "
                     "--from if it is one")
