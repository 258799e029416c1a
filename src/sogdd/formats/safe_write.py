"""Writing files a user can trust: atomically, with the user's permissions, never over an input.

One home for the three rules every writer of the package follows:

- a file appears under its name complete or not at all: it is written to a
  temporary name beside its target (:data:`TMP_SUFFIX`) and renamed into place
  (:func:`atomic_write`); a failure removes the temporary file and names the
  target, never the temporary one;
- it gets ``0666 & ~umask``, the permissions ``open()`` would give it
  (:func:`user_mode`), not ``mkstemp``'s 0600;
- an output that is one of the inputs, by any path, is refused before any work
  (:func:`check_not_inputs`, :func:`folder_holds`).

A writer holds its temporary file or folder (:func:`claimed`: a lock the system
drops when the process ends, however it ends), so that a later run can tell
what a killed writer left beside a target from what a running one is writing,
and remove only the former (:func:`remove_stale_beside`).
"""

from __future__ import annotations

import os
import re
import shutil
import stat
import tempfile
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: nothing is held, and nothing is taken for stale
    fcntl = None

__all__ = ["TMP_SUFFIX", "atomic_write", "check_input_files", "check_not_inputs", "claimed", "existing_file",
           "folder_holds", "remove_stale_beside", "temporary_beside", "user_mode", "write_bytes", "write_text"]

#: the suffix of a temporary file that is being written (an interrupted writer's are stale)
TMP_SUFFIX = ".sogdd.tmp"
_FRAME = re.compile(r"^(.*)\[(\d+)\]$")


def user_mode() -> int:
    """``0o666 & ~umask``: the permissions of a new file made by ``open()``.

    Examples
    --------
    >>> old = os.umask(0o022); m = user_mode(); _ = os.umask(old)
    >>> oct(m)
    '0o644'
    """
    mask = os.umask(0o022)  # read it (the only portable way) and put it back
    os.umask(mask)
    return 0o666 & ~mask


def temporary_beside(target: str | os.PathLike) -> Path:
    """A new empty file beside ``target`` (same folder, so the final rename is atomic), named
    ``.<name>.<random>`` + :data:`TMP_SUFFIX`, with :func:`user_mode` permissions."""
    target = Path(target)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=TMP_SUFFIX, dir=target.parent)
    os.close(fd)
    os.chmod(tmp, user_mode())
    return Path(tmp)


def atomic_write(target: str | os.PathLike, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp)`` on a temporary file beside ``target``, then rename it to ``target``.

    Raises what ``write`` raises, or ``OSError`` naming ``target`` when its folder
    cannot be written; the temporary file never survives a failure (Ctrl-C
    included).

    Examples
    --------
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = atomic_write(d / "a.txt", lambda tmp: tmp.write_text("hi"))
    >>> (d / "a.txt").read_text(), sorted(p.name for p in d.iterdir())
    ('hi', ['a.txt'])
    """
    target = Path(target)
    if target.is_dir():
        raise IsADirectoryError(f"{target}: is a folder, not a file name")
    try:
        tmp = temporary_beside(target)
    except OSError as exc:
        raise type(exc)(exc.errno, f"{target}: cannot write ({exc.strerror or exc})") from None
    try:
        write(tmp)
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return target


@contextmanager
def claimed(path: str | os.PathLike) -> Iterator[None]:
    """Hold the temporary file or folder ``path`` while it is written: an exclusive lock on it, which the
    system drops when the process ends, however it ends (``SIGKILL`` too).

    :func:`remove_stale_beside` leaves what is held alone: a temporary of a
    running writer is never taken for a killed writer's.
    """
    if fcntl is None:  # pragma: no cover
        yield
        return
    fd = os.open(path, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


def _stale(name: str, target: str) -> bool:
    """Whether ``name`` is a temporary of ``target`` (``.<target>.<one word>`` + :data:`TMP_SUFFIX`)."""
    prefix = f".{target}."
    if not (name.startswith(prefix) and name.endswith(TMP_SUFFIX)):
        return False
    word = name[len(prefix):-len(TMP_SUFFIX)]
    return bool(word) and "." not in word  # ``.calib.x.new-1.sogdd.tmp`` is calib.x's, not calib's


def remove_stale_beside(target: str | os.PathLike) -> list[Path]:
    """Remove the temporary files and folders that killed writers of ``target`` left beside it; return them.

    A writer killed outright (``SIGKILL``, the out-of-memory killer) cannot
    clean up: its ``.<name>.<random>`` + :data:`TMP_SUFFIX` file or folder
    stays beside ``target``. Those that no running process holds
    (:func:`claimed`) are removed; a symbolic link by that name is removed
    itself, never followed. Entries that cannot be removed are left.

    Examples
    --------
    >>> d = Path(tempfile.mkdtemp())
    >>> (d / ".calib.new-1a2b.sogdd.tmp").mkdir(); (d / ".calib.x.new-3c.sogdd.tmp").mkdir()
    >>> [p.name for p in remove_stale_beside(d / "calib")], sorted(p.name for p in d.iterdir())
    (['.calib.new-1a2b.sogdd.tmp'], ['.calib.x.new-3c.sogdd.tmp'])
    """
    target = Path(target)
    if fcntl is None:  # pragma: no cover - a running writer could not be told from a killed one
        return []
    try:
        names = sorted(n for n in os.listdir(target.parent) if _stale(n, target.name))
    except OSError:  # no folder yet, or not readable: nothing of ours there
        return []
    removed = []
    for n in names:
        p = target.parent / n
        try:
            if p.is_symlink():
                p.unlink()
                removed.append(p)
                continue
            fd = os.open(p, os.O_RDONLY)
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # held: a running writer's
            if p.is_dir():
                shutil.rmtree(p)
            else:
                p.unlink()
            removed.append(p)
        except OSError:
            pass
        finally:
            os.close(fd)
    return removed


def write_bytes(target: str | os.PathLike, data: bytes) -> Path:
    """:func:`atomic_write` of ``data``, flushed to the disk before the rename."""
    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())

    return atomic_write(target, write)


def write_text(target: str | os.PathLike, text: str) -> Path:
    """:func:`write_bytes` of ``text`` in UTF-8 (newlines as given)."""
    return write_bytes(target, text.encode("utf-8"))


def existing_file(path: str | os.PathLike) -> Path | None:
    """The file ``path`` names: itself, or the file of a frame (``photo.tif[2]``); ``None`` if none."""
    text = os.fsdecode(path)
    if os.path.lexists(text):
        return Path(text)
    m = _FRAME.match(text)
    return Path(m.group(1)) if m and os.path.lexists(m.group(1)) else None


def _kind(mode: int) -> str | None:
    """What a file that is neither a regular file nor a folder is, or ``None`` for those two."""
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    return "not a regular file"


def check_input_files(paths: Iterable[str | os.PathLike], what: str = "an image file") -> None:
    """Refuse inputs that are devices, FIFOs or sockets (``ValueError``, one line), before any work.

    Reading ``/dev/zero`` or a FIFO never ends (or waits for a writer for ever),
    so such an input is named and refused at the door. Missing files are left
    to the reader, which names them.

    Examples
    --------
    >>> check_input_files(["/dev/zero"])
    Traceback (most recent call last):
    ...
    ValueError: /dev/zero: a device, not a file; give an image file
    """
    for path in paths:
        p = existing_file(path)
        try:
            kind = _kind(os.stat(p).st_mode) if p is not None else None
        except OSError:  # a broken link, no permission: the reader says so
            kind = None
        if kind:
            raise ValueError(f"{p}: {kind}, not a file; give {what}")


def _identity(path: Path) -> tuple:
    """What makes two paths one file: the resolved path, and (device, inode) where it exists
    (a hard link has another path but the same inode)."""
    real = os.path.realpath(path)
    try:
        st = os.stat(path)
    except OSError:
        return (real,)
    return real, (st.st_dev, st.st_ino)


def check_not_inputs(outputs, inputs) -> None:
    """Refuse an output that is one of the inputs, before any work (``ValueError``, one line).

    ``outputs``: ``(flag, path)`` pairs of the files a command writes (``None``
    paths are skipped); ``inputs``: the files it reads. A path is the input
    also through a symbolic link, a hard link, ``..`` or a relative path;
    writing it would replace the input with the output.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp()); _ = (d / "photo.png").write_bytes(b"x")
    >>> check_not_inputs([("--overlay", d / "sub" / ".." / "photo.png")], [d / "photo.png"])
    Traceback (most recent call last):
    ...
    ValueError: --overlay .../sub/../photo.png: that is the input .../photo.png; choose another file name
    """
    known: dict = {}
    for path in inputs:
        p = existing_file(path) if path is not None else None
        if p is not None:
            for key in _identity(p):
                known.setdefault(key, p)
    for flag, path in outputs:
        if path is None or str(path) == "-":
            continue
        for key in _identity(Path(path)):
            if key in known:
                raise ValueError(f"{flag} {path}: that is the input {known[key]}; choose another file name")


def folder_holds(folder: str | os.PathLike, inputs: Iterable[str | os.PathLike]) -> Path | None:
    """The first input that lies inside ``folder`` (at any depth, through links too), else None.

    An output folder that holds an input would mix outputs with inputs: a later
    run over ``folder/*`` would take the outputs for images.

    Examples
    --------
    >>> d = Path(tempfile.mkdtemp()); _ = (d / "a.png").write_bytes(b"x")
    >>> folder_holds(d, [d / "a.png"]) == d / "a.png", folder_holds(d / "out", [d / "a.png"])
    (True, None)
    """
    root = os.path.realpath(folder)
    for p in inputs:
        f = existing_file(p)
        real = os.path.realpath(f if f is not None else p)
        if os.path.commonpath([root, real]) == root:
            return Path(p)
    return None
