"""What a batch reports: a :class:`BatchItem` per image; :class:`BatchInterrupted` when a signal stops it."""

from __future__ import annotations

import signal
from dataclasses import dataclass

__all__ = ["BatchInterrupted", "BatchItem"]


@dataclass(frozen=True)
class BatchItem:
    """The outcome for one image: ``status`` is "done", "skipped" or "failed"."""

    image: str
    status: str
    n: int = 0
    message: str = ""


class BatchInterrupted(KeyboardInterrupt):
    """A batch stopped by a signal; ``signum`` says which, ``items`` holds what finished."""

    def __init__(self, signum: int, items: list | None = None):
        super().__init__(f"interrupted by {signal.Signals(signum).name}")
        self.signum = int(signum)
        self.items = list(items or [])
