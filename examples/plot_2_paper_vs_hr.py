"""
``paper`` against ``hr`` on a checkerboard
==========================================

At a checkerboard's X-corner (a saddle point of the image) the SOGDD measure has a local *minimum*,
ringed by maxima about 2 px away. The ``paper`` preset reports those maxima, and its gradient
refinement pulls some of them onto the corner; the ``hr`` preset reports each X-corner once, on its
saddle point, and refines it there. A rendered board with exactly known inner corners shows the
difference.
"""

import matplotlib.pyplot as plt
import numpy as np

import sogdd
from sogdd.evaluation.chessboard.scenes import BoardScene, render_board

board = render_board(BoardScene(cell=8, n_cols=12, n_rows=9, angle=10.0, phase=(0.31, 0.17),
                                psf=0.7, noise=2.0, seed=3))
img, truth = board.image, board.corners


def score(xy):
    """Inner corners found within 1 px, their mean error, and the other points within the board."""
    d = np.linalg.norm(truth[:, None, :] - xy[None, :, :], axis=2)
    hit = d.min(axis=1) <= 1.0
    return hit.mean(), d.min(axis=1)[hit].mean(), int((d.min(axis=0) > 1.0).sum())


results = {}
for preset in ("paper", "hr"):
    c = sogdd.detect_corners(img, preset=preset)
    results[preset] = c
    recall, err, other = score(c.xy)
    print(f"{preset}: {len(c)} points; inner corners found within 1 px: {recall:.2f}, mean error {err:.3f} px")
    print(f"    {other} points farther than 1 px from every inner corner")

# %%
# The ``hr`` points sit on the corners; ``paper``'s are spread around them. The other points of
# ``hr`` lie on the board's outer edge and its outer corners, which are real corners of the image
# but not inner corners of the board: a calibration needs the board, not just the points.

fig, axes = plt.subplots(1, 2, figsize=(10, 4.6))
for ax, (preset, c) in zip(axes, results.items()):
    ax.imshow(img, cmap="gray", vmin=0, vmax=255)
    ax.plot(truth[:, 0], truth[:, 1], "o", ms=6, mfc="none", mec="lime", mew=1.2)
    ax.plot(c.xy[:, 0], c.xy[:, 1], "+", ms=6, color="red", mew=1.2)
    ax.set_title(f"preset={preset!r}: {len(c)} points")
    ax.set_axis_off()
fig.tight_layout()

# %%
# A close look at four cells in the middle of the board: each true corner (green circle) and the
# detections (red crosses).

# sphinx_gallery_thumbnail_number = 2
x0, y0 = truth[np.argmin(np.linalg.norm(truth - truth.mean(axis=0), axis=1))]
fig, axes = plt.subplots(1, 2, figsize=(10, 4.6))
for ax, (preset, c) in zip(axes, results.items()):
    ax.imshow(img, cmap="gray", vmin=0, vmax=255)
    ax.plot(truth[:, 0], truth[:, 1], "o", ms=14, mfc="none", mec="lime", mew=1.5)
    ax.plot(c.xy[:, 0], c.xy[:, 1], "+", ms=14, color="red", mew=2)
    ax.set_xlim(x0 - 10, x0 + 10)
    ax.set_ylim(y0 + 10, y0 - 10)
    ax.set_title(f"preset={preset!r}")
fig.tight_layout()
plt.show()
