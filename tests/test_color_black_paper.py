"""Light pens on black paper (``--colors/--pens`` with ``--invert``): separation, writers, CLI."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from PIL import Image

from diskpack_cl.cli import main
from diskpack_cl.color_measures import color_measures, render_pens
from diskpack_cl.colorspace import linear_negative, srgb_to_linear
from diskpack_cl.palette import auto_palette
from diskpack_cl.separation import separate
from diskpack_cl.drawing.color_writers import write_color_png
from diskpack_cl.drawing.writers import read_stipple
from diskpack_cl.multipen import stipple_colors

INK = "{http://www.inkscape.org/namespaces/inkscape}"
LIGHT3 = "white=#fff,orange=#f80,sky=#08f"   # black paper and these: a tetrahedron


def _dark_image(path=None):
    """Dark red, green and blue quarters, a near-black one and a white square in the middle."""
    img = np.zeros((48, 64, 3), np.uint8)
    img[:24, :32] = (150, 20, 20)
    img[:24, 32:] = (20, 110, 30)
    img[24:, :32] = (25, 30, 140)
    img[24:, 32:] = (8, 8, 8)
    img[20:28, 28:36] = (230, 230, 230)
    if path is not None:
        Image.fromarray(img).save(path)
    return img


def _mixes(pens, m, seed=0):
    """`m` colours (sRGB, 8-bit) mixed side by side from `pens` (linear) over black, every
    coverage at least 0.05 and their sum at most 0.9 (inside the gamut), and the coverages."""
    rng = np.random.default_rng(seed)
    a = rng.dirichlet(np.ones(len(pens) + 1), m) * 0.75 + 0.05   # the last: black paper
    a /= a.sum(axis=1, keepdims=True)
    rgb = np.round(np.clip(a[:, :-1] @ pens, 0, 1) ** (1 / 2.2) * 255).astype(np.uint8)
    return rgb, a[:, :-1]


def test_the_layers_mix_over_black_to_the_image_and_are_its_one_mix():
    """Independent of the solver: with three pens, black paper and the pens are a tetrahedron,
    so each colour in it has one mix, the barycentric coordinates numpy solves for."""
    names = ("white", "orange", "sky")
    pens = srgb_to_linear(np.array([[1, 1, 1], [1, 0x88 / 255, 0], [0, 0x88 / 255, 1.0]]))
    rgb, _ = _mixes(pens, 400)
    sep = separate(rgb[None], LIGHT3, invert=True)
    a = sep.layers[:, 0, :].T                                   # (m, P)
    target = srgb_to_linear(rgb / 255.0)
    assert sep.names == names and sep.invert
    np.testing.assert_allclose(a @ pens, target, atol=1e-9)   # the area mix over black
    np.testing.assert_allclose(a, np.linalg.solve(pens.T, target.T).T, atol=1e-9)
    assert a.min() >= 0 and a.sum(axis=1).max() <= 1
    np.testing.assert_allclose(srgb_to_linear(sep.render()[0]), target, atol=1e-9)


def test_four_pens_over_black_reproduce_the_colours_in_their_gamut():
    pens = srgb_to_linear(np.array([[1, 1, 1], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]))
    rgb, _ = _mixes(pens, 400, seed=1)
    sep = separate(rgb[None], "white=#fff,red=#f00,green=#0f0,blue=#00f", invert=True)
    a = sep.layers[:, 0, :].T
    np.testing.assert_allclose(a @ pens, srgb_to_linear(rgb / 255.0), atol=1e-9)
    assert a.min() >= 0 and a.sum(axis=1).max() <= 1 + 1e-12


def test_black_is_no_ink_and_white_paper_pens_stay_on_white():
    img = np.array([[[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]])
    black = separate(img, LIGHT3, invert=True).layers
    assert black[:, 0, 0].tolist() == [0, 0, 0] and black[0, 0, 1] == pytest.approx(1.0)
    assert separate(img, LIGHT3).layers[:, 0, 1].tolist() == [0, 0, 0]   # white paper: no ink


def test_auto_on_black_is_white_and_the_negatives_of_the_negatives_pens():
    img = _dark_image() / 255.0
    names, colors = auto_palette(img, 3, invert=True)
    neg_names, neg_colors = auto_palette(linear_negative(img), 3)
    assert names[-1] == "white" and neg_names[-1] == "black"
    np.testing.assert_allclose(colors, np.round(linear_negative(neg_colors) * 255) / 255)
    assert list(names[:-1]) == ["#%02x%02x%02x" % tuple(np.round(c * 255).astype(int))
                                for c in colors[:-1]]
    lum = srgb_to_linear(colors) @ [0.2126, 0.7152, 0.0722]
    assert np.all(np.diff(lum) >= 0)   # darkest first, the order they are drawn in


@pytest.mark.parametrize("palette", ["cmyk", "cmy", "CMYK"])
def test_palettes_for_white_paper_are_refused_on_black(palette):
    with pytest.raises(ValueError, match=f"^{palette} is for white paper: on black paper give "
                                         "auto:N .* white=#fff,red=#f00,green=#0f0,blue=#00f$"):
        separate(np.zeros((2, 2, 3)), palette, invert=True)
    with pytest.raises(ValueError, match="is for white paper"):
        stipple_colors(np.zeros((8, 8, 3)), 20, palette, invert=True)


def test_a_black_image_has_nothing_to_draw_on_black():
    with pytest.raises(ValueError, match="nothing to stipple: the image is black"):
        stipple_colors(np.zeros((8, 8, 3)), 20, LIGHT3, invert=True)


def test_stipple_colors_on_black_records_its_paper():
    img = _dark_image() / 255.0
    res = stipple_colors(img, 300, "auto:3", invert=True, backend="exact")
    assert res.params["invert"] and res.certificate.valid and res.names[-1] == "white"


def test_cli_svg_png_npz_and_export_keep_black_paper(tmp_path, capsys):
    _dark_image(tmp_path / "dark.png")
    out = {ext: str(tmp_path / f"a.{ext}") for ext in ("svg", "png", "npz", "csv")}
    assert main(["stipple", str(tmp_path / "dark.png"), "--colors", "auto:3", "--invert",
                 "-n", "300", *sum((["-o", p] for p in out.values()), []), "-q"]) == 0
    root = ET.parse(out["svg"]).getroot()
    labels = [g.get(f"{INK}label") for g in root.iter() if g.get(f"{INK}groupmode") == "layer"]
    back = read_stipple(out["npz"])
    assert back.params["invert"] is True and back.names[-1] == "white" and len(back.pen) == 300
    # the black paper first (a layer plotters skip), then the pens darkest first, white last
    lum = srgb_to_linear(back.colors) @ [0.2126, 0.7152, 0.0722]
    assert labels == ["% paper (not plotted)"] + [back.names[i] for i in np.argsort(lum)]
    assert read_stipple(out["svg"]).params["invert"] is True
    with Image.open(out["png"]) as im:
        png = np.asarray(im, np.float64) / 255.0
    # no dot where the photograph is (near) black: the paper's black shows
    assert png[48:, 72:].max(axis=2).mean() < 0.1 and png.mean() < 0.5
    # the PNG is the drawing render_pens measures, light pens' light added on black
    drawn = render_pens(back.points * 2, back.pen, back.pen_radius * 2, back.colors, (96, 128),
                        scale=2, invert=True)
    assert np.abs(srgb_to_linear(png) - drawn).mean() < 0.02
    # the red quarter is drawn red, the blue one blue
    assert png[:40, :56, 0].mean() > 2 * png[:40, :56, 2].mean()
    assert png[56:, :56, 2].mean() > 2 * png[56:, :56, 0].mean()
    again = {ext: str(tmp_path / f"b.{ext}") for ext in ("svg", "png")}
    assert main(["export", out["npz"], "-o", again["svg"], "-o", again["png"], "-q"]) == 0
    with open(out["svg"], encoding="utf-8") as a, open(again["svg"], encoding="utf-8") as b:
        assert a.read() == b.read()
    with Image.open(out["png"]) as a, Image.open(again["png"]) as b:
        assert np.array_equal(np.asarray(a), np.asarray(b))
    # the CSV says so too: an export of it draws on black without --invert
    from_csv = str(tmp_path / "c.svg")
    assert main(["export", out["csv"], "-o", from_csv, "-q"]) == 0
    assert read_stipple(out["csv"]).params == {"invert": True}
    root = ET.parse(from_csv).getroot()
    layers = [g.get(f"{INK}label") for g in root.iter() if g.get(f"{INK}groupmode") == "layer"]
    assert layers == labels and read_stipple(from_csv).params["invert"] is True
    page = str(tmp_path / "page.png")
    assert main(["export", out["npz"], "-o", page, "--preview", "page", "--page", "100x80mm",
                 "-q"]) == 0
    with Image.open(page) as im:
        assert max(im.getpixel((2, 2))) == 0   # the black paper's corner
    capsys.readouterr()


def test_cli_bad_combinations_are_one_line(tmp_path, capsys):
    _dark_image(tmp_path / "dark.png")
    svg = str(tmp_path / "a.svg")
    for palette in ("cmyk", "cmy"):
        assert main(["stipple", str(tmp_path / "dark.png"), "--colors", palette, "--invert",
                     "-n", "100", "-o", svg, "-q"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"--invert: {palette} is for white paper" in err
    # pens separated for white paper are not drawn on black
    npz = str(tmp_path / "w.npz")
    assert main(["stipple", str(tmp_path / "dark.png"), "--pens", LIGHT3, "-n", "100",
                 "-o", npz, "-q"]) == 0
    assert main(["export", npz, "-o", svg, "--invert", "-q"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "separated for white paper" in err


def test_write_png_draws_a_result_on_the_paper_it_was_made_for(tmp_path):
    img = _dark_image() / 255.0
    res = stipple_colors(img, 200, LIGHT3, invert=True, schedule=[("mix", 3, 0.5)],
                         backend="exact")
    write_color_png(tmp_path / "a.png", res, png_scale=1.0)   # no invert given: the result's paper
    with Image.open(tmp_path / "a.png") as im:
        assert np.asarray(im)[30:, 40:].mean() < 0.1 * 255   # the near-black quarter


def test_vpype_draws_the_light_pens_and_refuses_cmyk_on_black(tmp_path):
    vpype = pytest.importorskip("vpype")
    vpype_cli = pytest.importorskip("vpype_cli")
    from click.testing import CliRunner

    image = tmp_path / "dark.png"
    _dark_image(image)
    doc = vpype_cli.execute(f"diskpack {image} -n 300 --colors auto:3 --invert")
    layers = list(doc.layers.values())   # the black paper is an image: no layer of paths
    names = [layer.property(vpype.METADATA_FIELD_NAME) for layer in layers]
    assert len(names) == 3 and names[-1] == "white" and sum(map(len, layers)) == 300
    assert str(layers[-1].property(vpype.METADATA_FIELD_COLOR)) == "#ffffff"
    result = CliRunner().invoke(vpype_cli.cli, ["diskpack", str(image), "-n", "100",
                                                "--colors", "cmyk", "--invert"])
    assert result.exit_code == 2 and "cmyk is for white paper" in result.output


def test_analyze_measures_a_black_paper_stippling_on_black(tmp_path):
    from diskpack_cl.reports import analyze_color_stippling

    img = _dark_image() / 255.0
    res = stipple_colors(img, 300, "auto:3", invert=True)
    got = analyze_color_stippling("a.npz", res, img)["delta_e"]
    drawn = color_measures(res.points, res.pen, res.layers, res.colors, img, invert=True)
    assert got == pytest.approx(drawn["delta_e"], rel=1e-9)
