"""The registry of lens models: one row per model, each model's record in its own module.

:data:`LENSES` maps a model's name to its :class:`~.lens.LensModel`, in the order the
models are listed (and, at equal numbers of coefficients, preferred by ``--model auto``).
To add a model, write its module (its record ``LENS``, see :mod:`.lens`) and add its row here.
"""

from __future__ import annotations

from . import fisheye, omnidir, pinhole, pinhole4, rational
from .lens import LensModel

__all__ = ["LENSES", "lens"]

#: model name -> its record
LENSES: dict[str, LensModel] = {m.name: m for m in (
    pinhole4.LENS,
    pinhole.LENS,
    rational.LENS,
    fisheye.LENS,
    omnidir.LENS,
)}


def lens(name: str) -> LensModel:
    """The record of the model ``name``; a one-line ``ValueError`` naming the choices if there is none.

    Examples
    --------
    >>> lens("fisheye").params, lens("pinhole4").fisheye
    (('k1', 'k2', 'k3', 'k4'), False)
    """
    try:
        return LENSES[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown camera model {name!r}; choose one of {', '.join(LENSES)}") from None
