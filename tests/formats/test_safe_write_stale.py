"""What killed writers leave beside a target: removed by the next writer, never a running writer's, never
through a link, never another target's."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from sogdd.formats.safe_write import TMP_SUFFIX, claimed, remove_stale_beside

pytest.importorskip("fcntl")


def test_the_stale_temporaries_of_a_target_are_removed_and_nothing_else(tmp_path):
    dead = tmp_path / f".calib.new-1a2b{TMP_SUFFIX}"
    dead.mkdir()
    (dead / "camera.yaml").write_text("x")
    old = tmp_path / f".calib.old-3c4d{TMP_SUFFIX}"
    old.mkdir()
    file = tmp_path / f".calib.k2j3h4{TMP_SUFFIX}"
    file.write_text("partial")
    other = tmp_path / f".calib.x.new-5e6f{TMP_SUFFIX}"  # calib.x's, not calib's
    other.mkdir()
    mine = tmp_path / "notes.calib.sogdd.tmp"
    mine.write_text("mine")
    kept = tmp_path / "kept"
    kept.mkdir()
    (kept / "precious").write_text("x")
    link = tmp_path / f".calib.new-7a8b{TMP_SUFFIX}"
    link.symlink_to(kept)
    removed = remove_stale_beside(tmp_path / "calib")
    assert sorted(p.name for p in removed) == sorted(p.name for p in (dead, old, file, link))
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([other.name, mine.name, "kept"])
    assert (kept / "precious").read_text() == "x"  # the link was removed, not followed


def test_a_running_writers_temporary_is_kept(tmp_path):
    live = tmp_path / f".calib.new-9c0d{TMP_SUFFIX}"
    live.mkdir()
    with claimed(live):
        assert remove_stale_beside(tmp_path / "calib") == []
        assert live.is_dir()
    assert remove_stale_beside(tmp_path / "calib") == [live] and not live.exists()


def test_the_hold_ends_with_the_process_however_it_ends(tmp_path):
    live = tmp_path / f".calib.new-beef{TMP_SUFFIX}"
    live.mkdir()
    holder = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import sys, time
        from sogdd.formats.safe_write import claimed
        with claimed({str(live)!r}):
            print("held", flush=True)
            time.sleep(600)
    """)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "held\n"
        assert remove_stale_beside(tmp_path / "calib") == []
        holder.kill()
        holder.wait()
        assert remove_stale_beside(tmp_path / "calib") == [live]
    finally:
        holder.kill()
        holder.wait()


def test_no_folder_no_work(tmp_path):
    assert remove_stale_beside(tmp_path / "missing" / "calib") == []
