"""
A stereo rig, with the uncertainty of its result
================================================

Two cameras with different lenses, 120 mm apart and turned 8 degrees towards each other, see a 9 x 6
board of 25 mm squares in 12 frames; some frames cut the board in one camera. :func:`sogdd.calib.detect_board`
finds the board in each image, and :func:`sogdd.calib.rig.calibrate_rig` fits both cameras' intrinsics,
the second camera's pose and every frame's board pose together (a sparse least-squares fit), then gives
the standard deviation of every result and a map of how far a distant point's projection can be
trusted. The command line does the same:
``sogdd calibrate --camera left 'left/*.png' --camera right 'right/*.png' --board chessboard:9x6
--square 25 --out rig/``.
"""

import cv2
import matplotlib.pyplot as plt
import numpy as np

from sogdd.calib import detect_board
from sogdd.calib.rig import calibrate_rig, projection_uncertainty, stereo_pair
from sogdd.evaluation.calibration.render import Camera, ChessboardTarget, random_sequence, render_view

# %%
# The true rig: x_right = R x_left + T, in millimetres.

left = Camera(np.array([[700.0, 0.0, 318.0], [0.0, 702.0, 242.0], [0.0, 0.0, 1.0]]),
              (-0.12, 0.05, 0.001, -0.0005), (640, 480))
right = Camera(np.array([[680.0, 0.0, 325.0], [0.0, 681.0, 236.0], [0.0, 0.0, 1.0]]),
               (-0.09, 0.03, -0.0008, 0.0006), (640, 480))
R_true = cv2.Rodrigues(np.array([0.0, np.deg2rad(-8.0), 0.0]))[0]
T_true = np.array([-120.0, 1.0, 8.0])
target = ChessboardTarget(9, 6, 25.0)

boards = {"left": [], "right": []}
images = {}
for f, (rv, tv) in enumerate(random_sequence(left, target, 12, seed=4)):
    R_f = cv2.Rodrigues(rv)[0]
    for name, cam, R, T in (("left", left, np.eye(3), np.zeros(3)), ("right", right, R_true, T_true)):
        view = render_view(cam, target, cv2.Rodrigues(R @ R_f)[0].ravel(), R @ tv + T, blur=0.7, noise=2.0,
                           rng=2 * f + (name == "right"))
        boards[name].append(detect_board(view.image, pattern=(9, 6)))
        images.setdefault(name, view.image)
print({name: sum(b is not None for b in bs) for name, bs in boards.items()}, "boards found of 12 frames")

# %%
# The joint fit, against the truth. The standard deviations come from the fit's Jacobian and the corner
# noise its residuals measure.

rig = calibrate_rig(boards, {"left": left.size, "right": right.size}, square=25.0, models="pinhole4",
                    pattern=(9, 6))
cam = rig.camera("right")
angle = np.degrees(np.linalg.norm(cv2.Rodrigues(cam.R @ R_true.T)[0]))
print(f"baseline {cam.baseline:.3f} ± {cam.std['baseline']:.3f} mm (true {np.linalg.norm(T_true):.3f}); "
      f"rotation error {angle:.4f} degrees (± {cam.std['rotation_deg']:.4f} predicted)")
print(f"right fx {cam.K[0, 0]:.2f} ± {cam.std['fx']:.2f} (true 680.00); RMS {rig.rms:.3f} px")

# %%
# Where a far point's projection can be trusted: 1 sigma over each camera's frame. The right camera's
# map includes its pose's uncertainty, since a far point is fixed in the left camera's frame.

fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
for ax, name in zip(axes, rig.names):
    pixels, sigma = projection_uncertainty(rig, name, grid=(32, 24))
    xs, ys = np.unique(pixels[:, 0]), np.unique(pixels[:, 1])
    im = ax.imshow(sigma.reshape(len(ys), len(xs)), extent=(xs[0], xs[-1], ys[-1], ys[0]), cmap="magma")
    fig.colorbar(im, ax=ax, label="px")
    ax.set_title(f"{name}: projection uncertainty (1 sigma)")
fig.tight_layout()

# %%
# Rectified with the fitted rig, the same corner lies on the same row in both images.

pair = stereo_pair(rig)
maps = {}
for name, cam_fit, Rr, P in (("left", rig.camera("left"), pair.R1, pair.P1),
                             ("right", rig.camera("right"), pair.R2, pair.P2)):
    m1, m2 = cv2.initUndistortRectifyMap(cam_fit.K, cam_fit.dist, Rr, P[:, :3], cam_fit.image_size,
                                         cv2.CV_32FC1)
    maps[name] = cv2.remap(images[name], m1, m2, cv2.INTER_LINEAR)
fig, ax = plt.subplots(figsize=(10, 3.8))
ax.imshow(np.hstack([maps["left"], maps["right"]]), cmap="gray")
for y in range(40, 480, 40):
    ax.axhline(y, color="y", lw=0.6)
ax.set_title("rectified pair with epipolar lines")
ax.set_axis_off()
fig.tight_layout()
