"""
COLMAP export
=============

``sogdd detect photos/ --out feats/`` then ``sogdd colmap export feats/ --database db.db --images
photos/`` writes the keypoints and SIFT descriptors of every image into a COLMAP database, ready for
COLMAP's matcher and mapper (``pip install '.[sfm]'``). COLMAP puts pixel centres at +0.5, sogdd (like
OpenCV) at integers; the export adds the 0.5.
"""

import sqlite3
import tempfile
from pathlib import Path

import cv2
import matplotlib.pyplot as plt
import numpy as np

import sogdd
from sogdd.collection import run_batch
from sogdd.formats.colmap import export_features
from sogdd.synthetic import pattern_image

work = Path(tempfile.mkdtemp())
photos = work / "photos"
photos.mkdir()
base, _ = pattern_image((240, 320), seed=5)
for i in range(3):  # three "views": the scene shifted by a few pixels
    cv2.imwrite(str(photos / f"p{i}.png"), np.roll(base, 6 * i, axis=1))

run_batch(sorted(photos.iterdir()), work / "feats")
summary = export_features(work / "feats", work / "db.db", images=photos)
print({k: summary[k] for k in ("images", "keypoints", "descriptors")})

# %%
# The database is COLMAP's own SQLite schema; its keypoints are float32 rows (x, y, ...). Reading them
# back shows the +0.5 pixel-centre shift against the feature file.

con = sqlite3.connect(work / "db.db")
image_id = con.execute("SELECT image_id FROM images WHERE name = 'p0.png'").fetchone()[0]
rows, cols, blob = con.execute("SELECT rows, cols, data FROM keypoints WHERE image_id = ?",
                               (image_id,)).fetchone()
con.close()
colmap_xy = np.frombuffer(blob, np.float32).reshape(rows, cols)[:, :2]
ours = sogdd.load_features(work / "feats" / "p0.png.npz").xy
print("largest |COLMAP xy - 0.5 - sogdd xy|:", float(np.abs(colmap_xy - 0.5 - ours).max()))

fig, ax = plt.subplots(figsize=(7, 5.3))
ax.imshow(base, cmap="gray", vmin=0, vmax=255)
ax.plot(colmap_xy[:, 0] - 0.5, colmap_xy[:, 1] - 0.5, "+", color="red", ms=9, mew=1.5,
        label="keypoints read from the COLMAP database, - 0.5")
ax.legend(loc="lower right")
ax.set_axis_off()
fig.tight_layout()
plt.show()
