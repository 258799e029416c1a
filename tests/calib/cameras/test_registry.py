"""The lens registry: every model one record whose equations agree with each other and with OpenCV's."""

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import LENSES, MODELS, distort, lens, project, undistort

K = np.array([[420.0, 0.0, 330.0], [0.0, 410.0, 250.0], [0.0, 0.0, 1.0]])
DIST = {"pinhole4": [-0.2, 0.05, 0.001, -0.002], "pinhole": [-0.2, 0.05, 0.001, -0.002, -0.01],
        "rational": [-0.2, 0.05, 0.001, -0.002, -0.01, 0.02, 0.001, 0.0005],
        "fisheye": [0.02, -0.01, 0.003, 0.0],
        "omnidir": [1.2, -0.1, 0.02, 0.001, -0.001]}


def test_every_model_is_a_record_named_by_its_row():
    assert list(LENSES) == ["pinhole4", "pinhole", "rational", "fisheye", "omnidir"]
    for name, rec in LENSES.items():
        assert rec.name == name and MODELS[name] == rec.params and rec.summary
    with pytest.raises(ValueError, match="unknown camera model 'kb8'; choose one of pinhole4, pinhole"):
        lens("kb8")


@pytest.mark.parametrize("name", list(LENSES))
def test_projection_distortion_and_unprojection_agree(name):
    rec, d = lens(name), np.array(DIST[name])
    rng = np.random.default_rng(0)
    xy = rng.uniform(-0.6, 0.6, (50, 2))
    rays = np.c_[xy, np.ones(50)]
    # the projection of the ray (x, y, 1) is the distortion of (x, y)
    assert np.abs(rec.project(rays * 3.0, d) - distort(xy, d, name)).max() < 1e-12
    px = project(rays, K, d, name)
    back, ok = undistort(px, K, d, name)
    assert ok.all() and np.abs(back - xy).max() < 1e-9
    unit = rays / np.linalg.norm(rays, axis=1, keepdims=True)
    assert np.abs(rec.unproject(px, K, d) - unit).max() < 1e-9


@pytest.mark.parametrize("name", ["pinhole4", "pinhole", "rational", "fisheye"])
def test_projection_is_opencvs(name):
    d = np.array(DIST[name])
    X = np.random.default_rng(1).uniform([-1, -1, 2], [1, 1, 4], (40, 3))
    rv, tv = np.array([0.1, -0.05, 0.02]), np.array([0.1, 0.2, 0.3])
    if lens(name).start == "fisheye.calibrate":
        cv = cv2.fisheye.projectPoints(X.reshape(-1, 1, 3), rv, tv, K, d)[0]
    else:
        cv = cv2.projectPoints(X, rv, tv, K, d)[0]
    assert np.abs(project(X, K, d, name, rv, tv) - cv.reshape(-1, 2)).max() < 1e-6


def test_the_command_offers_the_registered_models():
    import argparse

    from sogdd.cli.calibrate import configure

    p = argparse.ArgumentParser()
    configure(p)
    action = next(a for a in p._actions if a.dest == "model")
    assert tuple(action.choices) == ("auto", *LENSES)
    assert "omnidir: the unified omnidirectional" in action.help
