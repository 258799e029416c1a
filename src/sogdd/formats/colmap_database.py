"""A COLMAP database file: checked before it is touched, copied, quietened, its stale rows removed.

:func:`sogdd.formats.colmap.export_features` writes into a copy of the
database that replaces it only when the whole export has succeeded. This
module holds what that needs and pycolmap does not give:

* :func:`check_database` refuses, in one line, a path that is not a COLMAP
  database (a folder, a text file, a damaged or unrelated SQLite file) before
  pycolmap would add its tables to it or fail with a traceback;
* :func:`copy_database` copies with SQLite's backup API, so that rows still
  in a write-ahead log (COLMAP opens databases in WAL mode) are copied too;
* :func:`quiet_colmap` keeps pycolmap's log lines (glog, written to file
  descriptor 2) off the terminal, and turns its ``RuntimeError`` into a
  one-line ``ValueError``;
* :func:`forget_features` deletes the descriptors and matches that would
  no longer fit an image's new keypoints.
"""

from __future__ import annotations

import contextlib
import os
import sqlite3
import sys
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

__all__ = ["COLMAP_TABLES", "check_database", "copy_database", "forget_features", "quiet_colmap"]

# the tables every COLMAP database has had since 3.x (4.x adds rigs, frames and pose priors)
COLMAP_TABLES = ("cameras", "images", "keypoints", "descriptors", "matches", "two_view_geometries")
_SQLITE_MAGIC = b"SQLite format 3\x00"


def _connect_ro(path: Path) -> sqlite3.Connection:
    # not "mode=ro": a read-only connection to a WAL database leaves its -wal and -shm files behind,
    # where the last read-write connection to close removes them; query_only keeps it from writing
    con = sqlite3.connect(path)
    con.execute("PRAGMA query_only = 1")
    return con


def check_database(path: str | os.PathLike) -> bool:
    """Whether ``path`` holds a COLMAP database to add to (``False``: there is none yet, create one).

    A missing or empty file is a new database (its folder must exist). Anything
    else that is not an SQLite file with COLMAP's tables is refused with a
    one-line ``ValueError`` naming the file, and left as it is.

    Examples
    --------
    >>> import sqlite3, tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> check_database(d / "new.db")
    False
    >>> (d / "notes.db").write_text("hello")
    5
    >>> check_database(d / "notes.db")
    Traceback (most recent call last):
    ...
    ValueError: ...notes.db: not a COLMAP database (not an SQLite file)
    >>> sqlite3.connect(d / "other.db").execute("create table t (x)").connection.close()
    >>> check_database(d / "other.db")
    Traceback (most recent call last):
    ...
    ValueError: ...other.db: not a COLMAP database (an SQLite file without COLMAP's tables: ...); left untouched
    """
    p = Path(path)
    if not p.exists():
        if not p.parent.is_dir():
            raise ValueError(f"{p}: the folder {p.parent} does not exist")
        return False
    if p.is_dir():
        raise ValueError(f"{p}: a folder, not a COLMAP database")
    try:
        with open(p, "rb") as f:
            head = f.read(len(_SQLITE_MAGIC))
    except OSError as exc:
        raise ValueError(f"{p}: cannot read the database ({exc.strerror.lower()})") from None
    if not head:
        return False  # an empty file is an empty SQLite database: COLMAP creates its tables
    if head != _SQLITE_MAGIC:
        raise ValueError(f"{p}: not a COLMAP database (not an SQLite file)")
    try:
        con = _connect_ro(p)
        try:
            tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        finally:
            con.close()
    except sqlite3.Error as exc:
        raise ValueError(f"{p}: not a readable COLMAP database (SQLite: {exc})") from None
    missing = [t for t in COLMAP_TABLES if t not in tables]
    if missing:
        raise ValueError(f"{p}: not a COLMAP database (an SQLite file without COLMAP's tables: "
                         f"{', '.join(missing)}); left untouched")
    return True


def copy_database(src: str | os.PathLike, dst: str | os.PathLike) -> None:
    """Copy the database ``src`` to ``dst`` with SQLite's backup API (write-ahead log included).

    Refuses (``ValueError``) a database that another program has open, since
    replacing it under that program would lose what it writes.
    """
    s, d = Path(src), Path(dst)
    try:
        con = _connect_ro(s)
        try:
            out = sqlite3.connect(d)
            try:
                con.backup(out)
            finally:
                out.close()
        finally:
            con.close()
    except sqlite3.Error as exc:
        raise ValueError(f"{s}: cannot read the database (SQLite: {exc})") from None
    if Path(f"{s}-wal").exists():  # the last connection to close removes it: someone else holds one
        raise ValueError(f"{s}: the database is open in another program (it has a -wal file); close it first")


class _Log:
    """What pycolmap printed inside :func:`quiet_colmap` (``text``, filled in on exit)."""

    text = ""

    def last_line(self, about: str = "") -> str:
        """The last line (glog's prefix removed) that contains ``about``; ``""`` if none."""
        lines = [x.split("] ", 1)[-1].strip() for x in self.text.splitlines() if about in x and x.strip()]
        return lines[-1] if lines else ""


@contextlib.contextmanager
def quiet_colmap(what: str) -> Iterator[_Log]:
    """Run pycolmap calls with its log lines captured; a ``RuntimeError`` becomes a one-line ``ValueError``.

    ``what`` starts the message (a file name, say). The captured lines are in
    the yielded object's ``text`` after the block.

    Examples
    --------
    >>> with quiet_colmap("x.db") as log:
    ...     os.write(2, b"E1201 images.cc:55] im2.png: an error\\n")
    38
    >>> log.last_line()
    'im2.png: an error'
    """
    log = _Log()
    sys.stderr.flush()
    with tempfile.TemporaryFile() as f:
        saved = os.dup(2)
        os.dup2(f.fileno(), 2)
        error: RuntimeError | None = None
        try:
            yield log
        except RuntimeError as exc:
            error = exc
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            f.seek(0)
            log.text = f.read().decode("utf-8", "replace")
    if error is not None:
        said = log.last_line()
        raise ValueError(f"{what}: COLMAP: {str(error).strip()}" + (f" ({said})" if said else "")) from None


def forget_features(database: str | os.PathLike, descriptors_of: Iterable[int],
                    matches_of: Iterable[int]) -> tuple[int, int]:
    """Delete the descriptors of the images ``descriptors_of`` and every match of the images ``matches_of``.

    Called before new keypoints replace old ones: descriptors and matches are
    rows indexed by keypoint, and would otherwise describe points that are
    gone. Returns ``(images whose descriptors were deleted, image pairs whose
    matches were deleted)``.
    """
    import pycolmap  # here only when export_features has required it

    pair = pycolmap.pair_id_to_image_pair
    desc_ids, match_ids = sorted(set(descriptors_of)), set(matches_of)
    con = sqlite3.connect(Path(database))
    try:
        with con:
            n_desc = 0
            for iid in desc_ids:
                n_desc += con.execute("DELETE FROM descriptors WHERE image_id = ?", (iid,)).rowcount
            pairs: set[int] = set()
            if match_ids:
                for table in ("matches", "two_view_geometries"):
                    for (pid,) in con.execute(f"SELECT pair_id FROM {table}"):
                        if match_ids.intersection(pair(pid)):
                            pairs.add(pid)
                for table in ("matches", "two_view_geometries"):
                    con.executemany(f"DELETE FROM {table} WHERE pair_id = ?", [(p,) for p in pairs])
    finally:
        con.close()
    return n_desc, len(pairs)
