"""
Stippling a photograph
======================

Stipple the bundled 512 x 512 photograph (here a 160 px crop of the face, so
the example runs in seconds) with 2500 dots, and draw them as a plotter
would: every dot the same size, chosen so that the dots hold the photograph's
ink. The result is certified: the packing disks lie inside the picture and
are pairwise disjoint.
"""

import matplotlib.pyplot as plt
import numpy as np

from diskpack_cl import load_gray, sample_image_path, stipple
from diskpack_cl.picture_measures import render_dots

gray = load_gray(sample_image_path())[40:200, 170:330]   # rows, columns: the face
res = stipple(gray, 2500, seed=0)
print(f"{len(res.points)} dots, certified: {res.certificate.valid}, "
      f"{len(res.history)} iterations")

# %%
# ``res.points`` are pixel coordinates (x right, y down); ``res.tone_radius``
# is the dot radius at which the dots hold the image's ink.

ink = render_dots(res.points, res.tone_radius, gray.shape)
fig, (a, b) = plt.subplots(1, 2, figsize=(8, 4.2))
a.imshow(gray, cmap="gray", vmin=0, vmax=1)
a.set_title("photograph")
b.imshow(1 - np.clip(ink, 0, 1), cmap="gray", vmin=0, vmax=1)
b.set_title(f"{len(res.points)} dots")
for ax in (a, b):
    ax.set_axis_off()
fig.tight_layout()
plt.show()

# %%
# To write the drawing for a pen plotter, pass the result to
# :func:`diskpack_cl.write_stipple` with a ``.svg`` path (see the plotter
# guide): ``write_stipple("face.svg", res, page="a4", pen_mm=0.5)``.
