"""``sogdd colmap export``: a bad database is one line and stays as it was; the database stays consistent."""

import sqlite3

import cv2
import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.corners import Corners
from sogdd.formats import features
from sogdd.formats.features import FeatureRecord, write_features

pycolmap = pytest.importorskip("pycolmap")

XY = np.array([[10.0, 12.0], [30.0, 25.0], [50.0, 40.0], [20.0, 45.0]])


def _image(folder, name, shape, seed=0):
    folder.mkdir(parents=True, exist_ok=True)
    img = np.random.default_rng(seed).integers(0, 255, shape, dtype=np.uint8)
    assert cv2.imwrite(str(folder / name), img)


def _features(folder, name, xy, shape, descriptors=None):
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.npz"
    write_features(path, FeatureRecord(name, Corners(xy, np.ones(len(xy)), np.full(len(xy), 8.0)), shape))
    if descriptors is not None:
        with np.load(path) as z:
            arrays = dict(z)
        np.savez(path, **arrays, descriptors=descriptors)
    return path


def _setup(tmp_path, sizes=((60, 80), (60, 80))):
    """Images ``im<i>.png`` of the given (height, width) and their feature files."""
    img, feat = tmp_path / "img", tmp_path / "feat"
    for i, shape in enumerate(sizes):
        _image(img, f"im{i}.png", shape, seed=i)
        _features(feat, f"im{i}.png", XY + i, shape)
    return img, feat


def _export(feat, db, *extra):
    return main(["colmap", "export", str(feat), "--database", str(db), "--quiet", *extra])


def _one_error(capfd) -> str:
    """The only thing on stderr (pycolmap's own log lines included, read at the file descriptor)."""
    err = capfd.readouterr().err
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("sogdd: error: "), err
    return lines[0]


def _tables(db) -> set[str]:
    con = sqlite3.connect(db)
    try:
        return {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    finally:
        con.close()


def _consistent(db) -> dict[str, tuple[int, int]]:
    """``{name: (keypoints, descriptors)}``, asserting that every image's descriptors fit its keypoints."""
    out = {}
    with pycolmap.Database.open(str(db)) as d:
        for im in d.read_all_images():
            n_kp = d.num_keypoints_for_image(im.image_id)
            n_desc = d.num_descriptors_for_image(im.image_id) if d.exists_descriptors(im.image_id) else 0
            assert n_desc in (0, n_kp), (im.name, n_kp, n_desc)
            out[im.name] = (n_kp, n_desc)
    return out


# ----------------------------------------------------------------- databases that are not COLMAP's
@pytest.mark.parametrize("content, says", [
    (b"hello, not a database\n", "not a COLMAP database (not an SQLite file)"),
    (b"SQLite format 3\x00" + b"\xff" * 200, "not a readable COLMAP database"),
])
def test_a_file_that_is_no_database_is_one_line_and_untouched(tmp_path, capfd, content, says):
    img, feat = _setup(tmp_path)
    db = tmp_path / "notes.db"
    db.write_bytes(content)
    assert _export(feat, db, "--images", str(img)) == 2
    line = _one_error(capfd)
    assert "notes.db" in line and says in line
    assert db.read_bytes() == content
    assert sorted(p.name for p in tmp_path.iterdir()) == ["feat", "img", "notes.db"]  # no leftovers


def test_a_folder_as_database_is_one_line(tmp_path, capfd):
    img, feat = _setup(tmp_path)
    (tmp_path / "dir.db").mkdir()
    assert _export(feat, tmp_path / "dir.db", "--images", str(img)) == 2
    assert "a folder, not a COLMAP database" in _one_error(capfd)


def test_an_unrelated_sqlite_file_gets_no_colmap_tables(tmp_path, capfd):
    img, feat = _setup(tmp_path)
    db = tmp_path / "shop.sqlite"
    con = sqlite3.connect(db)
    con.execute("CREATE TABLE orders (id INTEGER, item TEXT)")
    con.execute("INSERT INTO orders VALUES (1, 'bread')")
    con.commit()
    con.close()
    before = db.read_bytes()
    assert _export(feat, db, "--images", str(img)) == 2
    line = _one_error(capfd)
    assert "shop.sqlite: not a COLMAP database (an SQLite file without COLMAP's tables" in line
    assert db.read_bytes() == before and _tables(db) == {"orders"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["feat", "img", "shop.sqlite"]


def test_a_new_or_empty_path_is_still_created(tmp_path, capfd):
    img, feat = _setup(tmp_path)
    new, empty = tmp_path / "new.db", tmp_path / "empty.db"
    empty.write_bytes(b"")
    for db in (new, empty):
        assert _export(feat, db, "--images", str(img)) == 0
        assert {"cameras", "images", "keypoints", "descriptors"} <= _tables(db)
        assert _consistent(db) == {"im0.png": (4, 4), "im1.png": (4, 4)}
        assert db.stat().st_mode & 0o777 == 0o644 & ~_umask()
    assert "sogdd: error" not in capfd.readouterr().err


def _umask() -> int:
    import os

    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def test_a_database_open_in_another_program_is_refused(tmp_path, capfd):
    img, feat = _setup(tmp_path)
    db = tmp_path / "db.db"
    assert _export(feat, db, "--images", str(img)) == 0
    before = db.read_bytes()
    holder = sqlite3.connect(db)  # COLMAP databases are in WAL mode: a reader holds the -wal file
    holder.execute("SELECT count(*) FROM images").fetchall()
    try:
        assert _export(feat, db, "--images", str(img)) == 2
        assert "open in another program" in _one_error(capfd)
        assert db.read_bytes() == before
    finally:
        holder.close()


def test_a_symbolic_link_to_the_database_stays_a_link(tmp_path):
    img, feat = _setup(tmp_path)
    real, link = tmp_path / "real.db", tmp_path / "link.db"
    assert _export(feat, real, "--images", str(img)) == 0
    link.symlink_to(real)
    _features(feat, "im0.png", XY[:2], (60, 80))
    assert _export(feat, link) == 0
    assert link.is_symlink() and _consistent(real)["im0.png"] == (2, 0)


# ----------------------------------------------------------------- cameras
def test_images_of_different_sizes_get_one_camera_per_size(tmp_path, capfd):
    img, feat = _setup(tmp_path, sizes=((60, 80), (70, 90), (60, 80)))
    db = tmp_path / "db.db"
    assert _export(feat, db, "--images", str(img)) == 0
    assert capfd.readouterr().err == ""  # pycolmap's log lines stay off the terminal
    with pycolmap.Database.open(str(db)) as d:
        cams = {c.camera_id: (c.width, c.height) for c in d.read_all_cameras()}
        of = {im.name: cams[im.camera_id] for im in d.read_all_images()}
    assert sorted(cams.values()) == [(80, 60), (90, 70)]
    assert of == {"im0.png": (80, 60), "im1.png": (90, 70), "im2.png": (80, 60)}
    assert _consistent(db) == {f"im{i}.png": (4, 4) for i in range(3)}


def test_one_camera_prior_for_images_of_different_sizes_is_one_line(tmp_path, capfd):
    img, feat = _setup(tmp_path, sizes=((60, 80), (70, 90)))
    (img / "K.txt").write_text("100 0 40\n0 100 30\n0 0 1\n")
    db = tmp_path / "db.db"
    assert _export(feat, db, "--images", str(img)) == 2
    line = _one_error(capfd)
    assert "2 sizes (80x60, 90x70)" in line and "K.txt" in line
    assert not db.exists()


def test_features_of_another_image_size_than_the_camera_are_refused(tmp_path, capfd):
    img, feat = _setup(tmp_path)
    _features(feat, "im1.png", XY, (80, 60))  # detected on the image turned by 90 degrees
    db = tmp_path / "db.db"
    assert _export(feat, db, "--images", str(img)) == 2
    line = _one_error(capfd)
    assert "im1.png.npz: detected on a 60x80 image, but COLMAP's camera for im1.png is 80x60" in line
    assert not db.exists()


# ----------------------------------------------------------------- re-exporting
def _matches(db, table="matches") -> set[tuple[int, int]]:
    with pycolmap.Database.open(str(db)) as d:
        ids = {im.image_id: im.name for im in d.read_all_images()}
    con = sqlite3.connect(db)
    pids = [r[0] for r in con.execute(f"SELECT pair_id FROM {table}")]
    con.close()
    return {tuple(sorted(ids[i] for i in pycolmap.pair_id_to_image_pair(p))) for p in pids}


def _match_everything(db):
    """Matches and verified geometries (inliers) between every pair of images."""
    pairs = np.array([[0, 1], [1, 0]], np.uint32)
    with pycolmap.Database.open(str(db)) as d:
        ids = sorted(im.image_id for im in d.read_all_images())
        for a in range(len(ids)):
            for b in range(a + 1, len(ids)):
                d.write_matches(ids[a], ids[b], pairs)
                g = pycolmap.TwoViewGeometry()
                g.inlier_matches = pairs
                d.write_two_view_geometry(ids[a], ids[b], g)


def test_re_exporting_without_descriptors_leaves_none_stale(tmp_path, capfd):
    img, feat = _setup(tmp_path, sizes=((60, 80),) * 3)
    db = tmp_path / "db.db"
    assert _export(feat, db, "--images", str(img)) == 0
    _match_everything(db)
    _features(feat, "im0.png", XY[:3] + 0.25, (60, 80))  # new keypoints for im0 only
    capfd.readouterr()
    assert main(["colmap", "export", str(feat), "--database", str(db), "--describe", "none", "--quiet"]) == 0
    out = capfd.readouterr().out
    # im0's old descriptors are gone with its old keypoints; the others' keypoints did not change
    assert _consistent(db) == {"im0.png": (3, 0), "im1.png": (4, 4), "im2.png": (4, 4)}
    # matches and inliers indexing im0's old keypoints are gone
    assert _matches(db) == _matches(db, "two_view_geometries") == {("im1.png", "im2.png")}
    assert "old descriptors of 1 image(s)" in out and "matches of 2 image pair(s)" in out


def test_re_exporting_with_descriptors_replaces_them(tmp_path):
    img, feat = _setup(tmp_path)
    db = tmp_path / "db.db"
    assert _export(feat, db, "--images", str(img)) == 0
    _features(feat, "im1.png", XY[:2], (60, 80), descriptors=np.full((2, 128), 7.0, np.float32))
    assert _export(feat, db, "--images", str(img)) == 0
    assert _consistent(db) == {"im0.png": (4, 4), "im1.png": (2, 2)}
    with pycolmap.Database.open(str(db)) as d:
        iid = d.read_image_with_name("im1.png").image_id
        assert np.asarray(d.read_descriptors(iid).data).tolist() == [[7] * 128] * 2


def test_a_failed_re_export_leaves_the_database_as_it_was(tmp_path, capfd):
    img, feat = _setup(tmp_path)
    db = tmp_path / "db.db"
    assert _export(feat, db, "--images", str(img)) == 0
    before = db.read_bytes()
    _features(feat, "im0.png", XY[:1], (60, 80))
    _features(feat, "im1.png", XY, (60, 80), descriptors=np.full((4, 128), np.nan, np.float32))
    assert _export(feat, db, "--images", str(img)) == 2
    assert "im1.png.npz: descriptors must be finite numbers" in _one_error(capfd)
    assert db.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["db.db", "feat", "img"]


# ----------------------------------------------------------------- the schema's descriptors field
def test_read_descriptors_is_the_schema_of_the_field(tmp_path):
    path = _features(tmp_path, "a.png", XY, (60, 80))
    assert features.read_descriptors(path) is None
    _features(tmp_path, "a.png", XY, (60, 80), descriptors=np.arange(8.0).reshape(4, 2))
    assert features.read_descriptors(path).tolist() == np.arange(8.0).reshape(4, 2).tolist()
    for bad, says in [(np.ones((3, 128)), "descriptors of shape (3, 128) for 4 corners"),
                      (np.ones(4), "descriptors of shape (4,) for 4 corners"),
                      (np.full((4, 2), np.inf), "must be finite numbers"),
                      (np.ones((4, 2), complex), "must be finite numbers (dtype complex128)")]:
        _features(tmp_path, "a.png", XY, (60, 80), descriptors=bad)
        with pytest.raises(ValueError, match=r"a\.png\.npz: ") as info:
            features.read_descriptors(path)
        assert says in str(info.value)
    assert features.read_descriptors(tmp_path / "a.csv") is None  # CSV and JSON hold no descriptors
    with pytest.raises(ValueError, match="no such file"):
        features.read_descriptors(tmp_path / "gone.npz")


def test_an_image_colmap_cannot_read_is_one_line_naming_it(tmp_path, capfd):
    img, feat = _setup(tmp_path)
    a = np.random.default_rng(0).integers(0, 255, (60, 80), dtype=np.uint8)
    assert cv2.imwrite(str(img / "im9.jp2"), a)  # OpenCV writes JPEG 2000; pycolmap's reader may not read it
    _features(feat, "im9.jp2", XY, (60, 80))
    db = tmp_path / "db.db"
    if _export(feat, db, "--images", str(img)) == 0:
        pytest.skip("this pycolmap reads JPEG 2000")
    line = _one_error(capfd)
    assert "im9.jp2: COLMAP could not import it: im9.jp2" in line
    assert not db.exists()
