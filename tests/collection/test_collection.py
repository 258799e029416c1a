import json

import cv2
import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.collection import expand_inputs, feature_path, run_batch
from sogdd.synthetic import pattern_image as make_pattern


@pytest.fixture
def folder(tmp_path):
    src = tmp_path / "images"
    src.mkdir()
    for i in range(3):
        img, _ = make_pattern((160, 240), seed=10 + i)
        cv2.imwrite(str(src / f"im{i}.png"), img)
    (src / "broken.png").write_bytes(b"not an image")
    return src


def test_batch_writes_one_file_per_image_and_reports_the_bad_one(folder, tmp_path):
    out = tmp_path / "feat"
    items = run_batch(expand_inputs([str(folder)]), out, fmt="npz")
    status = {i.image.rsplit("/", 1)[-1]: i.status for i in items}
    assert status == {"broken.png": "failed", "im0.png": "done", "im1.png": "done", "im2.png": "done"}
    f = np.load(feature_path(out, "im0.png", "npz"))
    assert f["xy"].shape[1] == 2 and len(f["xy"]) == len(f["response"]) > 5
    assert tuple(f["image_shape"]) == (160, 240)
    assert not list(out.glob(".*tmp"))  # atomic writes leave no temporaries


def test_resume_skips_done_images(folder, tmp_path):
    out = tmp_path / "feat"
    first = run_batch([folder / "im0.png"], out, fmt="csv")
    assert first[0].status == "done"
    target = feature_path(out, "im0.png", "csv")
    before = target.stat().st_mtime_ns, target.read_text()
    again = run_batch([folder / "im0.png", folder / "im1.png"], out, fmt="csv", resume=True)
    assert [i.status for i in again] == ["skipped", "done"]
    assert (target.stat().st_mtime_ns, target.read_text()) == before  # not rewritten


def test_processes_give_the_same_features(folder, tmp_path):
    imgs = expand_inputs([str(folder / "im*.png")])
    assert len(imgs) == 3
    run_batch(imgs, tmp_path / "a", fmt="npz", jobs=1)
    run_batch(imgs, tmp_path / "b", fmt="npz", jobs=2)
    for p in imgs:
        a = np.load(feature_path(tmp_path / "a", p.name, "npz"))
        b = np.load(feature_path(tmp_path / "b", p.name, "npz"))
        np.testing.assert_array_equal(a["xy"], b["xy"])


def test_dask_local_cluster(folder, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        items = run_batch(expand_inputs([str(folder)]), tmp_path / "d", fmt="json",
                          scheduler=cluster.scheduler_address)
    assert sorted(i.status for i in items) == ["done", "done", "done", "failed"]
    (obj,) = json.loads(feature_path(tmp_path / "d", "im1.png", "json").read_text())
    assert obj["n"] == len(obj["x"]) > 5


def test_cli_folder_mode(folder, tmp_path, capsys):
    out = tmp_path / "feat"
    assert main(["detect", str(folder), "--out", str(out), "--jobs", "2"]) == 2
    err = capsys.readouterr().err
    assert "3 done" in err and "1 failed" in err and "broken.png" in err
    assert main(["detect", str(folder / "im*.png"), "--out", str(out), "--resume"]) == 0
    assert "3 skipped" in capsys.readouterr().err
    assert main(["detect", str(folder / "im0.png"), "--resume"]) == 2  # needs --out


def test_unreachable_scheduler_is_a_clear_error(folder, tmp_path, capsys, monkeypatch):
    distributed = pytest.importorskip("distributed")
    clients = []

    def client(*a, **k):  # Dask's client retries a refused address for its whole timeout (10 s)
        clients.append(a)
        raise OSError("timed out")

    monkeypatch.setattr(distributed, "Client", client)
    code = main(["detect", str(folder / "im0.png"), "--out", str(tmp_path / "x"),
                 "--scheduler", "tcp://127.0.0.1:1"])
    err = capsys.readouterr().err
    assert code == 2
    assert "Traceback" not in err and "cannot reach the Dask scheduler at tcp://127.0.0.1:1" in err
    assert clients == []  # refused at once by the probe: no Dask client waits for a connection that cannot come


def test_batch_leaves_the_callers_thread_setting_alone(folder, tmp_path, monkeypatch):
    import os

    monkeypatch.delenv("SOGDD_NUM_THREADS", raising=False)
    run_batch([folder / "im0.png"], tmp_path / "t", fmt="npz", jobs=1)
    assert "SOGDD_NUM_THREADS" not in os.environ


def test_an_unreachable_scheduler_prints_no_progress_bar_first(folder, tmp_path, capsys):
    pytest.importorskip("distributed")
    code = main(["detect", str(folder / "im0.png"), "--out", str(tmp_path / "x"),
                 "--scheduler", "tcp://127.0.0.1:1"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("sogdd: error: cannot reach the Dask scheduler"), err
    assert "0/1" not in err and "it/s" not in err and "img/s" not in err


def test_started_is_called_once_before_the_first_image(folder, tmp_path):
    events = []
    run_batch([folder / "im0.png", folder / "im1.png"], tmp_path / "s",
              started=lambda: events.append("started"), progress=lambda item: events.append(item.status))
    assert events == ["started", "done", "done"]
