"""
Detection and overlay
=====================

Detect the corners of a rendered scene with the default (``paper``) preset and draw them over the
image beside the true vertices. :func:`sogdd.synthetic.pattern_image` renders anti-aliased polygons
whose vertices have random sub-pixel positions, and returns them.
"""

import matplotlib.pyplot as plt
import numpy as np

import sogdd
from sogdd.synthetic import pattern_image

img, truth = pattern_image((240, 320), seed=0)
c = sogdd.detect_corners(img)

# %%
# ``c.xy`` holds (x, y) = (column, row) with pixel centres at integers, strongest first. Each true
# vertex is found when a detection lies within 2 px of it.

d = np.linalg.norm(truth[:, None, :] - c.xy[None, :, :], axis=2)
nearest = d.min(axis=1)
found = nearest <= 2.0
print(f"{len(c)} corners; {found.sum()} of {len(truth)} vertices found within 2 px; "
      f"mean error {nearest[found].mean():.3f} px")

fig, ax = plt.subplots(figsize=(7, 5.3))
ax.imshow(img, cmap="gray", vmin=0, vmax=255)
ax.plot(truth[:, 0], truth[:, 1], "o", ms=9, mfc="none", mec="lime", mew=1.5, label="true vertex")
ax.plot(c.xy[:, 0], c.xy[:, 1], "+", ms=9, color="red", mew=1.5, label="sogdd (paper)")
ax.set_axis_off()
ax.legend(loc="lower right", framealpha=0.9)
ax.set_title("detect_corners(img): detections and the true vertices")
fig.tight_layout()

# %%
# The response map
# ----------------
# :func:`sogdd.corner_response` returns the measure Υ = det(Λ) / (tr(Λ) + ς) at every pixel; the
# corners are its local maxima above the threshold (T_h = 1e9 in the ``paper`` preset). Υ grows
# with the 14th power of the contrast at K = 8, so a logarithmic scale shows it best.

R = sogdd.corner_response(img)
fig, ax = plt.subplots(figsize=(7, 5.3))
im = ax.imshow(np.log10(np.maximum(R, 1.0)), cmap="magma")
ax.set_axis_off()
ax.set_title("log10 Υ")
fig.colorbar(im, ax=ax, shrink=0.8)
fig.tight_layout()
plt.show()
