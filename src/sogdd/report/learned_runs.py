"""The learned detectors' repeatability rows of the results page, read from cached runs.

ALIKED and DISK cost about an hour of repeatability on two cores, XFeat
minutes, and their results do not depend on sogdd's core. So they are run
once, each on its own, by ``python benchmarks/bench_learned.py repeatability``
(:data:`RUN_COMMAND`), into ``figures/repeatability_learned/<name>/`` next to
the page, and ``sogdd report`` reads them (:func:`read_cached`) instead of
running them. A cached run is used only when its protocol
(:meth:`~sogdd.evaluation.repeatability.RepeatabilityReport.protocol`: the
grid, transform by transform; the images by name and pixel digest; a digest
of what the transform code makes of the first image; the seed, the top-N, the
match radius, the margin, the families) is the one the report
has just run for the other detectors; otherwise it is named on the page as
stale, with what differs, and left out. A run whose rows the report ran
itself, or that a run read before already gave, is left out as a duplicate.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

from ..evaluation.repeatability import RUN_FILE, RepeatabilityReport

__all__ = ["RUNS_DIR", "RUN_COMMAND", "CachedRuns", "protocol_differences", "read_cached", "cached_note"]

#: the folder of the cached runs, next to the page's ``figures/results/``
RUNS_DIR = "repeatability_learned"
#: how they are made (``--full`` added for the paper's grid); one sub-folder per detector
RUN_COMMAND = "python benchmarks/bench_learned.py repeatability --out {dir}"


def protocol_differences(want: dict, have: dict) -> list[str]:
    """What a cached run's protocol ``have`` changes in ``want`` (empty: the same test).

    Examples
    --------
    >>> a = {"quick": True, "top_n": 500, "grid": {"jpeg": ["q=5", "q=50"]}, "images": [["a.bmp", "01"]]}
    >>> protocol_differences(a, a)
    []
    >>> b = {**a, "top_n": 300, "grid": {"jpeg": ["q=5"]}, "images": [["a.bmp", "02"]]}
    >>> protocol_differences(a, b)
    ['top_n 300, not 500', 'grid of jpeg (1 transforms, not 2)', 'image a.bmp has other pixels']
    """
    out = []
    for k in sorted(set(want) | set(have), key=lambda k: (k in ("grid", "images"), k)):
        w, h = want.get(k), have.get(k)
        if w == h:
            continue
        if k == "grid" and want.get("quick") != have.get("quick"):
            continue  # the other grid is said by "quick"
        if k == "grid" and isinstance(w, dict) and isinstance(h, dict):
            out += [f"grid of {f} ({len(h.get(f) or [])} transforms, not {len(w.get(f) or [])})"
                    for f in sorted(set(w) | set(h)) if w.get(f) != h.get(f)]
        elif k == "images" and isinstance(w, list) and isinstance(h, list):
            wn, hn = dict(map(tuple, w)), dict(map(tuple, h))
            if list(wn) != list(hn):
                out.append(f"images {len(hn)} ({', '.join(sorted(set(hn) ^ set(wn))) or 'another order'}), "
                           f"not {len(wn)}")
            else:
                out += [f"image {n} has other pixels" for n in wn if wn[n] != hn[n]]
        else:
            out.append(f"{k} {h}, not {w}")
    return out


@dataclass
class CachedRuns:
    """What :func:`read_cached` found: the matching runs merged, and the ones left out with why."""

    folder: Path
    report: RepeatabilityReport | None = None
    used: list[tuple[Path, list[str]]] = field(default_factory=list)
    stale: list[tuple[Path, list[str]]] = field(default_factory=list)

    @property
    def seconds(self) -> float:
        """The run time the cached rows cost when they were made."""
        return self.report.seconds if self.report is not None else 0.0


def read_cached(folder: str | os.PathLike, live: RepeatabilityReport) -> CachedRuns:
    """The cached runs under ``folder`` (every :data:`RUN_FILE`, in path order) that share ``live``'s protocol.

    ``live`` is the report's own run; its rows are never replaced. A run that
    cannot be read, whose protocol differs (:func:`protocol_differences`) or
    whose rows are already there is put in ``stale`` with the reasons.

    Examples
    --------
    >>> read_cached("/no/such/folder", None).used
    []
    """
    found = CachedRuns(Path(folder))
    if not found.folder.is_dir():
        return found
    have = set(live.specs)
    for path in sorted(found.folder.rglob(RUN_FILE)):
        try:
            run = RepeatabilityReport.from_run_json(json.loads(path.read_text()))
        except (OSError, ValueError, KeyError, TypeError) as exc:
            found.stale.append((path, [f"unreadable ({' '.join(str(exc).split()) or type(exc).__name__})"]))
            continue
        why = protocol_differences(live.protocol(), run.protocol())
        dup = sorted(set(run.specs) & have)
        if dup and not why:
            why = [f"rows {', '.join(dup)} already on the page"]
        if why:
            found.stale.append((path, why))
            continue
        found.report = run if found.report is None else found.report.merged(run)
        found.used.append((path, list(run.specs)))
        have |= set(run.specs)
    return found


def cached_note(found: CachedRuns, page_dir: str | os.PathLike, *, full: bool = False) -> str:
    """The page's paragraph on the cached rows: where they come from, how to make them, which were stale."""
    rel = os.path.relpath(found.folder, page_dir)
    # the command runs where the report runs (the repository root), the links are the page's
    cmd = "`" + RUN_COMMAND.format(dir=os.path.relpath(found.folder)) + (" --full" if full else "") + "`"
    parts = []
    if found.used:
        rows = ", ".join(f"`{s}`" for _, specs in found.used for s in specs)
        parts.append(f"The rows {rows} (both modes) are read from the cached runs in `{rel}/` (made by {cmd} "
                     f"in a venv with the `learned` extra; {found.seconds / 60:.0f} min of run time), not "
                     "re-run by `sogdd report`: their protocol (grid, images and their pixels, transform code, "
                     "seed, top-N) was checked to be the one run here.")
    else:
        parts.append(f"No cached learned run matches this protocol in `{rel}/`: the learned rows are made by "
                     f"{cmd} in a venv with the `learned` extra, and read from there.")
    if found.stale:
        parts.append("Left out as stale: " + "; ".join(
            f"`{os.path.relpath(p, page_dir)}` ({', '.join(why)})" for p, why in found.stale) + ".")
    return "\n" + " ".join(parts) + "\n"
