"""Photographs outside the validation set for the default-against-Lloyd misses.

Writes 8-bit grayscale PNGs, at most 512 px on the long side, into ``--out``
(default ``build/photo_misses/``, not committed): images of the kinds on which
the default kept less edge or tone than weighted Lloyd on held-out
photographs (a rocket's thin structures, a face, a dark scientific image),
built from the scikit-image and matplotlib wheels (no download). They are
measured with ``benchmarks/stipple_quality.py --images`` and cropped with
``benchmarks/stipple_crops.py`` (see ``docs/stipple_quality.md``,
"Photographs where Lloyd keeps more edge or tone").

    python benchmarks/photo_misses.py [--out build/photo_misses]

=============  ==========================================================================
name           source and conversion
=============  ==========================================================================
rocket         ``skimage/data/rocket.jpg`` (a rocket on its launch pad, gantry, cables);
               RGB -> luma, Lanczos 640x427 -> 512x342. Its public-domain status is
               disputed (scikit-image issue 5095): measured here, not committed.
rocket640      the same at its native 640x427 (finer gantry lines, in pixels)
hopper_face    matplotlib ``sample_data/grace_hopper.jpg`` (U.S. Navy, public domain):
               the face alone, crop x 120-400, y 40-340 at native scale (the held-out
               ``hopper`` is the whole portrait at 437x512)
mri            matplotlib ``sample_data/s1045.ima.gz``: a 256x256 MRI slice of a head,
               16-bit, scaled by its maximum, Lanczos -> 512x512; dark (mean 0.18)
hubble_top     ``skimage/data/hubble_deep_field.jpg``: the strip above the validation
               crops, x 0-640, y 0-186; very dark (mean 0.08), small bright galaxies, the
               nearest bundled kin of a fluorescence image (its photograph is that of
               the tuning ``hubble_left``: a weaker test than a new photograph)
lattice        drawn, not photographed (no licence question): a 256x256 gantry-like
               lattice of light 2 px lines, gray 0.75, on a dark sky of gray 0.15:
               the rocket's lit tower struts in kind (thinner than the dot spacing)
=============  ==========================================================================
"""

from __future__ import annotations

import argparse
import gzip
import sys
from pathlib import Path

import numpy as np
from PIL import Image

OUT = Path(__file__).resolve().parents[1] / "build" / "photo_misses"


def _skimage(name):
    import skimage

    return Image.open(Path(skimage.__file__).parent / "data" / name).convert("L")


def _rocket():
    im = _skimage("rocket.jpg")
    return im.resize((512, round(512 * im.size[1] / im.size[0])), Image.LANCZOS)


def _hopper_face():
    import matplotlib

    src = Path(matplotlib.get_data_path()) / "sample_data" / "grace_hopper.jpg"
    return Image.open(src).convert("L").crop((120, 40, 400, 340))


def _mri():
    import matplotlib

    raw = gzip.open(Path(matplotlib.get_data_path()) / "sample_data" / "s1045.ima.gz").read()
    a = np.frombuffer(raw, "<u2").reshape(256, 256).astype(float)
    im = Image.fromarray(np.round(255 * a / a.max()).astype(np.uint8))
    return im.resize((512, 512), Image.LANCZOS)


def _lattice(size=256, line=2.0, sky=0.15, ink=0.75):
    # two verticals 60 px apart braced by diagonals every 40 px, drawn with
    # antialiased lines (4x supersampling), then a light blur (the camera's)
    from PIL import ImageDraw, ImageFilter

    k = 4
    im = Image.new("L", (size * k, size * k), round(255 * sky))
    d = ImageDraw.Draw(im)
    w, g = round(line * k), round(255 * ink)
    for x0 in (40, 150):
        xs = (x0 * k, (x0 + 60) * k)
        for x in xs:
            d.line([(x, 0), (x, size * k)], fill=g, width=w)
        for y in range(-40, size, 40):
            d.line([(xs[0], y * k), (xs[1], (y + 40) * k)], fill=g, width=w)
            d.line([(xs[1], y * k), (xs[0], (y + 40) * k)], fill=g, width=w)
    return im.resize((size, size), Image.LANCZOS).filter(ImageFilter.GaussianBlur(0.5))


#: name -> builder of the 8-bit gray image
BUILDERS = {
    "rocket": _rocket,
    "rocket640": lambda: _skimage("rocket.jpg"),
    "hopper_face": _hopper_face,
    "mri": _mri,
    "hubble_top": lambda: _skimage("hubble_deep_field.jpg").crop((0, 0, 640, 186)),
    "lattice": _lattice,
}


def build(out=OUT):
    """Write every image of :data:`BUILDERS` to ``out/<name>.png``; return the paths.

    Examples
    --------
    >>> paths = build(Path("/tmp/photo_misses"))   # doctest: +SKIP
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, make in BUILDERS.items():
        path = out / f"{name}.png"
        make().save(path)
        paths.append(path)
    return paths


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=OUT, help="folder of the PNGs (default: %(default)s)")
    a = ap.parse_args(argv)
    for p in build(a.out):
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
