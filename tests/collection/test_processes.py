"""Local worker processes: workers die with their parent under every start method of multiprocessing
(fork, the default up to Python 3.13; forkserver, the default from 3.14; spawn)."""

import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

WORK = '''
import time
from sogdd.collection.items import BatchItem

def work(name, *rest):
    time.sleep(60)
    return BatchItem(name, "done")
'''

PARENT = '''
import multiprocessing, os, signal, sys, threading, time
from slow_work import work
from sogdd.collection.processes import run_local

def die():
    while len(multiprocessing.active_children()) < 2:
        time.sleep(0.05)
    time.sleep(0.5)  # the workers are in their tasks
    with open(sys.argv[2], "w") as fh:
        fh.write(" ".join(str(p.pid) for p in multiprocessing.active_children()))
    os.kill(os.getpid(), signal.SIGKILL)

if __name__ == "__main__":
    multiprocessing.set_start_method(sys.argv[1])
    threading.Thread(target=die, daemon=True).start()
    run_local(work, [(f"a{i}",) for i in range(4)], 2, print)
'''


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("method", ["fork", "forkserver", "spawn"])
def test_workers_die_with_a_killed_parent_whatever_the_start_method(tmp_path, method):
    (tmp_path / "slow_work.py").write_text(WORK)
    (tmp_path / "parent.py").write_text(textwrap.dedent(PARENT))
    pids_file = tmp_path / "pids"
    proc = subprocess.run([sys.executable, str(tmp_path / "parent.py"), method, str(pids_file)], cwd=tmp_path,
                          capture_output=True, timeout=120)
    assert proc.returncode == -9, proc.stderr.decode()[-2000:]
    pids = [int(p) for p in pids_file.read_text().split()]
    assert len(pids) >= 2
    end = time.monotonic() + 120  # a guard against waiting for ever, not a limit
    while any(_alive(p) for p in pids) and time.monotonic() < end:
        time.sleep(0.05)
    assert not any(_alive(p) for p in pids), f"workers outlived their parent ({method})"
