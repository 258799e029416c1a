"""Figures on a page from the commands that make them: blocks between markers, rewritten.

A block is the text between ``<!-- results:NAME -->`` and
``<!-- /results:NAME -->`` in a Markdown page (the README or a page of the
documentation). The command that computes a figure (``sogdd report --readme
docs/reproducing/index.md``, ``benchmarks/bench_exactness.py --readme
docs/explanations/exactness.md``) writes the block from the same run as its own
results, so the two never drift apart.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from ..formats.safe_write import write_text

__all__ = ["readme_blocks", "sync_readme"]


def _pattern(name: str) -> re.Pattern:
    n = re.escape(name)
    return re.compile(rf"(<!-- results:{n} -->\n)(.*?)(<!-- /results:{n} -->)", re.S)


def readme_blocks(text: str) -> dict[str, str]:
    """Every block of a README text, by name.

    Examples
    --------
    >>> readme_blocks("a\\n<!-- results:gt -->\\nold\\n<!-- /results:gt -->\\nb")
    {'gt': 'old\\n'}
    """
    return {m.group(1): m.group(2) for m in
            re.finditer(r"<!-- results:([\w-]+) -->\n(.*?)<!-- /results:\1 -->", text, re.S)}


def sync_readme(path: str | os.PathLike, blocks: dict[str, str]) -> list[str]:
    """Replace the named blocks of the README at ``path``; return the names that changed.

    Raises ``ValueError`` (one line) when a block's markers are missing, so a
    renamed section is an error rather than a figure silently left stale.

    Examples
    --------
    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "README.md"
    >>> _ = p.write_text("x\\n<!-- results:gt -->\\nold\\n<!-- /results:gt -->\\ny\\n")
    >>> sync_readme(p, {"gt": "new table\\n"})
    ['gt']
    >>> p.read_text()
    'x\\n<!-- results:gt -->\\nnew table\\n<!-- /results:gt -->\\ny\\n'
    """
    p = Path(path)
    text = p.read_text()
    changed = []
    for name, body in blocks.items():
        pat = _pattern(name)
        m = pat.search(text)
        if m is None:
            raise ValueError(f"{p}: no <!-- results:{name} --> ... <!-- /results:{name} --> block")
        body = body if body.endswith("\n") else body + "\n"
        if m.group(2) != body:
            changed.append(name)
            text = text[: m.start(2)] + body + text[m.end(2):]
    if changed:
        write_text(p, text)
    return changed
