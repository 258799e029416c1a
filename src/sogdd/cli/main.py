"""Entry point of the sogdd command.

Each command lives in its own module of this package, imported only when that
command runs (so that sogdd --help stays fast), and exposes configure(parser),
which adds its arguments and sets func: a callable taking the parsed
argparse.Namespace and returning an exit code. Errors a user can fix (bad
files, bad parameters) are raised as ValueError or OSError and reported here as
one line on stderr with exit code 2, never as a traceback.

Stdout is flushed before the exit code is returned, so a write error (a full
disk) is such an error too, never exit 0 with a truncated output. A reader that
closes the pipe early (sogdd detect ... | head -1) ends the command quietly
with exit code 141 (128 + SIGPIPE), what a shell reports for cat or seq in the
same place: the output was not all read, and a script with pipefail sees it.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence

from .._version import __version__
from ._common import HelpFormatter, OutputClosed

__all__ = ["COMMANDS", "build_parser", "main"]

#: command -> one-line help, in the order of ``sogdd --help``; the module is ``sogdd.cli.<command>``
COMMANDS = {
    "detect": "detect corners in images",
    "response": "write the corner measure map (.npy)",
    "demo": "run on a built-in example and write an overlay",
    "calibrate": "calibrate a camera from images of a chessboard or ChArUco board",
    "theory": "the paper's corner theory: figures, sigma ranges, tables",
    "eval": "evaluate detectors: GT accuracy, repeatability, resolution, matching, SfM",
    "report": "run the evaluations and write the results page (Markdown + figures)",
    "colmap": "COLMAP interoperability (needs pycolmap)",
    "convert": "convert a calibration to or from ROS, Kalibr, mrcal and COLMAP files",
    "check": "check new views against a stored calibration: pass, warn or fail",
}


def _command_of(argv: Sequence[str]) -> str | None:
    """The command named in ``argv`` (the main parser's own options take no values)."""
    for a in argv:
        if not a.startswith("-"):
            return a if a in COMMANDS else None
    return None


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line, ``sogdd: error: <command>: ...``, exit code 2 (sub-parsers inherit it)."""

    def error(self, message: str):
        where = self.prog.removeprefix("sogdd").strip()
        print(f"sogdd: error: {where + ': ' if where else ''}{message} (see {self.prog} --help)",
              file=sys.stderr)
        sys.exit(2)


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The ``sogdd`` parser: every command listed, only the one in ``argv`` configured.

    With ``argv=None`` every command is configured (all modules imported).
    """
    parser = _Parser(prog="sogdd", description="High-resolution corner detection with SOGDD "
                     "filters.", formatter_class=HelpFormatter)
    parser.add_argument("--version", action="version", version=f"sogdd {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    wanted = None if argv is None else _command_of(argv)
    for name, text in COMMANDS.items():
        p = sub.add_parser(name, help=text, description=text, formatter_class=HelpFormatter)
        if argv is None or name == wanted:
            importlib.import_module(f"sogdd.cli.{name}").configure(p)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``sogdd`` with ``argv`` (default: the process's arguments); return the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(argv)
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help(sys.stderr)
        return 2
    try:
        code = int(args.func(args) or 0)
        try:
            sys.stdout.flush()  # a write error shows now, as an error, not at exit (or never)
        except BrokenPipeError:
            raise OutputClosed() from None
        return code
    except OutputClosed:
        return _reader_gone()
    except (ValueError, OSError) as exc:
        print(f"sogdd: error: {_message(exc)}", file=sys.stderr)
        return 2
    except Exception as exc:  # an OpenCV error is one line too (cv2 is not imported just to name it)
        if type(exc).__module__ != "cv2":
            raise
        from ..image.files import opencv_message

        print(f"sogdd: error: {opencv_message(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:  # Ctrl-C: 130; a batch or a calibration stopped by SIGTERM: 143
        return 128 + int(getattr(exc, "signum", 2))


def _message(exc: Exception) -> str:
    """One line for ``exc``: an OSError without a file name by its own text, without ``[Errno N]``."""
    if isinstance(exc, OSError) and exc.strerror and exc.filename is None:
        return exc.strerror
    return str(exc)


def _reader_gone() -> int:
    """Stdout's reader has gone: point stdout at /dev/null, so that the interpreter's last flush
    finds nowhere to fail, and return 141 (128 + SIGPIPE)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):  # a stream without a descriptor has nothing left to flush
        pass
    return 141


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
