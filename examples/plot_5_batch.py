"""
A batch of images
=================

:func:`sogdd.collection.run_batch` (``sogdd detect DIR --out FEATURES``) writes one feature file per
image, atomically, and with ``resume=True`` (``--resume``) skips the images whose file is current: same
parameters, same sogdd version, same source file. A bad image fails alone; the others complete.
"""

import tempfile
from pathlib import Path

import cv2
import matplotlib.pyplot as plt
import numpy as np

import sogdd
from sogdd.collection import run_batch
from sogdd.synthetic import pattern_image

work = Path(tempfile.mkdtemp())
photos = work / "photos"
photos.mkdir()
for i in range(6):
    img, _ = pattern_image((240, 320), seed=i, noise=1.0)
    cv2.imwrite(str(photos / f"view_{i}.png"), img)
(photos / "broken.png").write_bytes(b"not an image")

# %%
# The same as ``sogdd detect photos/ --out features/ --preset hr``:

images = sorted(photos.iterdir())
items = run_batch(images, work / "features", preset="hr")
for it in items:
    reason = it.message.split(": ", 1)[-1]  # the message names the file; the name is in the first column
    print(f"{Path(it.image).name:12s} {it.status:8s} {it.n:3d} corners {reason}")

# %%
# A second run with ``resume=True`` redoes nothing that is current (the broken file is tried again).

again = run_batch(images, work / "features", preset="hr", resume=True)
print({s: sum(it.status == s for it in again) for s in ("done", "skipped", "failed")})

# %%
# Every feature file reads back as :class:`sogdd.Corners` with :func:`sogdd.load_features`.

files = sorted((work / "features").glob("*.npz"))
corners = [sogdd.load_features(f) for f in files]
fig, axes = plt.subplots(2, 3, figsize=(10, 5.2))
for ax, f, c in zip(axes.ravel(), files, corners):
    img = cv2.imread(str(photos / f.name[: -len(".npz")]), cv2.IMREAD_GRAYSCALE)
    ax.imshow(img, cmap="gray", vmin=0, vmax=255)
    ax.plot(c.xy[:, 0], c.xy[:, 1], "+", color="red", ms=6)
    ax.set_title(f"{f.name}: {len(c)}", fontsize=9)
    ax.set_axis_off()
fig.tight_layout()
print("mean corners per image:", np.mean([len(c) for c in corners]))
plt.show()
