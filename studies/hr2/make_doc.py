"""Regenerate the tables of docs/hr2.md (between the generated markers) from ``studies/hr2/results/``.

    python studies/hr2/make_doc.py
"""

from __future__ import annotations

import contextlib
import io
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import tables  # noqa: E402

DOC = HERE.parent.parent / "docs" / "hr2.md"
BEGIN, END = "<!-- generated:begin -->", "<!-- generated:end -->"


def generated() -> str:
    parts = []
    for half, title in (("dev", "Development half (screening)"), ("conf", "Confirmation half"),
                        ("full", "Full scenes and all pairs (the issue's protocol)")):
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            tables.main(["--half", half])
        text = buf.getvalue().replace("### ", "#### ")
        parts.append(f"### {title}\n\n{text}")
    return "\n".join(parts)


def main() -> int:
    doc = DOC.read_text()
    body = f"{BEGIN}\n\n{generated()}\n{END}"
    if BEGIN in doc:
        head, rest = doc.split(BEGIN, 1)
        doc = head + body + rest.split(END, 1)[1]
    else:
        doc = doc.rstrip() + "\n\n## 4. Results\n\n" + body + "\n"
    DOC.write_text(doc)
    return 0


if __name__ == "__main__":
    sys.exit(main())
