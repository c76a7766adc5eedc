"""Write the colour photographs of the colour benchmark (tests/data/color/) from scikit-image's data.

``python benchmarks/make_color_set.py``: astronaut, coffee and chelsea from
``skimage/data/`` (installed with scikit-image; no download), as 8-bit RGB
PNGs of at most 256 px on the long side (Lanczos), the crops of the gray
versions in ``tests/data``. Licences: ``tests/data/color/README.md``.
"""

from pathlib import Path

from PIL import Image

SIZE = 256
OUT = Path(__file__).resolve().parents[1] / "tests" / "data" / "color"


def main():
    import skimage

    data = Path(skimage.__file__).parent / "data"
    OUT.mkdir(exist_ok=True)
    for name in ("astronaut", "coffee", "chelsea"):
        im = Image.open(data / f"{name}.png").convert("RGB")
        if name == "coffee":   # the centre square, as tests/data/coffee.png
            w, h = im.size
            im = im.crop(((w - h) // 2, 0, (w - h) // 2 + h, h))
        scale = SIZE / max(im.size)
        im = im.resize((round(im.width * scale), round(im.height * scale)), Image.LANCZOS)
        im.save(OUT / f"{name}.png", optimize=True)
        print(OUT / f"{name}.png", im.size)


if __name__ == "__main__":
    main()
