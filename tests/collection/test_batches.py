"""Batches keep every good result : names, dying workers, signals, resume."""

import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

import sogdd
from sogdd import collection
from sogdd.collection import BatchInterrupted, expand_inputs, feature_path, processes, relative_names, run_batch
from sogdd.formats.features import read_features
from sogdd.synthetic import pattern_image


def _images(folder: Path, n: int, shape=(120, 160), prefix="im") -> list[Path]:
    """``n`` different images: shifted copies of one rendered pattern (rendering each is slow)."""
    folder.mkdir(parents=True, exist_ok=True)
    base = pattern_image(shape, seed=0)[0]
    out = []
    for i in range(n):
        p = folder / f"{prefix}{i}.png"
        cv2.imwrite(str(p), np.roll(base, (7 * i, 11 * i), axis=(0, 1)))
        out.append(p)
    return out


def test_same_file_names_in_different_folders_never_collide(tmp_path):
    a = _images(tmp_path / "src" / "a", 1)[0]
    b = tmp_path / "src" / "b" / "im0.png"
    b.parent.mkdir()
    cv2.imwrite(str(b), pattern_image((120, 160), seed=7)[0])  # different content, same name
    items = run_batch([a, b], tmp_path / "out")
    assert [i.status for i in items] == ["done", "done"]
    fa, fb = (read_features(tmp_path / "out" / d / "im0.png.npz")[0] for d in ("a", "b"))
    assert fa.image == str(a) and fb.image == str(b)
    assert not np.array_equal(fa.corners.xy, fb.corners.xy)
    assert relative_names([a, b]) == ["a/im0.png", "b/im0.png"]


def test_names_that_would_collide_fail_before_any_work(tmp_path):
    with pytest.raises(ValueError, match="A.png.*a.png|a.png.*A.png"):
        relative_names([tmp_path / "x" / "A.png", tmp_path / "x" / "a.png"])


def test_the_same_file_twice_is_processed_once(tmp_path):
    p = _images(tmp_path, 1)[0]
    assert expand_inputs([str(p), str(tmp_path), str(tmp_path / ".." / tmp_path.name / p.name)]) == [p]


def test_a_worker_killed_mid_image_loses_only_that_image(tmp_path, monkeypatch):
    paths = _images(tmp_path / "src", 4)
    bad = paths[1]
    real = collection.read_image

    def read_or_die(path, **kw):  # the OOM killer, deterministically, inside the worker
        if str(path) == str(bad):
            os.kill(os.getpid(), signal.SIGKILL)
        return real(path, **kw)

    monkeypatch.setattr(collection, "read_image", read_or_die)
    # forked workers inherit the patched reader (this test process may have run numba's parallel code,
    # which would otherwise start them from a forkserver that does not have it)
    monkeypatch.setattr(processes, "safe_start_method", lambda: "fork")
    items = run_batch(paths, tmp_path / "out", jobs=2)
    status = {Path(i.image).name: i.status for i in items}
    assert status == {"im0.png": "done", "im1.png": "failed", "im2.png": "done", "im3.png": "done"}
    assert "worker process died" in items[1].message and str(bad) in items[1].message


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-c", "import sys; from sogdd.cli.main import main; sys.exit(main())", *args]


def _children(pid: int) -> list[int]:
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                fields = (d / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                out.append(int(d.name))
    return out


def _alive(pid: int) -> bool:
    """Running, not a zombie waiting for init to reap it."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _wait_for(cond, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.05)
    return cond()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_signal_stops_a_parallel_batch_fast_and_keeps_finished_files(tmp_path, sig, code):
    # 4 small images, then 36 large ones: when the first 2 files exist, 34 or more large images
    # (seconds of work at any load) are still to do, so the signal always finds work in flight
    _images(tmp_path / "src", 4, prefix="a")
    _images(tmp_path / "src", 36, shape=(900, 1200), prefix="b")
    out = tmp_path / "out"
    env = {**os.environ, "SOGDD_NUM_THREADS": "1"}
    # SIGINT at its default in the child, as for a command run from a terminal: a shell without job
    # control starts background commands (nohup ... &, some CI runners) with SIGINT ignored, and
    # the CLI rightly keeps an ignored SIGINT ignored
    proc = subprocess.Popen(_cli("detect", str(tmp_path / "src"), "--out", str(out), "--jobs", "2"),
                            stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, env=env,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        assert _wait_for(lambda: len(list(out.glob("*.npz"))) >= 2, 120), "no feature file appeared"
        workers = _children(proc.pid)
        before = len(list(out.glob("*.npz")))
        proc.send_signal(sig)
        rc = proc.wait(timeout=300)  # a guard against a hang, not a limit: the stop is measured below
    finally:
        proc.kill()
    err = proc.stderr.read().decode()
    assert rc == code, err
    assert "Traceback" not in err and "interrupted" in err
    done = list(out.glob("*.npz"))
    # stopped at once: no image started after the signal (each of the 2 workers may finish the one it has)
    assert 2 <= before <= len(done) <= before + 2
    for f in done:
        sogdd.load_features(f)  # every kept file is whole
    assert not list(out.rglob("*.tmp"))
    assert _wait_for(lambda: not any(_alive(w) for w in workers), 120)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
def test_killing_the_parent_leaves_no_orphan_workers(tmp_path):
    _images(tmp_path / "src", 40, shape=(400, 600))
    out = tmp_path / "out"
    proc = subprocess.Popen(_cli("detect", str(tmp_path / "src"), "--out", str(out), "--jobs", "2"),
                            stderr=subprocess.DEVNULL, stdout=subprocess.DEVNULL)
    try:
        assert _wait_for(lambda: len(list(out.glob("*.npz"))) >= 1, 60)
        workers = _children(proc.pid)
        assert len(workers) >= 2
        proc.kill()
        proc.wait(timeout=120)
        gone = _wait_for(lambda: not any(_alive(w) for w in workers), 120)  # a guard against waiting for ever
        assert gone, "workers outlived their parent"
    finally:
        proc.kill()


def test_interrupt_in_process_raises_with_the_finished_items(tmp_path, monkeypatch):
    paths = _images(tmp_path / "src", 3)
    real = collection.detect_to_file
    calls = []

    def stop_after_one(*a):
        if calls:
            raise KeyboardInterrupt
        calls.append(a)
        return real(*a)

    monkeypatch.setattr(collection, "detect_to_file", stop_after_one)
    with pytest.raises(BatchInterrupted) as info:
        run_batch(paths, tmp_path / "out", jobs=1)
    assert info.value.signum == signal.SIGINT
    assert [i.status for i in info.value.items] == ["done"]


def test_resume_redoes_truncated_empty_stale_and_changed_files(tmp_path):
    paths = _images(tmp_path / "src", 5)
    out = tmp_path / "out"
    run_batch(paths, out)
    f = [feature_path(out, p.name, "npz") for p in paths]
    data = f[0].read_bytes()
    f[0].write_bytes(data[: len(data) // 2])  # truncated
    f[1].write_bytes(b"")  # zero bytes
    cv2.imwrite(str(paths[2]), cv2.imread(str(paths[3])))  # the source changed
    os.utime(paths[2], ns=(time.time_ns(), time.time_ns() + 10**9))
    stale = out / f".{f[3].name}.abc123.sogdd.tmp"
    stale.write_bytes(b"half")
    items = run_batch(paths, out, resume=True)
    assert [i.status for i in items] == ["done", "done", "done", "skipped", "skipped"]
    assert not stale.exists()
    again = run_batch(paths, out, resume=True, params={"window": 5})  # changed parameters
    assert [i.status for i in again] == ["done"] * 5
    assert read_features(f[4])[0].params["window"] == 5


def test_feature_files_get_normal_permissions(tmp_path):
    old = os.umask(0o022)
    try:
        run_batch(_images(tmp_path / "src", 1), tmp_path / "out")
    finally:
        os.umask(old)
    f = next((tmp_path / "out").glob("*.npz"))
    assert stat.S_IMODE(f.stat().st_mode) == 0o644


def test_feature_files_record_parameters_version_and_source(tmp_path):
    p = _images(tmp_path / "src", 1)[0]
    run_batch([p], tmp_path / "out", fmt="json", preset="authors", params={"max_corners": 9})
    r = read_features(tmp_path / "out" / "im0.png.json")[0]
    st = p.stat()
    assert r.params["preset"] == "authors" and r.params["max_corners"] == 9 and r.params["sigma2"] == 1.44
    assert r.sogdd_version == sogdd.__version__
    assert (r.source_size, r.source_mtime_ns) == (st.st_size, st.st_mtime_ns)
    assert r.image_shape == (120, 160)
