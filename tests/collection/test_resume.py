"""--resume redoes a file when any parameter changed or the source image was edited, even in place with
its size and modification time kept; it skips only what would come out the same."""

import os

import cv2
import numpy as np
import pytest

from sogdd.collection import feature_path, run_batch
from sogdd.formats.features import read_features
from sogdd.synthetic import pattern_image


@pytest.fixture
def batch(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    img = pattern_image((120, 160), seed=3)[0]
    paths = [src / f"im{i}.png" for i in range(2)]
    for i, p in enumerate(paths):
        cv2.imwrite(str(p), np.roll(img, 9 * i, axis=1), [cv2.IMWRITE_PNG_COMPRESSION, 0])  # room to edit
    out = tmp_path / "out"
    assert [i.status for i in run_batch(paths, out)] == ["done", "done"]
    return paths, out


@pytest.mark.parametrize("fmt", ["npz", "csv", "json"])
@pytest.mark.parametrize("change", [{"threshold": 5e9}, {"max_corners": 3}, {"subpixel": "quadratic"},
                                    {"threshold_units": "grey", "threshold": 20.0}])
def test_a_changed_parameter_redoes_every_file(batch, fmt, change):
    paths, out = batch
    run_batch(paths, out, fmt=fmt)
    assert [i.status for i in run_batch(paths, out, fmt=fmt, resume=True)] == ["skipped", "skipped"]
    again = run_batch(paths, out, fmt=fmt, resume=True, params=change)
    assert [i.status for i in again] == ["done", "done"]
    r = read_features(feature_path(out, paths[0].name, fmt))[0]
    assert {k: r.params[k] for k in change} == change
    if "max_corners" in change:
        assert len(r.corners) == 3
    assert [i.status for i in run_batch(paths, out, fmt=fmt, resume=True, params=change)] == ["skipped"] * 2


def test_an_in_place_edit_keeping_size_and_time_is_redone(batch):
    paths, out = batch
    st = paths[0].stat()
    data = paths[0].read_bytes()
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    edited = img.copy()
    edited[40:60, 40:60] = 255 - edited[40:60, 40:60]
    ok, png = cv2.imencode(".png", edited)
    blob = png.tobytes()
    assert len(blob) <= len(data)
    blob += b"\0" * (len(data) - len(blob))  # the same size (PNG ignores bytes after IEND)
    with open(paths[0], "r+b") as f:  # in place: the same inode
        f.write(blob)
    os.utime(paths[0], ns=(st.st_atime_ns, st.st_mtime_ns))  # and the same time (cp -p, touch -r, one tick)
    assert paths[0].stat().st_size == st.st_size and paths[0].stat().st_mtime_ns == st.st_mtime_ns
    before = read_features(feature_path(out, paths[0].name, "npz"))[0].corners.xy
    items = run_batch(paths, out, resume=True)
    assert [i.status for i in items] == ["done", "skipped"]
    after = read_features(feature_path(out, paths[0].name, "npz"))[0].corners.xy
    assert not np.array_equal(before, after)


def test_a_file_only_touched_is_not_redone(batch):
    paths, out = batch
    os.utime(paths[1], ns=(0, paths[1].stat().st_mtime_ns + 10**9))
    assert [i.status for i in run_batch(paths, out, resume=True)] == ["skipped", "skipped"]


def test_a_changed_mask_redoes_the_files(batch):
    paths, out = batch
    mask = np.zeros((120, 160), bool)
    mask[:, :80] = True
    assert [i.status for i in run_batch(paths, out, resume=True, mask=mask)] == ["done", "done"]
    assert [i.status for i in run_batch(paths, out, resume=True, mask=mask)] == ["skipped", "skipped"]
    mask[:, 80:100] = True
    assert [i.status for i in run_batch(paths, out, resume=True, mask=mask)] == ["done", "done"]
    r = read_features(feature_path(out, paths[0].name, "npz"))[0]
    assert np.all(r.corners.xy[:, 0] < 100) and r.params["mask"].startswith("120x160:sha256:")
