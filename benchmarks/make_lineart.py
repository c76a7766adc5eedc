"""Build the line-art tuning images in ``tests/data/lineart/``.

    python benchmarks/make_lineart.py

* ``shapes.png`` (512x512, drawn here): a disc, a rectangle, a triangle,
  lines 1 to 4 px wide, small dots of radius 1.5 to 6 px, a word at three
  sizes and a 50% gray patch with hard edges, black on white.
* ``horse.png`` (400x328): scikit-image's ``horse`` silhouette
  (``skimage.data.horse()``, "No copyright restrictions. CC0 given by owner
  (Andreas Preuss (marauder))"), black on white.
* ``lines.png`` (384x384, drawn here): concentric rings and a fan of thin
  lines, a crossing grid and a small text, for thin-line survival.

The drawings are made with Pillow's primitives and its bundled font, so the
files are reproducible from this script alone.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

OUT = Path(__file__).resolve().parents[1] / "tests" / "data" / "lineart"


def shapes():
    """Geometric shapes, lines, dots, words and a gray patch: 512x512, black on white."""
    im = Image.new("L", (512, 512), 255)
    d = ImageDraw.Draw(im)
    d.ellipse([30, 30, 170, 170], fill=0)
    d.rectangle([210, 40, 330, 160], fill=0)
    d.polygon([(370, 170), (480, 170), (425, 40)], fill=0)
    for i, width in enumerate((1, 2, 3, 4)):
        y = 210 + 22 * i
        d.line([(30, y), (250, y + 30)], fill=0, width=width)
    for i, r in enumerate((1.5, 2, 3, 4, 6)):
        cx, cy = 300 + 38 * i, 235
        d.ellipse([cx - r, cy - r, cx + r, cy + r], fill=0)
    d.rectangle([300, 270, 480, 330], fill=128)
    for size, y in ((64, 350), (32, 430), (16, 480)):
        d.text((30, y), "Stipple", fill=0, font=ImageFont.load_default(size=size))
    d.text((300, 360), "edge", fill=0, font=ImageFont.load_default(size=48))
    return im


def lines():
    """Rings, a fan of thin lines, a grid and small text: 384x384, black on white."""
    im = Image.new("L", (384, 384), 255)
    d = ImageDraw.Draw(im)
    for i, r in enumerate(range(20, 120, 16)):
        d.ellipse([120 - r, 120 - r, 120 + r, 120 + r], outline=0, width=1 + i % 3)
    for a in np.linspace(0.0, np.pi / 2, 9):
        d.line([(250, 20), (250 + 120 * np.cos(a), 20 + 120 * np.sin(a))], fill=0, width=2)
    for x in range(30, 200, 24):
        d.line([(x, 260), (x, 370)], fill=0, width=1)
    for y in range(260, 371, 22):
        d.line([(30, y), (200, y)], fill=0, width=2)
    for size, y in ((24, 250), (14, 300), (10, 340)):
        d.text((230, y), "diskpack", fill=0, font=ImageFont.load_default(size=size))
    return im


def horse():
    """scikit-image's horse silhouette, black on white."""
    from skimage import data

    return Image.fromarray(np.where(data.horse(), 255, 0).astype(np.uint8))


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    for name, make in (("shapes", shapes), ("lines", lines), ("horse", horse)):
        make().save(OUT / f"{name}.png", optimize=True)
        print(OUT / f"{name}.png")


if __name__ == "__main__":
    main()
