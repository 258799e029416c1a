"""What every command shares: the help format, data paths, the common flags, JSON output, progress."""

from __future__ import annotations

import argparse
import errno
import json
import math
import os
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from contextlib import contextmanager
from pathlib import Path

from ..formats.safe_write import check_input_files, check_not_inputs

__all__ = [
    "BAD_VERDICT",
    "HelpFormatter",
    "add_detectors_argument",
    "add_output_arguments",
    "check_input_files",
    "check_not_inputs",
    "data_path",
    "data_root",
    "jsonable",
    "output_folder",
    "print_json",
    "reference_file",
    "reporter",
    "run_calibration",
    "verdict_level",
    "write_stdout",
]


class HelpFormatter(argparse.HelpFormatter):
    """Every option's default shown where it has a meaningful one; descriptions with line
    breaks (module docstrings) kept as written, one-line ones wrapped.

    An option whose help already says ``[default: ...]`` (defaults found at run
    time, such as ``$SOGDD_DATA/...``), or whose default is ``None``/``False``,
    is left as it is.
    """

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        if "\n" in text.strip():
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if ("default" in text or not action.option_strings or action.default in (None, False)
                or action.default is argparse.SUPPRESS):
            return text
        return f"{text} [default: %(default)s]"


def data_root() -> Path | None:
    """``$SOGDD_DATA``, else ``../shared/data`` relative to the working directory if it exists."""
    env = os.environ.get("SOGDD_DATA")
    if env:
        return Path(env)
    p = Path("..") / "shared" / "data"
    return p if p.is_dir() else None


def data_path(given: str | None, *sub: str, what: str, flag: str) -> Path:
    """``given``, else ``<data root>/<sub...>``; ``ValueError`` naming ``flag`` when neither exists."""
    if given:
        return Path(given)
    root = data_root()
    p = root.joinpath(*sub) if root is not None else None
    if p is None or not p.exists():
        raise ValueError(f"no {what}: pass {flag} or set SOGDD_DATA")
    return p


def reference_file(name: str) -> Path | None:
    """``<data root>/../reference/<name>`` (the published numbers), if it exists."""
    root = data_root()
    p = root.parent / "reference" / name if root is not None else None
    return p if p is not None and p.is_file() else None


def jsonable(obj):
    """``obj`` with non-finite floats as None and numpy scalars as Python numbers.

    Examples
    --------
    >>> import numpy as np
    >>> jsonable({"a": float("nan"), "b": np.int64(3), "c": [np.float32(0.5)]})
    {'a': None, 'b': 3, 'c': [0.5]}
    """
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if hasattr(obj, "item") and callable(obj.item):  # numpy scalars
        return jsonable(obj.item())
    return obj


def print_json(obj) -> None:
    """One JSON object on stdout (non-finite floats as null)."""
    write_stdout((json.dumps(jsonable(obj)) + "\n").encode())


class OutputClosed(Exception):
    """Stdout's reader went away (``| head``): the command ends quietly (:func:`sogdd.cli.main.main`)."""


def write_stdout(data: bytes) -> None:
    """All of ``data`` on stdout, or an error: never a silent short write.

    Python's buffered stdout can drop the rest of a large write that the disk
    only partly took (a full disk gave exit 0 and a truncated CSV), so this
    writes to the file descriptor itself until every byte is taken. Raises
    ``OSError`` ("cannot write to stdout: ...") on a full disk or any other
    write error, and :class:`OutputClosed` when the reader has closed the pipe.
    """
    out = sys.stdout
    try:
        out.flush()
        fd = out.fileno()
    except (AttributeError, OSError, ValueError):  # a captured stream (tests, an embedding program)
        fd = None
    try:
        if fd is None:
            out.write(data.decode())
            out.flush()
            return
        view = memoryview(data)
        while view:
            n = os.write(fd, view)
            if n <= 0:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            view = view[n:]
    except BrokenPipeError:
        raise OutputClosed() from None
    except OSError as exc:
        raise OSError(exc.errno, f"cannot write to stdout: {exc.strerror or exc}") from None




def output_folder(text: str) -> str:
    """An argparse ``type`` for ``--out DIR``: refuse an existing file (the folder is made later).

    Examples
    --------
    >>> output_folder("/dev/null")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: /dev/null is a file, not a folder; give a folder (made if missing)
    """
    if os.path.lexists(text) and not os.path.isdir(text):
        raise argparse.ArgumentTypeError(f"{text} is a file, not a folder; give a folder (made if missing)")
    return text


def add_detectors_argument(p: argparse.ArgumentParser, default: str) -> None:
    """``--detectors SPEC [SPEC ...]``, space- or comma-separated; ``default`` describes the default."""
    p.add_argument("--detectors", nargs="+", metavar="SPEC",
                   help="detector specs NAME[:key=value...], space- or comma-separated; 'all' = every "
                        f"registry name [default: {default}]")


def add_output_arguments(p: argparse.ArgumentParser, files: str) -> None:
    """``--out DIR`` (writing ``files``), ``--json`` and ``--quiet``/``--no-progress``."""
    p.add_argument("--out", metavar="DIR", type=output_folder, help=f"write {files} here")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--quiet", "--no-progress", dest="quiet", action="store_true",
                   help="no progress on stderr")


def reporter(args: argparse.Namespace) -> Callable[[str], None] | None:
    """A progress callback printing to stderr, or ``None`` with ``--quiet``."""
    if getattr(args, "quiet", False):
        return None
    return lambda msg: print(msg, file=sys.stderr, flush=True)


#: the exit code of a calibration whose verdict is "bad": its outputs are written all the same
BAD_VERDICT = 3


def run_calibration(out: str, calibrate: Callable[[], tuple[object, dict]],
                    summary: Callable[[object, dict], Sequence[tuple[str, str]]]) -> int:
    """A calibration command's run: ``calibrate()`` (the library's, which checks, calibrates and writes ``out``,
    returning the result and the files written), Ctrl-C or ``SIGTERM`` saying that ``out`` is as it was; each
    unreadable input on stderr, then ``summary(result, written)``, which prints the summary and returns the
    verdict it gave (``(level, text)`` findings). Returns the exit code (one camera and a rig alike):
    :data:`BAD_VERDICT` when a finding is "bad", else 2 when an input could not be read, else 0."""
    try:
        with _sigterm_interrupts():
            result, written = calibrate()
    except KeyboardInterrupt:  # Ctrl-C, or SIGTERM (a BatchInterrupted carrying its number)
        print(f"sogdd: interrupted; {out} left as it was", file=sys.stderr)
        raise
    for v in result.unreadable:
        print(f"sogdd: error: {v.reason}", file=sys.stderr)
    findings = summary(result, written)
    if any(level == "bad" for level, _ in findings):
        return BAD_VERDICT
    return 2 if result.unreadable else 0


def verdict_level(findings: Sequence[tuple[str, str]]) -> str:
    """The worst level of a verdict's findings: "bad", "warn" or "ok".

    Examples
    --------
    >>> verdict_level([("ok", "sound"), ("warn", "few views")])
    'warn'
    """
    levels = {level for level, _ in findings}
    return next((lv for lv in ("bad", "warn") if lv in levels), "ok")


@contextmanager
def _sigterm_interrupts():
    """While active (main thread only), ``SIGTERM`` interrupts as Ctrl-C does: a
    :class:`sogdd.collection.BatchInterrupted` carrying the signal's number (exit code 143)."""
    from ..collection import BatchInterrupted

    def interrupt(signum, _frame):
        raise BatchInterrupted(signum)

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)
