"""Write the colour photographs of the colour benchmark (tests/data/color/) from scikit-image's data.

``python benchmarks/make_color_set.py``: astronaut, coffee and chelsea (the
crops of the gray versions in ``tests/data``) and two dark, saturated
photographs, retina and the centre square of hubble_deep_field, from
``skimage/data/`` (installed with scikit-image; no download), as 8-bit RGB
PNGs of at most 256 px on the long side (Lanczos). Licences:
``tests/data/color/README.md``.
"""

from pathlib import Path

from PIL import Image

SIZE = 256
OUT = Path(__file__).resolve().parents[1] / "tests" / "data" / "color"


def main():
    import skimage

    data = Path(skimage.__file__).parent / "data"
    OUT.mkdir(exist_ok=True)
    for name, ext in (("astronaut", "png"), ("coffee", "png"), ("chelsea", "png"),
                      ("retina", "jpg"), ("hubble_deep_field", "jpg")):
        im = Image.open(data / f"{name}.{ext}").convert("RGB")
        if name in ("coffee", "hubble_deep_field"):   # the centre square (coffee: as tests/data/coffee.png)
            w, h = im.size
            im = im.crop(((w - h) // 2, 0, (w - h) // 2 + h, h))
        scale = SIZE / max(im.size)
        im = im.resize((round(im.width * scale), round(im.height * scale)), Image.LANCZOS)
        im.save(OUT / f"{name}.png", optimize=True)
        print(OUT / f"{name}.png", im.size)


if __name__ == "__main__":
    main()
