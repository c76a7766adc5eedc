"""The automatic palette ``--colors auto:N`` (diskpack_cl.palette.auto_palette)."""

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from skimage.color import deltaE_ciede2000, rgb2lab

from diskpack_cl.cli import main
from diskpack_cl.palette import auto_palette
from diskpack_cl.pens import ColorOptions, parse_auto
from diskpack_cl.separation import separate

PHOTO = Path(__file__).parent / "data" / "color" / "chelsea.png"
#: Three hues at full strength (a channel 0, a channel 255: what a pen of that hue can
#: give at most, the candidates auto:N draws from) and black, in four flat bands.
FLAT = ((255, 128, 0), (0, 176, 255), (255, 0, 160), (0, 0, 0))


def _flat_image():
    img = np.zeros((24, 96, 3), np.uint8)
    for i, c in enumerate(FLAT):
        img[:, 24 * i:24 * (i + 1)] = c
    return img


def _hex(c):
    return "#" + "".join(f"{v:02x}" for v in c)


def test_palette_is_deterministic_has_black_and_n_distinct_pens():
    for n in (2, 4):
        names, colors = auto_palette(PHOTO, n)
        again = auto_palette(PHOTO, n)
        assert names == again[0] and np.array_equal(colors, again[1])
        assert len(names) == n and names[-1] == "black" and np.array_equal(colors[-1], [0, 0, 0])
        assert len({tuple(np.round(c * 255)) for c in colors}) == n
        # the pens other than black are named by their colour, for the user to buy them
        assert all(name == _hex(np.round(c * 255).astype(int)) for name, c in zip(names[:-1], colors))
    assert separate(PHOTO, "auto:4").names == auto_palette(PHOTO, 4)[0]


def test_flat_colours_and_black_are_recovered():
    names, colors = auto_palette(_flat_image(), 4)
    assert names[-1] == "black"
    # the distance in CIELAB by scikit-image, not the module's own conversion
    want = rgb2lab(np.array([FLAT[:3]], float) / 255)[0]
    got = rgb2lab(colors[None, :3])[0]
    dist = deltaE_ciede2000(want[:, None], got[None, :])
    assert np.all(dist.min(axis=1) < 1.0), dist
    assert sorted(dist.argmin(axis=1)) == [0, 1, 2]   # each recovered once


def test_too_few_hues_is_a_clear_error():
    with pytest.raises(ValueError, match=r"the image has 3 hue\(s\) besides grey, auto:5 needs 4: "
                                         r"give auto:4 or fewer"):
        auto_palette(_flat_image(), 5)
    with pytest.raises(ValueError, match="no hue besides grey"):
        auto_palette(np.full((8, 8, 3), 0.5), 2)


@pytest.mark.parametrize("text", ["auto:0", "auto:1", "auto:9", "auto:2.5", "auto:x", "auto",
                                  "auto:"])
def test_bad_n_is_a_one_line_error(text):
    with pytest.raises(ValueError, match=r"auto:N takes N = 2 to 8 pens") as err:
        ColorOptions(colors=text)
    assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match=r"auto:N takes N = 2 to 8 pens"):
        parse_auto(text)


def test_pen_dots_may_name_black_alone():
    assert ColorOptions(colors="auto:3", pen_dots="black=10").pen_dots == "black=10"
    with pytest.raises(ValueError, match="the only pen of auto:N known before the image"):
        ColorOptions(colors="auto:3", pen_dots="red=10")


def test_cli_auto_palette_svg_layers_and_summary(tmp_path, capsys):
    src, svg = tmp_path / "in.png", tmp_path / "out.svg"
    Image.fromarray(_flat_image()).save(src)
    assert main(["stipple", str(src), "--colors", "auto:4", "-n", "300", "-o", str(svg),
                 "--schedule", "classic", "--json", "-q"]) == 0
    summary = json.loads(capsys.readouterr().out)
    pens = {p["name"]: p["color"] for p in summary["pens"]}
    assert sorted(pens) == sorted([_hex(c) for c in FLAT[:3]] + ["black"])
    assert pens["black"] == "#000000" and all(pens[h] == h for h in pens if h != "black")
    ink = "{http://www.inkscape.org/namespaces/inkscape}"
    layers = [g for g in ET.parse(svg).getroot().iter("{http://www.w3.org/2000/svg}g")
              if g.get(f"{ink}groupmode") == "layer"]
    assert sorted(g.get(f"{ink}label") for g in layers) == sorted(pens)
    for g in layers:   # each layer drawn in the colour it is named after
        assert pens[g.get(f"{ink}label")] in (g.get("fill"), g.get("stroke"), g.get("style"))


def test_cli_bad_n_exits_2_with_one_line(tmp_path, capsys):
    src = tmp_path / "in.png"
    Image.fromarray(_flat_image()).save(src)
    assert main(["stipple", str(src), "--colors", "auto:9", "-n", "100",
                 "-o", str(tmp_path / "o.svg"), "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) <= 2 and "auto:N takes N = 2 to 8 pens" in err[-1]
