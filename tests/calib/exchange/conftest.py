"""The exchange tests' shared fixture: the system Python with mrcal's module (Debian's python3-mrcal)."""

from __future__ import annotations

import subprocess
from functools import cache

import pytest

#: mrcal's Python module is for the system Python, not the venv's
SYSTEM_PYTHON = "/usr/bin/python3"


@cache
def _mrcal_here() -> bool:
    try:
        run = subprocess.run([SYSTEM_PYTHON, "-c", "import mrcal"], capture_output=True, timeout=60)
        return run.returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


@pytest.fixture
def mrcal_python() -> str:
    """The interpreter that imports mrcal; the test is skipped where there is none."""
    if not _mrcal_here():
        pytest.skip("mrcal's Python module is not installed for /usr/bin/python3 "
                    "(apt-get install python3-mrcal)")
    return SYSTEM_PYTHON
