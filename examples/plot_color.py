"""
Colour: one packing, several pens
=================================

:func:`diskpack_cl.stipple_colors` separates a colour photograph into one
layer per pen (here CMYK; any set of pens works, ``"black=#000,red=#c00"``)
and places the dots of all pens together: every dot has one pen, and the
dots of all pens form one certified packing, so a dot of one pen never
sits on a dot of another. The SVG writer puts each pen in its own layer.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from PIL import Image

from diskpack_cl import stipple_colors

here = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
photo = Image.open(here.parent / "tests" / "data" / "color" / "chelsea.png").convert("RGB")
photo = photo.resize((photo.width // 3, photo.height // 3))
res = stipple_colors(photo, 3000, "cmyk", seed=0)
print(dict(zip(res.names, res.counts)), "certified:", res.certificate.valid)

# %%
# Draw each dot in its pen's colour at the pen's equal-ink radius.

fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.8))
a.imshow(photo)
a.set_title("photograph")
colors = np.asarray(res.colors, dtype=float)
b.scatter(res.points[:, 0], res.points[:, 1], s=4, c=colors[res.pen], linewidths=0)
b.set_xlim(0, res.width)
b.set_ylim(res.height, 0)
b.set_aspect("equal")
b.set_title("CMYK dots")
for ax in (a, b):
    ax.set_axis_off()
fig.tight_layout()
plt.show()
