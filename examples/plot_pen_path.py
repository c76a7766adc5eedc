"""
Pen-path ordering
=================

A pen plotter lifts the pen and travels between dots; the order of the dots
sets that travel, and with it most of the plot time besides the pen lifts.
:func:`diskpack_cl.drawing.pen_path.pen_path_order` offers a Hilbert curve, greedy
nearest neighbour, and ``"auto"``: the shorter of both, then rounds of 2-opt
(as many as the number of dots allows, the same on every machine). The SVG
writer uses ``"auto"`` unless told otherwise.
"""

import matplotlib.pyplot as plt

from diskpack_cl import load_gray, sample_image_path, stipple
from diskpack_cl.drawing.pen_path import pen_path_order

gray = load_gray(sample_image_path())[40:200, 170:330]
points = stipple(gray, 800, seed=0).points

fig, axes = plt.subplots(1, 4, figsize=(12, 3.4))
for ax, method in zip(axes, ("none", "hilbert", "greedy", "auto")):
    order, _, travel = pen_path_order(points, method=method)
    p = points[order]
    ax.plot(p[:, 0], p[:, 1], lw=0.4, color="tab:blue")
    ax.plot(p[:, 0], p[:, 1], ".", ms=1.5, color="k")
    ax.set_title(f"{method}: {travel:.0f} px of travel")
    ax.set_xlim(0, gray.shape[1])
    ax.set_ylim(gray.shape[0], 0)
    ax.set_aspect("equal")
    ax.set_axis_off()
fig.tight_layout()
plt.show()
