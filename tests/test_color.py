"""Colour separation, ink compositing and colour measures (diskpack_cl.separation,
colorspace, color_measures), and the old diskpack_cl.color names."""

import importlib

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from PIL import Image

from diskpack_cl.color import MOVED
from diskpack_cl.color_measures import color_measures, render_pens
from diskpack_cl.colorspace import (area_mix, delta_e, linear_to_srgb, srgb_to_lab, srgb_to_linear,
                                    unmix)
from diskpack_cl.image import load_rgb
from diskpack_cl.pens import palette_pens, parse_pens
from diskpack_cl.separation import separate

PENS3 = "black=#000,red=#c00,blue=#06c"


def _mix(coverage, pens_srgb):
    """The area mix written out: white where no pen, each pen's colour on its share (linear)."""
    lin = srgb_to_linear(np.asarray(pens_srgb))
    out = (1.0 - coverage.sum()) * np.ones(3)
    for a, c in zip(coverage, lin):
        out = out + a * c
    return out


@given(st.lists(st.floats(0, 1), min_size=3, max_size=3), st.sampled_from(["cmy", PENS3]))
def test_area_separation_reproduces_colours_in_the_gamut(raw, palette):
    names, pens = palette_pens(palette)
    a = np.array(raw) / max(1.0, sum(raw))          # coverages of the pens, sum <= 1
    target = linear_to_srgb(_mix(a, pens))
    sep = separate(target[None, None, :], palette)
    got = sep.layers[:, 0, 0]
    assert got.min() >= 0 and got.sum() <= 1 + 1e-9
    # 8-bit quantization of the input bounds the error
    assert delta_e(area_mix(sep.layers, pens)[0, 0], target) < 1.0


@given(st.lists(st.integers(0, 255), min_size=3, max_size=3))
def test_cmyk_black_generation_and_under_colour_removal(rgb8):
    rgb = np.array(rgb8, float) / 255
    sep = separate(rgb[None, None, :], "cmyk")
    a = dict(zip(sep.names, sep.layers[:, 0, 0]))
    lin = srgb_to_linear(rgb)
    assert a["black"] == pytest.approx(1.0 - lin.max(), abs=1e-12)
    if rgb8[0] == rgb8[1] == rgb8[2]:                # a grey is black alone
        assert a["cyan"] + a["magenta"] + a["yellow"] < 1e-6
    assert sum(a.values()) <= 1 + 1e-9


@given(st.lists(st.integers(0, 255), min_size=3, max_size=3), st.floats(0, 1))
def test_overprint_cmyk_is_the_textbook_separation(rgb8, g):
    rgb = np.array(rgb8, float) / 255
    sep = separate(rgb[None, None, :], "cmyk", model="overprint", black_generation=g)
    a = sep.layers[:, 0, 0]
    # inks multiply: each coverage absorbs its share of what its colour lacks
    lin = np.prod(1.0 - a[:, None] * (1.0 - srgb_to_linear(sep.colors)), axis=0)
    assert np.allclose(lin, srgb_to_linear(rgb), atol=1e-9)


def test_clean_black_and_white():
    img = np.array([[[0.04, 0.02, 0.05], [0.97, 0.99, 0.98], [0.5, 0.5, 0.5]]])
    sep = separate(img, PENS3, clean_black=0.06, clean_white=0.05)
    black = sep.names.index("black")
    assert sep.layers[black, 0, 0] == pytest.approx(1.0)
    assert sep.layers[:, 0, 0].sum() == pytest.approx(1.0)
    assert np.all(sep.layers[:, 0, 1] == 0)
    assert separate(img, PENS3).layers[:, 0, 1].sum() > 0     # without the tolerance: some ink


def test_parse_pens_and_errors():
    names, colors = parse_pens(" black = #000 , teal=teal")
    assert names == ("black", "teal")
    assert np.allclose(colors[1], [0, 128 / 255, 128 / 255])
    with pytest.raises(ValueError, match="bad pen 'red'"):
        parse_pens("red")
    with pytest.raises(ValueError, match="unknown colour 'nocolour'"):
        parse_pens("a=nocolour")
    with pytest.raises(ValueError, match="pen names must differ"):
        parse_pens("a=#000,a=#fff")
    with pytest.raises(ValueError, match="model='overprint' is the textbook"):
        separate(np.ones((2, 2, 3)), PENS3, model="overprint")
    with pytest.raises(ValueError, match=r"clean_black must be in \[0, 1\]"):
        separate(np.ones((2, 2, 3)), "cmy", clean_black=2)


def test_lab_and_delta_e_match_scikit_image():
    from skimage.color import deltaE_cie76, rgb2lab

    rgb = np.random.default_rng(1).random((8, 9, 3))
    # the white point and matrix are rounded differently: 0.01 of a Lab unit
    assert np.allclose(srgb_to_lab(rgb), rgb2lab(rgb), atol=0.01)
    other = np.random.default_rng(2).random((8, 9, 3))
    assert delta_e(rgb, other) == pytest.approx(deltaE_cie76(rgb2lab(rgb), rgb2lab(other)).mean(),
                                                rel=1e-3)


def test_load_rgb(tmp_path):
    Image.fromarray(np.full((3, 4), 51, np.uint8), "L").save(tmp_path / "g.png")
    g = load_rgb(tmp_path / "g.png")
    assert g.shape == (3, 4, 3) and np.allclose(g, 0.2)
    rgba = np.zeros((2, 2, 4), np.uint8)
    rgba[..., 0] = 255
    rgba[0, 0, 3] = 255                                   # one opaque red pixel, others clear
    Image.fromarray(rgba, "RGBA").save(tmp_path / "a.png")
    a = load_rgb(tmp_path / "a.png")
    assert a[0, 0].tolist() == [1, 0, 0] and a[1, 1].tolist() == [1, 1, 1]
    with pytest.raises(ValueError, match="values in"):
        load_rgb(np.full((2, 2, 3), 2.0))


def test_render_pens_mixes_disjoint_dots_by_area():
    colors = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    pts = np.array([[5.0, 5.0], [15.0, 5.0]])
    lin = render_pens(pts, [0, 1], [2.0, 3.0], colors, (10, 20))
    # black removes pi 2^2 of light from every channel, red pi 3^2 from green and blue
    lost = (1.0 - lin).sum(axis=(0, 1))
    assert np.allclose(lost, [np.pi * 4, np.pi * 13, np.pi * 13], rtol=2e-3)


def test_color_measures_of_a_perfect_grey():
    """A uniform grey: black dots on a regular lattice give nearly no Delta E."""
    H = W = 60
    rgb = np.full((H, W, 3), 0.6)
    sep = separate(rgb, "cmyk")
    iy, ix = np.mgrid[0:20, 0:20].reshape(2, -1)
    pts = np.column_stack([(3.0 * ix + 0.75 + 1.5 * (iy % 2)), 3.0 * iy + 1.5])
    pen = np.full(len(pts), sep.names.index("black"))
    m = color_measures(pts, pen, sep.layers, sep.colors, rgb)
    assert m["delta_e"] < 1.5
    assert m["p01_joint"] > 0.95
    assert m["p01"][sep.names.index("cyan")] is None          # no cyan dots
    assert m["ssim"][sep.names.index("black")] > 0.9


@settings(max_examples=30)
@given(st.integers(0, 2**32 - 1), st.integers(1, 5))
def test_unmixing_is_as_near_as_nnls(seed, P):
    """The face enumeration finds the nearest mix: no farther than scipy's bounded
    least squares (BVLS, a non-negative one: scipy 1.12-1.13's ``nnls`` stops
    without converging on some of these) with the paper as a further pen and
    a heavily weighted row sum(a) = 1."""
    from scipy.optimize import lsq_linear

    rng = np.random.default_rng(seed)
    pens, targets = rng.random((P, 3)), rng.random((20, 3))
    a = unmix(targets, pens)
    assert np.all(a >= 0) and np.all(a.sum(axis=1) <= 1 + 1e-9)
    A = np.vstack([np.column_stack([np.ones(3), pens.T]), np.full(P + 1, 1e4)])
    for t, got in zip(targets, a):
        ref = lsq_linear(A, np.append(t, 1e4), bounds=(0, np.inf), method="bvls").x
        d_ref = np.linalg.norm(A[:3] @ ref - t)
        d_got = np.linalg.norm((1 - got.sum()) + pens.T @ got - t)
        assert d_got <= d_ref + 1e-6


@settings(max_examples=20)
@given(st.integers(0, 2**32 - 1))
def test_unmixing_three_pens_gives_back_the_mix(seed):
    """Paper and three pens: a colour mixed from them (inside their tetrahedron, where
    the mix is the one answer) separates into the coverages it was mixed from."""
    rng = np.random.default_rng(seed)
    pens = rng.random((3, 3))
    a = rng.dirichlet(np.ones(4), 50)[:, 1:]                 # paper's share first, dropped
    targets = (1 - a.sum(axis=1))[:, None] + a @ pens
    assume(abs(np.linalg.det(pens - 1.0)) >= 1e-3)           # nearly flat: mixes not unique
    assert np.allclose(unmix(targets, pens), a, atol=1e-6)


@pytest.mark.parametrize("name", sorted(MOVED))
def test_old_color_names_forward_to_their_homes_with_a_warning(name):
    """diskpack_cl.color keeps every public name for one release: the same object as in its
    new home, with a DeprecationWarning that names that home."""
    from diskpack_cl import color as old

    home = importlib.import_module(f"diskpack_cl.{MOVED[name]}")
    with pytest.warns(DeprecationWarning, match=rf"diskpack_cl\.{MOVED[name]}\.{name}\b"):
        assert getattr(old, name) is getattr(home, name)
    assert name in home.__all__


def test_old_color_module_refuses_unknown_names():
    from diskpack_cl import color as old

    with pytest.raises(AttributeError, match="'diskpack_cl.color' has no attribute 'nothing'"):
        old.nothing  # noqa: B018
