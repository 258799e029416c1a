"""Which files a batch reads and the feature file each one gets: inputs expanded, one name per image."""

from __future__ import annotations

import glob
import os
from collections.abc import Iterable
from pathlib import Path

from ..image.files import list_images

__all__ = ["expand_inputs", "feature_path", "relative_names"]


def expand_inputs(items: Iterable[str], *, recursive: bool = False) -> list[Path]:
    """Files as given; folders expand to their image files (``recursive``: and their
    sub-folders'); glob patterns expand (sorted). The same path twice is kept once."""
    out: list[Path] = []
    for item in items:
        p = Path(item)
        if p.is_dir():
            out.extend(list_images(p, recursive=recursive))
        elif not os.path.lexists(p) and any(ch in item for ch in "*?["):
            matches = sorted(Path(m) for m in glob.glob(item, recursive=True))
            matches = [m for m in matches if m.is_file()]
            if not matches and not _is_frame(item):
                raise ValueError(f"{item}: no files match")
            out.extend(matches or [p])
        else:
            out.append(p)
    seen: set[str] = set()
    unique = []
    for p in out:
        key = os.path.realpath(p) if os.path.lexists(p) else str(p)
        if key not in seen:
            seen.add(key)
            unique.append(p)
    return unique


def _is_frame(item: str) -> bool:
    """``photo.tif[2]``: a frame of an existing file, not a glob pattern."""
    base, _, rest = item.rpartition("[")
    return bool(base) and rest[:-1].isdigit() and rest.endswith("]") and os.path.isfile(base)


def relative_names(paths: list[str | os.PathLike]) -> list[str]:
    """Each path relative to the folder common to all of them, as a POSIX string.

    Raises ``ValueError`` naming both files if two of them still map to the same name.

    Examples
    --------
    >>> relative_names(["/data/a/0001.jpg", "/data/b/0001.jpg"])
    ['a/0001.jpg', 'b/0001.jpg']
    >>> relative_names(["/data/a/0001.jpg"])
    ['0001.jpg']
    """
    absolute = [os.path.abspath(os.fspath(p)) for p in paths]
    if not absolute:
        return []
    root = os.path.commonpath([os.path.dirname(a) for a in absolute])
    names = [Path(os.path.relpath(a, root)).as_posix() for a in absolute]
    first: dict[str, int] = {}
    for i, n in enumerate(names):
        j = first.setdefault(n.lower(), i)  # lower: case-insensitive file systems collide too
        if j != i:
            raise ValueError(f"{paths[j]} and {paths[i]} would both be written as {n!r}")
    return names


def feature_path(out_dir: str | os.PathLike, name: str, fmt: str) -> Path:
    """``out_dir/<name>.<fmt>``, ``name`` from :func:`relative_names`."""
    return Path(out_dir) / f"{name}.{fmt}"
