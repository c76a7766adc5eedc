"""Build the line-art tuning images in ``tests/data/lineart/``, or the held-out drawings.

    python benchmarks/make_lineart.py
    python benchmarks/make_lineart.py --heldout DIR

* ``shapes.png`` (512x512, drawn here): a disc, a rectangle, a triangle,
  lines 1 to 4 px wide, small dots of radius 1.5 to 6 px, a word at three
  sizes and a 50% gray patch with hard edges, black on white.
* ``horse.png`` (400x328): scikit-image's ``horse`` silhouette
  (``skimage.data.horse()``, "No copyright restrictions. CC0 given by owner
  (Andreas Preuss (marauder))"), black on white.
* ``lines.png`` (384x384, drawn here): concentric rings and a fan of thin
  lines, a crossing grid and a small text, for thin-line survival.

``--heldout DIR`` writes the held-out drawings (:data:`HELDOUT`), which no
setting of the default was tuned on, to ``DIR`` instead (they are not
stored in the repository; ``benchmarks/lineart_stray.py`` draws them in
memory):

* ``poster`` (512x384): a star, a ring, a rounded box, pairs of 1 px lines
  3 to 6 px apart, a row of small dots of radius 1 to 2.5 px and a word
  in the default font with white paper below it.
* ``hatching`` (512x384): parallel and crossed hatching at 4 to 7 px,
  an Archimedean spiral 1 and 2 px wide, a short word.
* ``sketch`` (512x384): bundles of near-parallel 1-2 px strokes, scattered
  small dots (seeded), a zigzag, outlined shapes and small text.

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


def poster():
    """A star, a ring, a rounded box, close 1 px line pairs, small dots and a word: 512x384."""
    im = Image.new("L", (512, 384), 255)
    d = ImageDraw.Draw(im)
    a = np.linspace(0.0, 2 * np.pi, 11)[:-1] - np.pi / 2
    rad = np.where(np.arange(10) % 2 == 0, 60.0, 25.0)
    d.polygon([(90 + r * np.cos(t), 80 + r * np.sin(t)) for r, t in zip(rad, a)], fill=0)
    d.ellipse([190, 25, 300, 135], outline=0, width=6)
    d.rounded_rectangle([330, 30, 480, 130], radius=18, fill=0)
    for i, gap in enumerate((3, 4, 5, 6)):
        y = 165 + 22 * i
        d.line([(30, y), (220, y + 12)], fill=0, width=1)
        d.line([(30, y + gap), (220, y + 12 + gap)], fill=0, width=1)
    for i, r in enumerate((1.0, 1.5, 2.0, 2.5) * 3):
        cx, cy = 260 + 20 * i, 180 + 14 * (i % 2)
        d.ellipse([cx - r, cy - r, cx + r, cy + r], fill=0)
    d.text((250, 215), "Plotter", fill=0, font=ImageFont.load_default(size=56))
    d.text((30, 270), "thin ink on white paper", fill=0, font=ImageFont.load_default(size=22))
    d.line([(30, 350), (480, 350)], fill=0, width=2)
    return im


def hatching():
    """Parallel and crossed hatching, a spiral 1-2 px wide and a word: 512x384."""
    im = Image.new("L", (512, 384), 255)
    d = ImageDraw.Draw(im)
    for x0, step in ((20, 4), (130, 5), (240, 7)):
        for k in range(0, 100, step):
            d.line([(x0 + k, 20), (x0 + k - 30, 140)], fill=0, width=1)
    for k in range(0, 110, 6):
        d.line([(360 + k, 20), (360 + k, 140)], fill=0, width=1)
        d.line([(360, 20 + k), (470, 20 + k)], fill=0, width=1)
    t = np.linspace(0.0, 8 * np.pi, 800)
    r = 4 + 4.2 * t
    xy = np.column_stack([140 + r * np.cos(t), 265 + r * np.sin(t)])
    d.line([tuple(p) for p in xy[:400]], fill=0, width=1)
    d.line([tuple(p) for p in xy[399:]], fill=0, width=2)
    d.text((300, 230), "spiral", fill=0, font=ImageFont.load_default(size=40))
    d.text((300, 300), "hatch 4 5 7", fill=0, font=ImageFont.load_default(size=18))
    return im


def sketch():
    """Bundles of near-parallel strokes, scattered dots, a zigzag, outlines, small text: 512x384."""
    rng = np.random.default_rng(37)
    im = Image.new("L", (512, 384), 255)
    d = ImageDraw.Draw(im)
    for j in range(7):
        y = 30 + 5 * j + (j % 2)
        d.line([(20, y), (200, y + 40 - 3 * j)], fill=0, width=1 + j % 2)
    for x, y in rng.uniform((230, 20), (490, 120), size=(60, 2)):
        r = rng.uniform(0.8, 2.2)
        d.ellipse([x - r, y - r, x + r, y + r], fill=0)
    zig = [(20 + 12 * i, 160 + (18 if i % 2 else 0)) for i in range(36)]
    d.line(zig, fill=0, width=1)
    d.ellipse([30, 210, 150, 330], outline=0, width=2)
    d.rectangle([180, 210, 300, 330], outline=0, width=1)
    d.regular_polygon((390, 270, 60), 6, outline=0, width=3)
    d.text((40, 345), "a quick sketch, 1 px", fill=0, font=ImageFont.load_default(size=14))
    return im


#: The held-out drawings (``--heldout``): name -> function drawing it.
HELDOUT = {"poster": poster, "hatching": hatching, "sketch": sketch}


def main(argv=None):
    import argparse

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--heldout", metavar="DIR", help="write the held-out drawings to DIR instead")
    a = ap.parse_args(argv)
    out = Path(a.heldout) if a.heldout else OUT
    drawings = HELDOUT if a.heldout else {"shapes": shapes, "lines": lines, "horse": horse}
    out.mkdir(parents=True, exist_ok=True)
    for name, make in drawings.items():
        make().save(out / f"{name}.png", optimize=True)
        print(out / f"{name}.png")


if __name__ == "__main__":
    main()
