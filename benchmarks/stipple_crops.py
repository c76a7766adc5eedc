"""Crops of stipplings side by side: the photograph, then one drawing per configuration.

Each drawing shows every dot with one radius (the equal-ink radius of
:func:`diskpack_cl.picture_measures.tone_radius`, the drawing the tone measure sees),
rendered at ``--scale`` output pixels per image pixel; the label gives the
configuration and, over the whole image, its tone SSIM (sigma 3), edge
fidelity and stray dots per 10 000 (:mod:`diskpack_cl.analysis`).

    python benchmarks/stipple_crops.py hubble_right -n 20000 --box 100 180 120 120 \\
        --configs default lloyd -o docs/figures/stipple_crop_hubble.png

Configurations are those of ``benchmarks/stipple_quality.py``
(``name[:key=value;...]``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

import stipple_quality as sq
from diskpack_cl.picture_measures import edge_fidelity, render_dots, stray_dots, tone_radius, tone_ssim


def drawing(points, darkness, box, scale):
    """The equal-ink drawing of ``points`` inside ``box = (x, y, w, h)``, as 8-bit gray (white paper)."""
    x0, y0, w, h = box
    r = tone_radius(len(points), darkness)
    inside = ((points[:, 0] > x0 - 2 * r) & (points[:, 0] < x0 + w + 2 * r)
              & (points[:, 1] > y0 - 2 * r) & (points[:, 1] < y0 + h + 2 * r))
    p = (points[inside] - [x0, y0]) * scale
    ink = render_dots(p, r * scale, (h * scale, w * scale))
    return Image.fromarray((255 * (1 - np.clip(ink, 0, 1))).astype(np.uint8))


def panel(image, n, configs, box, scale=4, seed=0, names=None):
    """One row: the photograph's crop, then the drawing of each configuration, labelled
    with its name (default: the configuration) and its measures."""
    gray = sq.load(image)
    dark = 1.0 - gray
    x0, y0, w, h = box
    crop = Image.fromarray((255 * gray[y0:y0 + h, x0:x0 + w]).astype(np.uint8))
    tiles = [(crop.resize((w * scale, h * scale), Image.NEAREST), f"{Path(image).stem} (input)")]
    for spec, shown in zip(configs, names or configs):
        name, extra = sq.parse_config(spec)
        kw = sq.stipple_kwargs(name, extra, (gray.shape[1], gray.shape[0], n))
        res = sq.stipple(gray, n, seed=seed, **kw)
        t, e = tone_ssim(res.points, dark), edge_fidelity(res.points, dark)
        s = stray_dots(res.points, dark).per_10k
        label = f"{shown}\nn={n}  tone {t:.3f}" + (f"  edge {e:.3f}" if e == e else "") + f"  stray {s:.0f}"
        tiles.append((drawing(res.points, dark, box, scale), label))
    pad, label = 6, 28
    W = sum(t.size[0] for t, _ in tiles) + pad * (len(tiles) + 1)
    H = h * scale + label + 2 * pad
    out = Image.new("L", (W, H), 255)
    d = ImageDraw.Draw(out)
    x = pad
    for tile, text in tiles:
        out.paste(tile, (x, pad + label))
        d.text((x, pad), text, fill=0)
        x += tile.size[0] + pad
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("image", help="a name of the validation set or an image file")
    ap.add_argument("-n", type=int, default=20000)
    ap.add_argument("--box", type=int, nargs=4, metavar=("X", "Y", "W", "H"), required=True,
                    help="crop in image pixels")
    ap.add_argument("--configs", nargs="+", default=["default", "lloyd"])
    ap.add_argument("--scale", type=int, default=4, help="output pixels per image pixel")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--names", nargs="+", help="labels of the configurations, in their order")
    ap.add_argument("-o", "--output", required=True)
    a = ap.parse_args(argv)
    if a.names is not None and len(a.names) != len(a.configs):
        ap.error(f"--names gives {len(a.names)} labels for {len(a.configs)} configurations")
    panel(a.image, a.n, a.configs, tuple(a.box), a.scale, a.seed, a.names).save(a.output, optimize=True)
    print(a.output)
    return 0


if __name__ == "__main__":
    sys.exit(main())
