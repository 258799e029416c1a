"""The rig's frames: which image of each camera was taken at the same moment.

A frame is one pose of the board seen by every camera at once. The cameras' images are
matched by the number in their file names, the last run of digits in the stem
(``left12.jpg`` and ``right12.png``, ``cam0_000012.png`` and ``cam1_12.png``: frame 12),
or, when no file name holds a number, by their rank in sorted order. A frame that one
camera lacks is an error unless it is explicitly allowed (``allow_missing``): a missing
file is more often a copy gone wrong than a camera that did not fire, and matching the
rest silently would pair images of different moments. Nor can the names prove the pairing:
:func:`check_pairing` tests it on the poses the frames give (the rig fit calls it).
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

__all__ = ["SHIFTS", "check_pairing", "frame_number", "match_frames"]

_DIGITS = re.compile(r"\d+")
#: how many of a camera's missing frame numbers an error names
_SHOWN = 5
#: the shifts of one camera's frames against another's that :func:`check_pairing` tries
SHIFTS = (1, -1, 2, -2, 3, -3)


def frame_number(path: str | os.PathLike) -> int | None:
    """The frame number of an image file: the last run of digits in its stem (None without one).

    Examples
    --------
    >>> frame_number("left/cam0_000012.png"), frame_number("right12.jpg"), frame_number("left.png")
    (12, 12, None)
    """
    runs = _DIGITS.findall(Path(os.fspath(path)).stem)
    return int(runs[-1]) if runs else None


def _numbers(few: Sequence[int]) -> str:
    shown = ", ".join(str(n) for n in sorted(few)[:_SHOWN])
    return shown + (f" and {len(few) - _SHOWN} more" if len(few) > _SHOWN else "")


def match_frames(cameras: Mapping[str, Sequence[str | os.PathLike]], *, allow_missing: bool = False
                 ) -> tuple[tuple[str, ...], dict[str, tuple[str | None, ...]]]:
    """Match the cameras' image files into frames (module doc).

    Parameters
    ----------
    cameras : mapping of str to sequence of paths
        Each camera's image files, in any order.
    allow_missing : bool
        With frame numbers: a frame some cameras lack is kept, their image of it
        ``None`` (that camera's view of the frame is absent). By default such a
        frame is an error. Without numbers (matching by rank) the counts must agree
        either way.

    Returns
    -------
    frames : tuple of str
        A name per frame: its number (``"12"``, without leading zeros), in
        increasing order; or, matched by rank, ``"1"``, ``"2"``, ... in sorted order
        of the file names.
    paths : dict of str to tuple
        Per camera, its image file of each frame (as given; ``None`` where it
        has none, with ``allow_missing``).

    Raises
    ------
    ValueError
        One line: a camera without images; some file names with a number and
        others without; two files of one camera with the same number; frames
        one camera has and another lacks (naming a few numbers each lacks);
        matched by rank, different counts.

    Examples
    --------
    >>> frames, paths = match_frames({"left": ["l/left2.png", "l/left10.png"],
    ...                               "right": ["r/cam1_0010.png", "r/cam1_0002.png"]})
    >>> frames, paths["right"]
    (('2', '10'), ('r/cam1_0002.png', 'r/cam1_0010.png'))
    >>> match_frames({"left": ["left1.png", "left2.png", "left3.png"], "right": ["right1.png"]})
    Traceback (most recent call last):
    ...
    ValueError: the cameras' frames do not match (by the number in the file names): right lacks frames 2, 3; \
give the same frames to every camera, or allow missing frames
    """
    given = {name: [os.fspath(p) for p in files] for name, files in cameras.items()}
    for name, files in given.items():
        if not files:
            raise ValueError(f"camera {name}: no input images")
    numbers = {name: [frame_number(f) for f in files] for name, files in given.items()}
    flat = [(name, f, n) for name in given for f, n in zip(given[name], numbers[name])]
    without = [(name, f) for name, f, n in flat if n is None]
    if len(without) == len(flat):
        return _by_rank(given)
    if without:
        name, f = without[0]
        with_one = next(f for _, f, n in flat if n is not None)
        raise ValueError(f"camera {name}: {f} has no frame number in its name while {with_one} has; frames "
                         "are matched by the number in the file names (or by sorted order when none has one)")
    by_number: dict[str, dict[int, str]] = {}
    for name, files in given.items():
        seen: dict[int, str] = {}
        for f, n in zip(files, numbers[name]):
            if n in seen:
                raise ValueError(f"camera {name}: {seen[n]} and {f} both have frame number {n}; one image "
                                 "per camera per frame")
            seen[n] = f
        by_number[name] = seen
    every = sorted(set().union(*(set(s) for s in by_number.values())))
    lacking = {name: [n for n in every if n not in s] for name, s in by_number.items()}
    if not allow_missing and any(lacking.values()):
        what = "; ".join(f"{name} lacks frame{'s' if len(few) > 1 else ''} {_numbers(few)}"
                         for name, few in lacking.items() if few)
        raise ValueError(f"the cameras' frames do not match (by the number in the file names): {what}; give "
                         "the same frames to every camera, or allow missing frames")
    return (tuple(str(n) for n in every),
            {name: tuple(s.get(n) for n in every) for name, s in by_number.items()})


def _by_rank(given: dict[str, list[str]]) -> tuple[tuple[str, ...], dict[str, tuple[str | None, ...]]]:
    """No file name holds a number: the k-th file of each camera in sorted order is frame k."""
    counts = {name: len(files) for name, files in given.items()}
    if len(set(counts.values())) > 1:
        what = ", ".join(f"{name} {n}" for name, n in counts.items())
        raise ValueError(f"the cameras have different numbers of images ({what}); without frame numbers in "
                         "the file names the frames are matched by sorted order, which needs the same count")
    n = next(iter(counts.values()))
    return tuple(str(k + 1) for k in range(n)), {name: tuple(sorted(files)) for name, files in given.items()}


def check_pairing(first: str, second: str, off: int, shared: int, names_first: Sequence[str],
                  names_second: Sequence[str], shifted: Callable[[int], tuple | None]) -> None:
    """Stop (``ValueError``, one line) when the frames two cameras share do not agree on the pose between
    them: when most disagree, or when pairing ``second``'s frames shifted by one of :data:`SHIFTS` makes
    more of them agree.

    Each camera's own calibration gives the board's pose :math:`P_{c,f}` in it, frame by frame, whatever
    the pairing; the frames of a rig agree on one relative pose :math:`P_{2,f} P_{1,f}^{-1}` only when
    each pairs images of one moment. Images paired one moment off (a file renamed, a camera that missed
    a trigger) each give another relative pose, and a joint fit of them bends every camera's intrinsics
    to reconcile them. With ``a_s`` of ``n_s`` frames agreeing with the consensus when ``second``'s frame
    ``f + s`` is paired with ``first``'s frame ``f``, the pairing stops when ``2 off > shared``, or when the
    best shift has ``2 a_s > n_s`` and ``a_s > shared - off``; the error names that shift if there is one.

    Parameters
    ----------
    first, second : str
        The cameras' names.
    off, shared : int
        Of the frames both used, how many disagree with the consensus, and how many there are.
    names_first, names_second : sequence of str
        Each camera's view name (its image file) per frame.
    shifted : callable
        ``shifted(s)``: ``(..., disagreeing, shared)`` (the last two items) with ``second``'s frames
        shifted by ``s``, or None without a shared frame.

    Examples
    --------
    >>> check_pairing("left", "right", 1, 12, ["l1"] * 14, ["r1"] * 14, lambda s: (0, 12 - abs(s)))
    >>> check_pairing("left", "right", 11, 12, [f"l{k}" for k in range(14)], [f"r{k}" for k in range(14)],
    ...               lambda s: (0, 11) if s == 1 else (10, 11))
    Traceback (most recent call last):
    ...
    ValueError: the shared frames disagree: in 11 of the 12 frames cameras left and right both used, the pose \
between them is not the one the other frames give, so their images are not paired by the moment they were \
taken; with camera right's frames shifted by +1 (l0 with r1, l1 with r2, ...), 11 of 11 agree: camera \
right's file names (or their order) look 1 frame(s) off; rename them so that each frame's images share its \
number, then run again
    """
    tried = []
    for s in SHIFTS:
        rel = shifted(s)
        if rel is not None:
            tried.append((rel[-1] - rel[-2], rel[-1], s))
    best = max(tried, key=lambda x: (x[0], -abs(x[2])), default=None)
    fits = best is not None and 2 * best[0] > best[1] and best[0] > shared - off
    if 2 * off <= shared and not fits:
        return
    head = (f"the shared frames disagree: in {off} of the {shared} frames cameras {first} and {second} both "
            "used, the pose between them is not the one the other frames give, so their images are not paired "
            "by the moment they were taken")
    if best is None or not fits:
        raise ValueError(f"{head}, and no shift of the pairing by up to {max(SHIFTS)} frames makes them "
                         "agree: check that the cameras were synchronised and that each frame's images are of "
                         "one moment")
    k, total, s = best
    F = len(names_first)
    shown = ", ".join(f"{names_first[f]} with {names_second[f + s]}"
                      for f in range(max(0, -s), min(F, F - s))[:2])
    raise ValueError(f"{head}; with camera {second}'s frames shifted by {s:+d} ({shown}, ...), {k} of {total} "
                     f"agree: camera {second}'s file names (or their order) look {abs(s)} frame(s) off; rename "
                     "them so that each frame's images share its number, then run again")
