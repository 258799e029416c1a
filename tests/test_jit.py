"""sogdd._jit: numba's on-disk cache notices an edited callee in another module; compile-time arguments."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import sogdd
from sogdd._jit import elimination, sources_key, window_rows

CALLEE = """import numba
from sogdd._jit import JIT


@numba.njit(**JIT)
def value():
    return {value}
"""
CALLER = """import numba
from sogdd._jit import JIT
from sogdd.{pkg}._probe_callee import value


@numba.njit(**JIT)
def twice():
    return 2 * value()
"""
RUN = "from sogdd.{pkg}._probe_caller import twice; print(twice(), sum(twice.stats.cache_hits.values()))"
#: a core folder, and a client's whose modules' compiled code calls each other's (the chessboard lattice)
FOLDERS = ("measure", "calib/targets/chessboard")


def _copy_package(tmp_path: Path, folder: str = "measure") -> Path:
    """A copy of the package, with a compiled caller in one module of ``folder`` and its callee in another."""
    root = tmp_path / "pkg"
    shutil.copytree(Path(sogdd.__file__).parent, root / "sogdd",
                    ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    pkg = folder.replace("/", ".")
    (root / "sogdd" / folder / "_probe_caller.py").write_text(CALLER.format(pkg=pkg))
    (root / "sogdd" / folder / "_probe_callee.py").write_text(CALLEE.format(value=1))
    return root


def _run(root: Path, cache: Path | None, folder: str = "measure") -> tuple[int, int]:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(root)
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = str(cache)
    code = RUN.format(pkg=folder.replace("/", "."))
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, cwd=root)
    assert done.returncode == 0, done.stderr
    result, hits = done.stdout.split()
    return int(result), int(hits)


@pytest.mark.parametrize("folder", FOLDERS)
@pytest.mark.parametrize("where", ["NUMBA_CACHE_DIR", "__pycache__"])
def test_the_cache_notices_an_edited_callee_in_another_module(tmp_path, where, folder):
    root = _copy_package(tmp_path, folder)
    cache = tmp_path / "cache" if where == "NUMBA_CACHE_DIR" else None
    assert _run(root, cache, folder) == (2, 0)  # compiled, and saved
    assert _run(root, cache, folder) == (2, 1)  # loaded from the cache
    (root / "sogdd" / folder / "_probe_callee.py").write_text(CALLEE.format(value=5))
    # numba alone checks the caller's own file, unchanged: it would load 2 * 1 again
    assert _run(root, cache, folder) == (10, 0)
    assert _run(root, cache, folder) == (10, 1)


def test_sources_key_covers_the_core_and_the_version(tmp_path):
    root = _copy_package(tmp_path)
    code = "from sogdd._jit import sources_key; print(sources_key())"

    def key() -> str:
        env = dict(os.environ, PYTHONPATH=str(root))
        return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                              check=True).stdout.strip()

    first = key()
    assert first == key() and len(first) == 64
    version = root / "sogdd" / "_version.py"
    version.write_text(version.read_text() + "\n# another build\n")
    second = key()
    assert second != first
    report = root / "sogdd" / "report" / "overlays.py"  # a client: compiled code never imports it
    report.write_text(report.read_text() + "\n# edited\n")
    assert key() == second
    assert len(sources_key()) == 64


def test_compile_time_arguments():
    assert elimination(8) == (0,) * 8 and elimination(6) == (0,) * 6 and elimination(4) == (0,) * 4
    assert elimination(3) == () and elimination(5) == () and elimination(12) == ()
    assert window_rows(7) == (0,) * 7 and window_rows(5) == () and window_rows(3) == ()
