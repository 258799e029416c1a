"""What an exchange format is: :class:`ExchangeFormat`, one record per format, and what its modules share.

Each format lives in a module of its own holding its record, ``FORMAT``; :mod:`.registry`
lists them. A record says how to recognise a file of the format (``sniff``), how to read it
into a :class:`~.stored.StoredRig` and how to write one (every file through
:func:`sogdd.formats.safe_write.write_text`, so that it appears complete or not at all). A
model or a rig a format cannot hold is refused by its ``write`` with a one-line ``ValueError``
saying why, never approximated.

The YAML formats need PyYAML to read (``pip install 'sogdd[formats]'``), imported only
when one is read (:func:`load_yaml`); they are written as the tools write them, number by
number (:func:`yaml_float`), so that writing needs nothing.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

from ...formats.safe_write import check_not_inputs, write_text
from .stored import StoredCamera, StoredRig

__all__ = ["ExchangeFormat", "load_yaml", "no_skew", "write_files", "yaml_float"]


@dataclass(frozen=True)
class ExchangeFormat:
    """One exchange format.

    Attributes
    ----------
    name : str
        What ``--to`` and ``--from`` call it.
    summary : str
        One line for the documentation and ``--help``.
    sniff : callable
        ``sniff(path) -> bool``: whether ``path`` (a file or a folder) is in this format.
    read : callable
        ``read(path) -> StoredRig``; a one-line ``ValueError`` for a file that is not one.
    write : callable
        ``write(rig, path, inputs=()) -> list of Path``: the files written (``path`` a file or a folder,
        as the format's module says); a one-line ``ValueError`` for what the format cannot hold, or for
        a target that is one of ``inputs`` (the files a conversion read), before anything is written.
    needs : str
        The extra it needs (``""``: none).
    """

    name: str
    summary: str
    sniff: Callable[[Path], bool]
    read: Callable[[Path], StoredRig]
    write: Callable[..., list[Path]]
    needs: str = ""


def yaml_float(v: float) -> str:
    """``v`` as YAML text that reads back bit for bit, by PyYAML and yaml-cpp alike.

    The shortest repr, with a ``.0`` before a bare exponent (YAML 1.1 reads ``1e-05`` as a
    string); a non-finite value is refused.

    Examples
    --------
    >>> yaml_float(0.1), yaml_float(1e-05), yaml_float(2.0), yaml_float(-3e+20)
    ('0.1', '1.0e-05', '2.0', '-3.0e+20')
    """
    f = float(v)
    if not math.isfinite(f):
        raise ValueError(f"a non-finite number ({f}) cannot be written")
    text = repr(f)
    return text.replace("e", ".0e") if "e" in text and "." not in text else text


def load_yaml(path: str | os.PathLike) -> object:
    """A YAML file's content by PyYAML's safe loader; a one-line ``ValueError`` when it is not YAML
    or PyYAML is missing (how to install it)."""
    try:
        import yaml
    except ImportError:
        raise ValueError("reading YAML needs PyYAML: pip install 'sogdd[formats]' (or pip install pyyaml)") \
            from None
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{p}: not a text file") from None
    if text.startswith("%YAML") and "!!opencv-matrix" in text:
        raise ValueError(f"{p}: an OpenCV FileStorage file (sogdd's camera.yaml or rig.yaml), not plain YAML")
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        where = getattr(exc, "problem_mark", None)
        raise ValueError(f"{p}: not valid YAML{f' (line {where.line + 1})' if where else ''}") from None


def no_skew(cam: StoredCamera, what: str) -> None:
    """``ValueError`` if the camera has a skew, which ``what`` (a format) cannot hold."""
    if cam.skew != 0:
        raise ValueError(f"camera {cam.name!r} has a skew (K[0, 1] = {cam.skew!r}), which {what} cannot hold")


def write_files(files: Mapping[Path, str], inputs: Iterable[str | os.PathLike] = ()) -> list[Path]:
    """Write each file's text atomically (:func:`~sogdd.formats.safe_write.write_text`), folders made
    as needed; the paths written, in order. A target that is one of ``inputs`` is refused
    (one-line ``ValueError``) before anything is written."""
    check_not_inputs([("output", p) for p in files], inputs)
    out = []
    for path, text in files.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        out.append(write_text(path, text))
    return out
