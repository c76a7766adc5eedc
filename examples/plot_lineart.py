"""
Line art and silhouettes
========================

Drawings are mostly white paper with sharp outlines. The default schedule
keeps white paper white (no stray dots) and keeps the dots on the ink, so
outlines stay sharp; weighted Lloyd stippling (``method="lloyd"``), the
classic look, is drawn beside it. The titles count the stray dots, dots on
white paper (:func:`diskpack_cl.picture_measures.stray_dots`). Thin lines need
enough dots: with far fewer, both methods leave stray dots beside them.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from diskpack_cl import load_gray, stipple
from diskpack_cl.picture_measures import render_dots, stray_dots

# tests/data/lineart holds the drawings of the quality benchmark
here = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
gray = load_gray(here.parent / "tests" / "data" / "lineart" / "shapes.png")
n = 4000
results = {"default": stipple(gray, n, seed=0),
           "weighted Lloyd": stipple(gray, n, method="lloyd", seed=0)}

fig, axes = plt.subplots(1, 3, figsize=(10, 3.6))
axes[0].imshow(gray, cmap="gray", vmin=0, vmax=1)
axes[0].set_title("drawing")
for ax, (name, res) in zip(axes[1:], results.items()):
    stray = stray_dots(res.points, 1 - gray)
    ink = render_dots(res.points, res.tone_radius, gray.shape)
    ax.imshow(1 - np.clip(ink, 0, 1), cmap="gray", vmin=0, vmax=1)
    ax.set_title(f"{name}: {stray.count} stray dots")
for ax in axes:
    ax.set_axis_off()
fig.tight_layout()
plt.show()
