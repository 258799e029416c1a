"""
Camera calibration
==================

From views of a chessboard to a calibrated camera, on rendered views of a camera whose parameters are
known exactly: :func:`sogdd.calib.detect_board` finds the board in each view, orders its X-corners and
labels them; :func:`sogdd.calib.calibrate` fits OpenCV's camera model (pinhole with radial and
tangential distortion) to every labelled view and cross-validates it. The command line does the same:
``sogdd calibrate 'frames/*.jpg' --board chessboard:9x6 --square 25 --out calib/``.
"""

import matplotlib.pyplot as plt
import numpy as np

from sogdd.calib import calibrate, detect_board
from sogdd.evaluation.calibration.render import Camera, ChessboardTarget, random_sequence, render_view

# %%
# A camera and a 9 x 6 board of 25 mm squares, seen in 12 views tilted by up to 40 degrees, with a little
# blur and noise.

true = Camera(np.array([[700.0, 0.0, 318.0], [0.0, 705.0, 242.0], [0.0, 0.0, 1.0]]),
              (-0.12, 0.05, 0.001, -0.0005), (640, 480))
target = ChessboardTarget(9, 6, 25.0)
poses = random_sequence(true, target, 12, seed=2)
views = [render_view(true, target, rvec, tvec, blur=0.7, noise=2.0, rng=i)
         for i, (rvec, tvec) in enumerate(poses)]

boards = [detect_board(v.image, pattern=(9, 6)) for v in views]
print(f"boards found in {sum(b is not None for b in boards)} of {len(views)} views")

# %%
# Each board's corners against the true projections: the labels must match, the positions nearly so.

errors = []
for view, board in zip(views, boards):
    if board is None:
        continue
    truth = {tuple(lab): xy for lab, xy in zip(view.labels.tolist(), view.corners)}
    errors += [np.linalg.norm(xy - truth[tuple(lab)])
               for lab, xy in zip(board.labels.tolist(), board.image_points)]
print(f"corner error against the truth: mean {np.mean(errors):.3f} px, max {np.max(errors):.3f} px")

fig, ax = plt.subplots(figsize=(7, 5.3))
v, b = views[0], boards[0]
ax.imshow(v.image, cmap="gray", vmin=0, vmax=255)
if b is not None:
    sc = ax.scatter(b.image_points[:, 0], b.image_points[:, 1], c=b.labels[:, 0] + 9 * b.labels[:, 1],
                    cmap="viridis", s=30, marker="+")
    ax.plot(*b.image_points[0], "o", ms=12, mfc="none", mec="red", mew=2, label="label (0, 0)")
    ax.legend(loc="lower right")
ax.set_title("one view: the board's corners, coloured by label")
ax.set_axis_off()
fig.tight_layout()

# %%
# Calibrate, and compare with the true camera.

calib = calibrate(boards, true.size, square=25.0)
print(f"RMS reprojection error {calib.rms:.3f} px over {calib.n_used} views")
for name, est, ref in (("fx", calib.K[0, 0], true.K[0, 0]), ("fy", calib.K[1, 1], true.K[1, 1]),
                       ("cx", calib.K[0, 2], true.K[0, 2]), ("cy", calib.K[1, 2], true.K[1, 2])):
    print(f"{name}: {est:8.2f} (true {ref:.2f})")
print("k1, k2, p1, p2:", np.round(np.ravel(calib.dist)[:4], 4), "(true", true.dist[:4], ")")
if calib.cross_validation is not None:
    print(f"cross-validation: the two halves' cameras differ by {calib.cross_validation.mean:.3f} px "
          "on average over the image")

# %%
# The residuals of every used corner: no structure left means the model fits.

res = np.concatenate([np.asarray(r).reshape(-1, 2) for r in calib.residuals if r is not None and len(r)])
fig, ax = plt.subplots(figsize=(5, 5))
ax.plot(res[:, 0], res[:, 1], ".", ms=3)
ax.set_aspect("equal")
ax.set_xlabel("residual x (px)")
ax.set_ylabel("residual y (px)")
ax.set_title("reprojection residuals")
fig.tight_layout()
plt.show()
