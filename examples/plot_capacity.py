"""
Equal ink per dot: ``capacity``
===============================

``capacity`` (``--capacity`` on the command line) lets each dot's radius
follow the ink its cell holds, as in capacity-constrained stippling: more
tone, at some cost in the evenness of the spacing. The default is 0.1;
``capacity=0`` gives the most even spacing. The tone SSIM (higher is closer
to the photograph after blurring) and P01 of the spacing (higher is more
even) are printed in the titles.
"""

import matplotlib.pyplot as plt
import numpy as np

from diskpack_cl import load_gray, sample_image_path, stipple
from diskpack_cl.picture_measures import render_dots, spacing, tone_ssim

gray = load_gray(sample_image_path())[40:200, 170:330]
darkness = 1 - gray
fig, axes = plt.subplots(1, 3, figsize=(10, 3.8))
for ax, gain in zip(axes, (0.0, 0.1, 0.4)):
    res = stipple(gray, 2000, capacity=gain, seed=0)
    tone = tone_ssim(res.points, darkness)
    p01 = spacing(res.points, darkness).p01
    ink = render_dots(res.points, res.tone_radius, gray.shape)
    ax.imshow(1 - np.clip(ink, 0, 1), cmap="gray", vmin=0, vmax=1)
    ax.set_title(f"capacity={gain}\ntone {tone:.3f}, P01 {p01:.2f}")
    ax.set_axis_off()
fig.tight_layout()
plt.show()
