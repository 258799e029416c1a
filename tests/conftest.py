import os
from pathlib import Path

import cv2
import numpy as np
import pytest

from sogdd.measure import soddc
from sogdd.synthetic import pattern_image as _pattern


def shared_data() -> Path | None:
    """The shared benchmark data folder, from SOGDD_DATA or ../shared/data."""
    env = os.environ.get("SOGDD_DATA")
    cands = [Path(env)] if env else []
    here = Path(__file__).resolve().parents[1]
    cands += [here.parent / "shared" / "data", Path.cwd().parent / "shared" / "data"]
    for c in cands:
        if c.is_dir():
            return c
    return None


@pytest.fixture(scope="session")
def data_dir() -> Path:
    d = shared_data()
    if d is None:
        pytest.skip("shared benchmark data not available (set SOGDD_DATA)")
    return d


@pytest.fixture(scope="session")
def pattern():
    return _pattern((240, 320), seed=1)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(autouse=True)
def _prune_small_maps(monkeypatch):
    """Small test images take the pruned path that photos take (``soddc.PRUNE_MIN_PIXELS``).

    Pruning never changes a result, so without this the tests of the bound's exactness on small
    images would compare the full map with itself. ``tests/measure/test_bound.py`` checks the real
    pixel rule.
    """
    monkeypatch.setattr(soddc, "PRUNE_MIN_PIXELS", 0)


def pytest_configure(config):
    config.addinivalue_line("markers", "learned: needs the 'learned' extra; skipped with the reason without it")


def pytest_collection_modifyitems(config, items):
    """Tests marked ``learned`` skip, saying what is missing and how to install it, where the extra is not."""
    from sogdd.baselines import learned_extra

    if learned_extra.installed():
        return
    skip = pytest.mark.skip(reason=f"the 'learned' extra is not installed (missing: "
                                   f"{', '.join(learned_extra.missing())}); install: {learned_extra.INSTALL}")
    for item in items:
        if item.get_closest_marker("learned") is not None:
            item.add_marker(skip)


#: the rendered frames' camera (fx = fy = 560 at 640 x 480)
RENDER_K = np.array([[560.0, 0, 322.0], [0, 560.0, 236.0], [0, 0, 1]])
RENDER_DIST = (-0.2, 0.06, 0.001, -0.0005, 0.0)


@pytest.fixture(scope="session")
def rendered_frames(tmp_path_factory):
    """Eight rendered 640 x 480 views of a 9 x 6 board (blur 0.8 px, noise 2 grey levels), f0.png ... f7.png.

    Read only: a test that changes the set copies it.
    """
    render = pytest.importorskip("sogdd.evaluation.calibration.render")
    cam = render.Camera(RENDER_K, RENDER_DIST, (640, 480))
    target = render.ChessboardTarget(9, 6, 1.0)
    folder = tmp_path_factory.mktemp("frames")
    for k, (rv, tv) in enumerate(render.random_sequence(cam, target, 8, seed=3)):
        view = render.render_view(cam, target, rv, tv, blur=0.8, noise=2.0, rng=k)
        assert cv2.imwrite(str(folder / f"f{k}.png"), view.image)
    return folder


#: the rendered rig: "left" is the rendered frames' camera; "right" has its own lens, 3 squares to the right
#: and turned 5 degrees towards the left one (x_right = R x_left + T, in squares)
RIG_RIGHT = (np.array([[590.0, 0, 318.0], [0, 589.0, 243.0], [0, 0, 1]]), (-0.22, 0.06, -0.0008, 0.0006, 0.0),
             cv2.Rodrigues(np.array([0.0, np.deg2rad(-5.0), 0.0]))[0], np.array([-3.0, 0.05, 0.1]))


@pytest.fixture(scope="session")
def rig_truth():
    """The rendered rig's lenses, ``{"left": (K, dist), "right": (K, dist)}``, and the right pose ``(R, T)``."""
    K_r, D_r, R, T = RIG_RIGHT
    return {"left": (RENDER_K, RENDER_DIST), "right": (K_r, D_r)}, (R, T)


@pytest.fixture(scope="session")
def rendered_rig(tmp_path_factory):
    """Eight frames of a 9 x 6 board seen by a rendered two-camera rig (640 x 480, blur 0.8 px, noise 2 grey
    levels): ``left/left01.png ... left08.png`` and ``right/right01.png ...``, the board whole in both.

    Camera k sees frame f's board at :math:`R_k R_f, R_k t_f + T_k`. Returns ``(folder, R, T)``, the right
    camera's true pose (T in squares). Read only: a test that changes the set copies it.
    """
    render = pytest.importorskip("sogdd.evaluation.calibration.render")
    K_r, D_r, R, T = RIG_RIGHT
    left = render.Camera(RENDER_K, RENDER_DIST, (640, 480))
    right = render.Camera(K_r, D_r, (640, 480))
    target = render.ChessboardTarget(9, 6, 1.0)
    folder = tmp_path_factory.mktemp("rig")
    kept = 0
    for k, (rv, tv) in enumerate(render.random_sequence(left, target, 40, seed=5)):
        rv_r, tv_r = cv2.Rodrigues(R @ cv2.Rodrigues(rv)[0])[0].ravel(), R @ tv + T
        edge = right.project(target.outline(with_margin=True), rv_r, tv_r)
        if not np.all(np.isfinite(edge) & (edge >= 4) & (edge <= np.array([635, 475]))):
            continue  # the board whole in the right camera too
        kept += 1
        for name, cam, r, t in (("left", left, rv, tv), ("right", right, rv_r, tv_r)):
            (folder / name).mkdir(exist_ok=True)
            view = render.render_view(cam, target, r, t, blur=0.8, noise=2.0, rng=100 * k + len(name))
            assert cv2.imwrite(str(folder / name / f"{name}{kept:02d}.png"), view.image)
        if kept == 8:
            break
    assert kept == 8
    return folder, R, T
