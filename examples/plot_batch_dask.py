"""
A batch on a Dask cluster
=========================

:func:`diskpack_cl.jobs.batch.stipple_many` stipples many images, writes each
one's outputs atomically and records it in a manifest, so a rerun skips the
finished items. With ``client=`` the items run on a ``dask.distributed``
cluster: here a small in-process ``LocalCluster``; on real machines give the
scheduler's address (``client="tcp://scheduler:8786"``).
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from distributed import Client, LocalCluster
from PIL import Image

from diskpack_cl import load_gray, read_stipple, sample_image_path
from diskpack_cl.picture_measures import render_dots
from diskpack_cl.jobs.batch import stipple_many

# three small crops of the sample photograph as the "photos" folder
work = Path(tempfile.mkdtemp())
(work / "photos").mkdir()
gray = load_gray(sample_image_path())
for name, (r, c) in {"face": (40, 170), "badge": (300, 300), "flag": (300, 20)}.items():
    crop = (gray[r:r + 128, c:c + 128] * 255).astype(np.uint8)
    Image.fromarray(crop).save(work / "photos" / f"{name}.png")

with LocalCluster(n_workers=1, threads_per_worker=1, processes=False) as cluster, \
        Client(cluster) as client:
    records = list(stipple_many([work / "photos"], [str(work / "out" / "{stem}.npz")],
                                n=1200, client=client))
for r in records:
    print(Path(r["input"]).name, r["status"], f"{r['seconds']:.1f} s")

# %%
# The manifest (``out/manifest.jsonl``) holds one line per item; the
# outputs read back with :func:`diskpack_cl.read_stipple`.

fig, axes = plt.subplots(1, len(records), figsize=(9, 3.2))
for ax, r in zip(axes, sorted(records, key=lambda r: r["input"])):
    res = read_stipple(r["outputs"][0])
    ink = render_dots(res.points, res.tone_radius, (res.height, res.width))
    ax.imshow(1 - np.clip(ink, 0, 1), cmap="gray", vmin=0, vmax=1)
    ax.set_title(Path(r["input"]).stem)
    ax.set_axis_off()
fig.tight_layout()
plt.show()
