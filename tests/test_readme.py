"""Every Python block of the README runs as pasted, on a rendered image written where it expects its file."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import cv2
import pytest

from sogdd.synthetic import pattern_image

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)
FILE = re.compile(r"""["']([\w./-]+\.(?:png|jpg|jpeg|tif|tiff|bmp|ppm))["']""")


def blocks() -> list[str]:
    return BLOCK.findall(README.read_text()) if README.is_file() else []


def _write_inputs(block: str, folder: Path, shape: tuple[int, int]) -> list[str]:
    """A rendered pattern (colour) at every image path the block names."""
    img, _ = pattern_image(shape)
    colour = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
    names = sorted(set(FILE.findall(block)))
    for n in names:
        (folder / n).parent.mkdir(parents=True, exist_ok=True)
        assert cv2.imwrite(str(folder / n), colour)
    return names


def _needs_gpu(block: str) -> bool:
    return 'device="cuda"' in block or "from sogdd import gpu" in block


@pytest.mark.skipif(not README.is_file(), reason="needs the repository checkout")
def test_the_readme_has_its_python_blocks():
    found = blocks()
    assert len(found) >= 2
    assert any("sogdd.detect_corners" in b for b in found)


@pytest.mark.parametrize("index", range(len(blocks())))
def test_readme_block_runs_as_pasted(index, tmp_path):
    block = blocks()[index]
    gpu = _needs_gpu(block)
    # the CUDA simulator runs every device thread in Python: a small image keeps it to seconds
    assert _write_inputs(block, tmp_path, (80, 96) if gpu else (480, 640)) or "read_image" not in block
    env = dict(os.environ)
    if gpu:
        try:
            from numba.cuda import simulator  # noqa: F401
        except ImportError:
            pytest.skip("numba's CUDA simulator cannot be imported")
        env["NUMBA_ENABLE_CUDASIM"] = "1"  # no GPU in CI: the same code on numba's simulator
    out = subprocess.run([sys.executable, "-c", block], cwd=tmp_path, env=env, capture_output=True,
                         text=True, timeout=600)
    assert out.returncode == 0, f"README block {index} failed:\n{block}\n{out.stderr[-3000:]}"


@pytest.mark.skipif(not README.is_file(), reason="needs the repository checkout")
def test_the_readme_is_a_short_page_with_the_quick_start_and_the_paper():
    text = README.read_text()
    assert len(text.splitlines()) <= 200  # a first read; the rest is on the documentation site
    assert "pip install . && sogdd demo" in text
    assert "pip install '.[test]' && pytest" in text
    assert "pip install '.[docs]' && sphinx-build -W -b html docs docs/_build/html" in text
    assert ("Second-order Gaussian directional derivative representations for image high-resolution corner "
            "detection") in " ".join(text.replace("\n> ", "\n").split())  # the citation is a block quote
    for part in ("LICENSE", "CITATION.cff", "CONTRIBUTING.md", "CHANGELOG.md"):
        assert f"]({part})" in text and (README.parent / part).is_file(), part
