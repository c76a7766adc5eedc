"""Build ``tests/data/validation/`` from scikit-image's bundled data folder.

Every source file ships inside the scikit-image wheel (``skimage/data/``, no
download) and is public domain or CC0 according to the docstring of its loader
in ``skimage/data/_fetchers.py`` (quoted in ``tests/data/validation/README.md``),
or inside the matplotlib wheel (``mpl-data/sample_data/``: a U.S. Navy
photograph and a USGS elevation model, works of the U.S. federal government).
The output is 8-bit grayscale PNG, at most 512 px on the long side.

    python benchmarks/make_validation_set.py [--check]

``--check`` rebuilds in memory and reports files whose pixels differ from the
committed ones (it writes nothing).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from PIL import Image

OUT = Path(__file__).resolve().parents[1] / "tests" / "data" / "validation"


def _skimage_data():
    import skimage

    return Path(skimage.__file__).parent / "data"


def _matplotlib_data():
    import matplotlib

    return Path(matplotlib.get_data_path()) / "sample_data"


def _hillshade(src):
    # the USGS elevation model as a shaded relief (sun from the north-west, 45 degrees)
    from matplotlib.colors import LightSource

    dem = np.load(src)
    z = dem["elevation"]
    dx, dy = float(dem["dx"]), float(dem["dy"])
    shade = LightSource(azdeg=315, altdeg=45).hillshade(z, vert_exag=1.0, dx=dx, dy=dy)
    return Image.fromarray(np.round(255 * shade).astype(np.uint8))


def _fit(im, long_side=512):
    """Lanczos downscale so that the long side is at most ``long_side``."""
    w, h = im.size
    s = long_side / max(w, h)
    if s >= 1:
        return im
    return im.resize((max(1, round(w * s)), max(1, round(h * s))), Image.LANCZOS)


def _retina(src, box):
    # 1411 x 1411 fundus photograph -> 1024 x 1024, then a 512 x 512 crop
    im = Image.open(src).convert("L").resize((1024, 1024), Image.LANCZOS)
    return im.crop(box)


#: output name -> (source file in skimage/data, conversion)
RECIPES = {
    "chelsea": ("chelsea.png", lambda p: Image.open(p).convert("L")),
    "brick": ("brick.png", lambda p: Image.open(p).convert("L")),
    "grass": ("grass.png", lambda p: Image.open(p).convert("L")),
    "gravel": ("gravel.png", lambda p: Image.open(p).convert("L")),
    "coins": ("coins.png", lambda p: Image.open(p).convert("L")),
    "clock": ("clock_motion.png", lambda p: Image.open(p).convert("L")),
    "text": ("text.png", lambda p: Image.open(p).convert("L")),
    "cell": ("cell.png", lambda p: _fit(Image.open(p).convert("L"))),
    # two disjoint 500 x 500 crops of the 1000 x 872 deep field, native scale
    "hubble_left": ("hubble_deep_field.jpg",
                    lambda p: Image.open(p).convert("L").crop((0, 186, 500, 686))),
    "hubble_right": ("hubble_deep_field.jpg",
                     lambda p: Image.open(p).convert("L").crop((500, 186, 1000, 686))),
    # optic disc side and macula side of the fundus, disjoint
    "retina_left": ("retina.jpg", lambda p: _retina(p, (0, 256, 512, 768))),
    "retina_right": ("retina.jpg", lambda p: _retina(p, (512, 256, 1024, 768))),
    # the second held-out part ("heldout2"), added after the first had been
    # looked at several times: new pixels only
    "ihc": ("ihc.png", lambda p: Image.open(p).convert("L")),
    "hopper": ("mpl:grace_hopper.jpg", lambda p: _fit(Image.open(p).convert("L"))),
    "terrain": ("mpl:jacksboro_fault_dem.npz", _hillshade),
    # the bottom strip of the deep field, below both hubble crops
    "hubble_bottom": ("hubble_deep_field.jpg",
                      lambda p: Image.open(p).convert("L").crop((0, 686, 512, 872))),
    # the bottom of the fundus, below both retina crops
    "retina_bottom": ("retina.jpg", lambda p: _retina(p, (256, 768, 768, 1024))),
}


def build(name):
    """The converted image ``name`` (a key of :data:`RECIPES`) as a Pillow image."""
    src, conv = RECIPES[name]
    if src.startswith("mpl:"):
        return conv(_matplotlib_data() / src[4:])
    return conv(_skimage_data() / src)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help="compare with the committed files, write nothing")
    a = ap.parse_args(argv)
    bad = 0
    for name in RECIPES:
        im = build(name)
        path = OUT / f"{name}.png"
        if a.check:
            same = path.exists() and np.array_equal(np.asarray(Image.open(path)), np.asarray(im))
            bad += not same
            print(f"{name:14s} {'ok' if same else 'DIFFERS'}")
        else:
            OUT.mkdir(parents=True, exist_ok=True)
            im.save(path, optimize=True)
            print(f"{name:14s} {im.size[0]}x{im.size[1]} {path.stat().st_size / 1024:.0f} KiB")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
