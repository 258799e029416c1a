"""Which rows of the results page need the ``learned`` extra, said under each table.

The learned registry entries (``xfeat``, ``aliked``, ``disk``) run only where
``sogdd[learned]`` is installed (:mod:`sogdd.baselines.learned_extra`); the
evaluations add their rows there and leave them out elsewhere. A reader of the
page must know which rows a plain install will not reproduce, and, on a page
made without the extra, that those rows are missing rather than lost.
"""

from __future__ import annotations

from collections.abc import Iterable

from ..baselines import learned_extra, registered

__all__ = ["learned_labels", "learned_note"]


def _name(label: str) -> str:
    """The registry name of a row label (``xfeat:desc=native:top_k=2000`` -> ``xfeat``;
    fixed-count labels such as ``xfeat [top-500]`` -> ``xfeat``)."""
    return label.split(":", 1)[0].split(" ", 1)[0].strip("`")


def learned_labels(labels: Iterable[str]) -> list[str]:
    """The labels (in order, once each) whose detector is a learned registry entry.

    Examples
    --------
    >>> learned_labels(["sift", "xfeat:desc=native", "aliked [top-500]", "sogdd", "xfeat:desc=native"])
    ['xfeat:desc=native', 'aliked [top-500]']
    """
    reg = registered()
    return [lab for lab in dict.fromkeys(labels)
            if _name(lab) in reg and reg[_name(lab)].family == "learned"]


def learned_note(labels: Iterable[str]) -> str:
    """One Markdown paragraph for under a table: its rows that need the extra, or that they are absent.

    Empty where the table has no learned rows and the extra is installed (the
    evaluation chose to run none).

    Examples
    --------
    >>> "needs the `learned` extra" in learned_note(["sift", "xfeat"])
    True
    >>> learned_note(["sift"]) == ("" if learned_extra.installed() else learned_note([]))
    True
    """
    rows = learned_labels(labels)
    if rows:
        return ("\nEach of the rows " + ", ".join(f"`{r}`" for r in rows) + " needs the `learned` extra "
                f"(`{learned_extra.INSTALL}`; docs/learned.md); a plain install leaves them out.\n")
    if learned_extra.installed():
        return ""
    return ("\nThe learned detectors (`xfeat`, `aliked`, `disk`) have no rows here: the `learned` extra is not "
            f"installed where this page was made (`{learned_extra.INSTALL}`; docs/learned.md).\n")
