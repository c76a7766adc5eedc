"""The whole-page preview (``--preview page``): the paper, its margins, and the dots
where the SVG draws them, as wide as their ink."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image
from scipy import ndimage

from diskpack_cl import cli
from diskpack_cl.drawing.writers import WriteOptions, write_npz, write_page_png, write_stipple, write_svg
from diskpack_cl.memory import MemoryLimit, check_stipple_memory

SVG = "{http://www.w3.org/2000/svg}"
LABEL = "{http://www.inkscape.org/namespaces/inkscape}label"
A5 = (148.0, 210.0)
MARGIN = 15.0


def _dots(seed=0, pens=None):
    """Disjoint disks on a jittered grid of a 60 x 40 px picture (and a pen each)."""
    rng = np.random.default_rng(seed)
    gx, gy = np.meshgrid(np.arange(4.0, 60, 8), np.arange(4.0, 40, 8))
    points = np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-0.8, 0.8, (gx.size, 2))
    res = SimpleNamespace(points=points, radii=rng.uniform(1.5, 2.8, gx.size), width=60,
                          height=40)
    if pens is not None:
        res.pen = np.arange(gx.size) % len(pens)
        res.names = tuple(pens)
        res.colors = np.array([[0.9, 0.1, 0.1], [0.1, 0.2, 0.9]])[: len(pens)]
        res.pen_radius = np.full(len(pens), 2.0)
    return res


def _svg_circles(path):
    """``{layer label: (n, 2) centres, (n,) radii}`` of the circles of an SVG (mm), and its metadata."""
    root = ET.parse(path).getroot()
    layers = {}
    for g in root.iter(f"{SVG}g"):
        circles = g.findall(f"{SVG}circle")
        if circles:
            c = np.array([[float(e.get(k)) for k in ("cx", "cy", "r")] for e in circles])
            layers[g.get(LABEL)] = (c[:, :2], c[:, 2])
    return layers, json.loads(root.find(f"{SVG}metadata").text)


def _blobs(ink):
    """Ink-weighted centres ((x, y), pixel units, pixel centres at +0.5) and ink of the dots.

    A dot is a connected part of the pixels more than half inked, with its
    anti-aliased rim (two pixels around; the dots are further apart).
    """
    labels, n = ndimage.label(ink > 0.5)
    labels = ndimage.grey_dilation(labels, size=5)
    idx = np.arange(1, n + 1)
    cy, cx = np.array(ndimage.center_of_mass(ink, labels, idx)).T
    return np.column_stack([cx + 0.5, cy + 0.5]), ndimage.sum(ink, labels, idx)


def _area_px(ppm):
    """The usable area of the A5 page, in pixels: x0, y0, x1, y1."""
    return np.array([MARGIN, MARGIN, A5[0] - MARGIN, A5[1] - MARGIN]) * ppm


def _check_page(ink, centres_mm, ppm):
    """White paper outside the margins, ink inside only, a blob at every dot within a pixel."""
    x0, y0, x1, y1 = _area_px(ppm)
    yy, xx = np.mgrid[: ink.shape[0], : ink.shape[1]] + 0.5
    outside = (xx < x0 - 1.5) | (xx > x1 + 1.5) | (yy < y0 - 1.5) | (yy > y1 + 1.5)
    assert np.all(ink[outside] == 0), "the paper outside the margin line is white"
    line = (ink > 0) & (ink < 0.3)
    assert line[outside].sum() == 0 and line.sum() > 2 * (x1 - x0), "a light margin line"
    dark = ink > 0.5
    assert dark.sum() > 0 and not np.any(dark & ((xx < x0) | (xx > x1) | (yy < y0) | (yy > y1)))
    found, _ = _blobs(ink)
    assert len(found) == len(centres_mm)
    want = centres_mm * ppm
    dist = np.linalg.norm(found[:, None] - want[None], axis=2).min(axis=1)
    assert dist.max() < 1.0, "each dot where the SVG draws it"


def test_the_page_preview_shows_the_svg_page(tmp_path):
    npz, svg, png = (tmp_path / f"a.{ext}" for ext in ("npz", "svg", "png"))
    write_npz(npz, _dots())
    assert cli.main(["export", str(npz), "-o", str(svg), "-o", str(png), "--page", "a5",
                     "--margin-mm", str(MARGIN), "--dots", "packing", "--radius-scale", "0.6",
                     "--png-scale", "8", "--preview", "page", "-q"]) == 0
    (centres, radii), = _svg_circles(svg)[0].values()
    meta = _svg_circles(svg)[1]
    ppm = 8 / meta["mm_per_px"]   # PNG pixels per mm: --png-scale per image pixel
    assert meta["offset_mm"][1] > 2 * MARGIN   # the picture is well inside the page
    with Image.open(png) as im:
        assert im.mode == "L" and im.size == (round(A5[0] * ppm), round(A5[1] * ppm))
        assert im.info["dpi"][0] == pytest.approx(ppm * 25.4, rel=1e-3)
        ink = 1.0 - np.asarray(im, dtype=np.float64) / 255
    _check_page(ink, centres, ppm)
    # each dot as much ink as its drawn disk
    _, area = _blobs(ink)
    want = np.sort(np.pi * (radii * ppm) ** 2)
    assert np.sort(area) == pytest.approx(want, rel=0.03)


def test_the_picture_preview_is_still_the_default(tmp_path):
    npz, png = tmp_path / "a.npz", tmp_path / "a.png"
    write_npz(npz, _dots())
    assert cli.main(["export", str(npz), "-o", str(png), "--page", "a5", "--dots", "packing",
                     "--png-scale", "2", "-q"]) == 0
    with Image.open(png) as im:
        assert im.size == (120, 80)


def test_without_a_paper_the_page_is_the_picture(tmp_path):
    """No margins to show: the page preview is the picture preview, with no line at its edges."""
    npz = tmp_path / "a.npz"
    write_npz(npz, _dots())
    for preview in ("picture", "page"):
        assert cli.main(["export", str(npz), "-o", str(tmp_path / f"{preview}.png"), "--dots",
                         "packing", "--png-scale", "4", "--preview", preview, "-q"]) == 0
    with Image.open(tmp_path / "picture.png") as a, Image.open(tmp_path / "page.png") as b:
        assert a.size == b.size == (240, 160)
        diff = np.abs(np.asarray(a, dtype=int) - np.asarray(b, dtype=int))
    # the page shows the dots as the SVG writes them (radii rounded inward on its 0.0001 mm
    # grid): at most one of a pixel's 4 x 4 samples differs, at a few edge pixels
    assert diff.max() <= 16 and np.count_nonzero(diff > 1) <= 0.01 * diff.size


def test_the_pen_inks_at_least_its_own_width(tmp_path):
    """With a pen, a dot narrower than the pen is a pen touch: half the pen's width around it."""
    res = _dots(1)
    pen = 3.0
    kw = dict(page="a5", margin_mm=MARGIN, dots="packing", radius_scale=0.4, pen_mm=pen)
    info = write_page_png(tmp_path / "p.png", res, png_scale=8.0, **kw)
    svg = write_svg(tmp_path / "p.svg", res, **kw)
    ppm = info["dpi"] / 25.4
    drawn = np.maximum(res.radii * 0.4 * svg["width_mm"] / res.width, 0.5 * pen)
    assert np.any(res.radii * 0.4 * svg["width_mm"] / res.width < 0.5 * pen)
    with Image.open(tmp_path / "p.png") as im:
        ink = 1.0 - np.asarray(im, dtype=np.float64) / 255
    _, area = _blobs(ink)
    assert np.sort(area) == pytest.approx(np.sort(np.pi * (drawn * ppm) ** 2), rel=0.03)


def test_a_colour_page_preview_has_each_pen_where_its_layer_is(tmp_path):
    res = _dots(2, pens=("red", "blue"))
    kw = dict(page="a5", margin_mm=MARGIN, dots="packing", radius_scale=0.6)
    info = write_page_png(tmp_path / "c.png", res, png_scale=8.0, **kw)
    write_stipple(tmp_path / "c.svg", res, **kw)   # the colour SVG: a layer per pen
    layers, _ = _svg_circles(tmp_path / "c.svg")
    ppm = info["dpi"] / 25.4
    with Image.open(tmp_path / "c.png") as im:
        assert im.mode == "RGB" and im.size == (round(A5[0] * ppm), round(A5[1] * ppm))
        rgb = np.asarray(im, dtype=np.float64) / 255
    _check_page(1.0 - rgb.min(axis=2), np.vstack([c for c, _ in layers.values()]), ppm)
    # the red pen's ink takes the blue light, the blue pen's the red light
    for name, channel in (("red", 2), ("blue", 0)):
        found, _ = _blobs(1.0 - rgb[..., channel])
        want = layers[name][0] * ppm
        assert len(found) == len(want)
        assert np.linalg.norm(found[:, None] - want[None], axis=2).min(axis=1).max() < 1.0


def test_the_memory_check_counts_the_whole_page():
    options = WriteOptions(page="a3", margin_mm=100, preview="page")
    area = options.preview_area(100, 100)
    assert area[0] > 100 and area[1] > 100
    check_stipple_memory(100, 100, 1000, supersample=1, png_scale=10, outputs=["a.png"],
                         free=10**8)
    with pytest.raises(MemoryLimit, match="png_scale"):
        check_stipple_memory(100, 100, 1000, supersample=1, png_scale=10, png_area=area,
                             outputs=["a.png"], free=10**8)
