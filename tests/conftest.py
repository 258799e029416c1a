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


# ---------------------------------------------------------------------------------------------
# a video of a 9 x 6 board waved before the rendered frames' camera (no evaluation code)

#: the board's paper (squares of 1; inner corner (i, j) at (i, j)): dark squares, paper, background levels
_VIDEO_LEVELS = (35.0, 215.0, 110.0)


def _video_poses(cam, n_key: int, rng) -> list[tuple[np.ndarray, np.ndarray]]:
    """``n_key`` board poses, each with its whole paper at least 6 px inside the frame: tilted up to 40 degrees
    about a random axis in its plane, rolled up to 25, spanning 40-80 % of the frame's height."""
    paper = np.array([(u, v, 0.0) for u in (-2, 10) for v in (-2, 7)])
    out = []
    while len(out) < n_key:
        axis, tilt = rng.uniform(0, 2 * np.pi), np.radians(rng.uniform(5, 40))
        R = cv2.Rodrigues(np.array([np.cos(axis), np.sin(axis), 0.0]) * tilt)[0] @ \
            cv2.Rodrigues(np.array([0.0, 0.0, np.radians(rng.uniform(-25, 25))]))[0]
        z = cam.fx * 9.0 / (rng.uniform(0.4, 0.8) * 480)
        ray = cam.undistort(np.array([[rng.uniform(100, 540), rng.uniform(80, 400)]]))[0]
        t = z * np.array([ray[0], ray[1], 1.0]) - R @ np.array([4.0, 2.5, 0.0])
        rv = cv2.Rodrigues(R)[0].ravel()
        edge = cam.project(paper, rv, t)
        if np.all(np.isfinite(edge)) and np.all((edge >= 6) & (edge <= np.array([633, 473]))):
            out.append((rv, t))
    return out


#: texels per square of the board's texture
_TEXELS = 32


def _video_texture() -> np.ndarray:
    """The board's paper as a float32 texture: texel ``(a, b)`` is board point ``((a + 0.5) / T - 2,
    (b + 0.5) / T - 2)``, ``T`` :data:`_TEXELS` per square."""
    dark, light, _ = _VIDEO_LEVELS
    T = _TEXELS
    a = (np.arange(12 * T) + 0.5) / T - 2
    b = (np.arange(9 * T) + 0.5) / T - 2
    U, V = np.meshgrid(a, b)
    inside = (U >= -1) & (U <= 9) & (V >= -1) & (V <= 6)
    return np.where(inside & ((np.floor(U) + np.floor(V)) % 2 == 0), dark, light).astype(np.float32)


def _video_frame(rays: np.ndarray, texture: np.ndarray, rv, t, ss: int, shape: tuple[int, int]) -> np.ndarray:
    """The board at pose ``(rv, t)`` seen along ``rays`` (undistorted ``(x', y')``, float32, ``ss`` per
    pixel each way): the texture sampled there (bilinear), then averaged ``ss x ss``."""
    R = cv2.Rodrigues(np.asarray(rv, float))[0]
    plane = np.c_[R[:, 0], R[:, 1], np.asarray(t, float)]  # (x', y', 1) ~ plane (U, V, 1)
    T = _TEXELS
    to_tex = np.array([[T, 0, 2 * T - 0.5], [0, T, 2 * T - 0.5], [0, 0, 1.0]])
    m = cv2.perspectiveTransform(rays, to_tex @ np.linalg.inv(plane))
    h, w = shape
    m = m.reshape(h * ss, w * ss, 2)
    img = cv2.remap(texture, m[..., 0], m[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                    borderValue=_VIDEO_LEVELS[2])
    return cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA).astype(np.float64)


@pytest.fixture(scope="session")
def board_video(tmp_path_factory):
    """A 109-frame 640 x 480 MJPG video (``board.avi``) of a 9 x 6 board moving smoothly between 10 poses,
    seen through the rendered frames' camera (:data:`RENDER_K`, :data:`RENDER_DIST`), blur 0.7 px and noise
    2 grey levels; every sixth frame (3, 9, ...) smeared by a 25 px motion blur. And the 10 poses' frames as
    stills (``stills/s00.png`` ...), sharp. Returns a namespace: ``path``, ``stills``, ``K``, ``dist``,
    ``blurred`` (the smeared frames' indices) and ``frames``. Read only."""
    from types import SimpleNamespace

    from sogdd.calib.cameras import Camera

    cam = Camera(RENDER_K, RENDER_DIST, (640, 480))
    ss, (w, h) = 2, cam.size
    xs = (np.arange(w * ss) + 0.5) / ss - 0.5
    ys = (np.arange(h * ss) + 0.5) / ss - 0.5
    pix = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    rays = cam.undistort(pix).astype(np.float32).reshape(-1, 1, 2)
    texture = _video_texture()
    rng = np.random.default_rng(7)
    keys = _video_poses(cam, 10, rng)
    folder = tmp_path_factory.mktemp("video")
    (folder / "stills").mkdir()

    def finish(img, smear=None):
        img = cv2.GaussianBlur(img, (0, 0), 0.7)
        if smear is not None:
            img = cv2.filter2D(img, -1, smear, borderType=cv2.BORDER_REFLECT)
        img = img + rng.normal(0.0, 2.0, img.shape)
        return np.clip(np.rint(img), 0, 255).astype(np.uint8)

    for k, (rv, t) in enumerate(keys):
        still = finish(_video_frame(rays, texture, rv, t, ss, (h, w)))
        assert cv2.imwrite(str(folder / "stills" / f"s{k:02d}.png"), still)
    path = folder / "board.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 25, (w, h), False)
    assert writer.isOpened()
    per, blurred, index = 12, [], 0
    for k in range(len(keys) - 1):
        for s in range(per + (k == len(keys) - 2)):
            a = s / per
            rv = (1 - a) * keys[k][0] + a * keys[k + 1][0]
            t = (1 - a) * keys[k][1] + a * keys[k + 1][1]
            smear = None
            if index % 6 == 3:
                L, angle = 25, rng.uniform(0, np.pi)
                smear = np.zeros((L, L), np.float32)
                c = (L - 1) / 2
                cv2.line(smear, (int(round(c - c * np.cos(angle))), int(round(c - c * np.sin(angle)))),
                         (int(round(c + c * np.cos(angle))), int(round(c + c * np.sin(angle)))), 1.0, 1)
                smear /= smear.sum()
                blurred.append(index)
            writer.write(finish(_video_frame(rays, texture, rv, t, ss, (h, w)), smear))
            index += 1
    writer.release()
    return SimpleNamespace(path=path, stills=folder / "stills", K=RENDER_K, dist=RENDER_DIST,
                           blurred=tuple(blurred), frames=index)
