"""Every name the README and the docs mention imports; the public API survives its own submodules."""

from __future__ import annotations

import importlib
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import sogdd

REPO = Path(__file__).resolve().parents[1]
# the README, the changelog, the contributors' guide and every page of the documentation site
TEXTS = [REPO / "README.md", REPO / "CHANGELOG.md", REPO / "CONTRIBUTING.md",
         *sorted(p for p in (REPO / "docs").rglob("*.md") if "_build" not in p.parts)]
TEXTS = [p for p in TEXTS if p.is_file()]
# a dotted sogdd name not inside a path (src/sogdd/x.py) or a file name (sogdd.egg-info)
DOTTED = re.compile(r"(?<![\w/.-])sogdd(?:\.[A-Za-z_]\w*)+(?![\w-])")
FROM_IMPORT = re.compile(r"from (sogdd[\w.]*) import ([\w, ]+)")
# the changelog's table of what 0.2.0 renamed: its left column names what no longer exists
RENAMED = re.compile(r"<!-- renamed-in-0.2 -->\n(.*?)<!-- /renamed-in-0.2 -->", re.S)


def mentioned_names() -> list[str]:
    names = set()
    for p in TEXTS:
        text = RENAMED.sub("", p.read_text())
        names |= set(DOTTED.findall(text))
        for mod, items in FROM_IMPORT.findall(text):
            names |= {f"{mod}.{n.strip()}" for n in items.split(",") if n.strip()}
    return sorted(names)


def resolve(dotted: str):
    """The object a dotted name means: the longest importable module, then attributes."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr)
        return obj
    raise ImportError(dotted)


@pytest.mark.skipif(not (REPO / "README.md").is_file(), reason="needs the repository checkout")
def test_every_name_in_the_readme_and_docs_imports():
    names = mentioned_names()
    assert len(names) > 40  # the scan finds the names (README and docs use dozens)
    missing = []
    for n in names:
        try:
            resolve(n)
        except (ImportError, AttributeError):
            missing.append(n)
    assert missing == []


@pytest.mark.skipif(not (REPO / "CHANGELOG.md").is_file(), reason="needs the repository checkout")
def test_the_renamed_table_is_honest():
    """Every 0.1 name the changelog lists as renamed is gone, and every 0.2.0 name it gives imports."""
    table = RENAMED.search((REPO / "CHANGELOG.md").read_text())
    assert table is not None
    rows = [r.split("|")[1:3] for r in table.group(1).splitlines()[2:]]
    assert len(rows) >= 10
    old = {n for left, right in rows for n in DOTTED.findall(left) if n not in DOTTED.findall(right)}
    new = {n for _, right in rows for n in DOTTED.findall(right)}
    assert len(old) >= 10
    for n in old:
        with pytest.raises((ImportError, AttributeError)):
            resolve(n)
    for n in new:
        resolve(n)


def test_the_scan_would_catch_an_old_module_path():
    with pytest.raises((ImportError, AttributeError)):
        resolve("sogdd.peaks.select_peaks")  # 0.1's path, gone in 0.2.0 (sogdd.select.select_peaks)
    assert DOTTED.findall("see src/sogdd/detector.py and sogdd.egg-info, but sogdd.select.peaks") == [
        "sogdd.select.peaks"]


def test_everything_in_all_imports():
    for name in sogdd.__all__:
        assert getattr(sogdd, name) is not None


def test_describe_is_the_function_after_the_class_and_colmap_are_used():
    """0.1's bug: importing the submodule sogdd/describe.py replaced the function sogdd.describe."""
    code = (
        "import numpy as np, sogdd, sogdd.formats.colmap\n"
        "from sogdd.synthetic import pattern_image\n"
        "img, _ = pattern_image((120, 160))\n"
        "det = sogdd.SOGDD(max_corners=20)\n"
        "kp, d = det.detectAndCompute(np.dstack([img] * 3), None)\n"
        "c = sogdd.detect_corners(img, max_corners=20)\n"
        "desc = sogdd.describe(img, c)\n"
        "assert callable(sogdd.describe) and desc.shape == (len(c), 128), desc.shape\n"
        "print('ok', len(kp), desc.shape[0])\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.startswith("ok ")


def test_no_public_function_shares_its_name_with_a_module():
    root = Path(sogdd.__file__).parent
    modules = {p.stem for p in root.glob("*.py")}
    modules |= {p.name for p in root.iterdir() if (p / "__init__.py").is_file()}
    assert modules.isdisjoint(set(sogdd.__all__)), modules & set(sogdd.__all__)
    assert np.isfinite(sogdd.corner_response(np.eye(8)).sum())  # the lazy exports load


@pytest.mark.skipif(not (REPO / "tests").is_dir(), reason="needs the repository checkout")
def test_every_repository_file_the_docs_name_exists():
    """Paths such as tests/gpu/test_gpu.py or benchmarks/bench_speed.py, as the README and docs cite them."""
    cited = set()
    for p in TEXTS:
        cited |= set(re.findall(r"(?<![\w/.])((?:tests|benchmarks|tools|studies)/[\w/.-]+\.py)", p.read_text()))
    assert len(cited) > 10
    assert sorted(c for c in cited if not (REPO / c).is_file()) == []
