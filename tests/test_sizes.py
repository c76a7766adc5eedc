"""Drawn sizes: a warning when the dots are drawn far wider than their spacing, and a pen
wider than a dot keeps its ink inside the usable part of the page."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st

from diskpack_cl import cli
from diskpack_cl.drawing.color_writers import write_color_svg
from diskpack_cl.drawing.page import CROWDED_RATIO, svg_layout
from diskpack_cl.drawing.writers import write_stipple, write_svg
from diskpack_cl.memory import (HOST_BYTES_PER_CELL, HOST_BYTES_PER_PNG_PIXEL, MemoryLimit,
                                check_png_memory, check_stipple_memory)

SVG = "{http://www.w3.org/2000/svg}"


def _grid(w=60, h=40, step=8.0, r=2.0):
    """Disjoint disks on a grid of a ``w x h`` px picture, the outer ones on its edge."""
    gx, gy = np.meshgrid(np.arange(r, w - r + 1e-9, step), np.arange(r, h - r + 1e-9, step))
    points = np.column_stack([gx.ravel(), gy.ravel()])
    return SimpleNamespace(points=points, radii=np.full(len(points), r), width=w, height=h,
                           k=0.5, tone_radius=1.0)


# ------------------------------------------------------------ dots drawn far wider than their spacing

def test_dots_far_wider_than_their_spacing_are_warned_of(capsys, tmp_path):
    rc = cli.main(["stipple", "sample", "-n", "2000", "--dot-mm", "50", "-o",
                   str(tmp_path / "x.svg")])
    err = capsys.readouterr().err
    assert rc == 0
    assert re.search(r"warning: dots of 50 mm overlap their neighbours: median spacing of "
                     r"their centres on paper [0-9.]+ mm \(warned above 2 x\); see --no-overlap",
                     err), err


def test_the_default_dots_of_a_photograph_are_not_warned_of(capsys, tmp_path):
    assert cli.main(["stipple", "sample", "-n", "2000", "-o", str(tmp_path / "x.svg")]) == 0
    assert "warning" not in capsys.readouterr().err


@pytest.mark.parametrize("flags, warned", [
    ([], False),
    (["--dot-mm", "4.5"], True),     # grid spacing 2.12 mm: 4.5 > 2 x 2.12
    (["--dot-mm", "4"], False),      # 4 < 2 x 2.12: neighbours overlap, centres stay clear
    (["--dot-mm", "4.5", "--no-overlap"], False),
    (["--dot-mm", "4.5", "--quiet"], False),
])
def test_export_warns_of_dots_wider_than_twice_their_spacing(tmp_path, capsys, monkeypatch,
                                                             flags, warned):
    monkeypatch.chdir(tmp_path)
    write_stipple("dots.npz", _grid(240, 160))
    assert cli.main(["export", "dots.npz", "-o", "a.svg", "--dpi", "96", *flags]) == 0
    assert ("warning: dots of" in capsys.readouterr().err) == warned


def test_the_svg_reports_the_spacing_and_the_ink_width(tmp_path):
    info = write_svg(tmp_path / "a.svg", _grid(), width_mm=60, dot_mm=3.0)
    assert info["median_spacing_mm"] == pytest.approx(8.0)
    assert info["median_ink_mm"] == pytest.approx(3.0)
    assert CROWDED_RATIO == 2


# ------------------------------------------------------------ the pen's ink stays on the usable area

def _ink_boxes(path):
    """Each dot's ink as drawn, ``(x0, y0, x1, y1)`` mm: a circle's stroke reaches half the
    pen beyond its radius, a pen touch (``M x,y h 0.01``) half the pen around its line, a
    path of rings half the pen beyond its outer ring."""
    root = ET.parse(path).getroot()
    boxes = []
    for g in root.iter(f"{SVG}g"):
        pen = float(g.get("stroke-width") or 0)
        for e in g.findall(f"{SVG}circle"):
            x, y, r = (float(e.get(k)) for k in ("cx", "cy", "r"))
            boxes.append((x - r, y - r, x + r, y + r, pen))
        for e in g.findall(f"{SVG}path"):
            d = e.get("d")
            touch = re.fullmatch(r"M ([-0-9.]+),([-0-9.]+) h ([0-9.]+)", d)
            if touch:
                x, y, dx = map(float, touch.groups())
                boxes.append((x, y, x + dx, y, pen))
                continue
            x, y, r = map(float, re.match(r"M ([-0-9.]+),([-0-9.]+) a ([0-9.]+),", d).groups())
            boxes.append((x - 2 * r, y - r, x, y + r, pen))
    b = np.array(boxes)
    half = 0.5 * b[:, 4:5]
    return np.hstack([b[:, :2] - half, b[:, 2:4] + half])


def _inside(boxes, area):
    x0, y0, x1, y1 = area
    return bool(np.all((boxes[:, 0] >= x0) & (boxes[:, 1] >= y0) & (boxes[:, 2] <= x1)
                       & (boxes[:, 3] <= y1)))


@pytest.mark.parametrize("writer", [write_svg, write_color_svg])
@pytest.mark.parametrize("drawing", [
    {"dot_mm": 0.2, "pen_mm": 1.5},                 # pen touches, ink 0.65 mm beyond the dots
    {"dot_mm": 2.0, "pen_mm": 1.5},                 # one ring: the ink is the dot
    {"dot_mm": 5.0, "pen_mm": 1.5},                 # rings
    {"dots": "packing", "pen_mm": 2.0},
])
@pytest.mark.parametrize("page", [
    {"page": "a5", "margin_mm": 10},                # the picture fills the margins' width
    {"page": "a5", "landscape": True, "margin_mm": 12},
    {"page": "a4", "plotter": "hp7475a"},
    {"width_mm": 60},                               # the page is the picture
])
def test_no_ink_leaves_the_usable_area(tmp_path, writer, drawing, page):
    res = _grid(r=0.1)                              # centres 0.1 px from the edges
    if writer is write_color_svg:
        res.pen = np.arange(len(res.points)) % 2
        res.names = ("red", "blue")
        res.colors = np.array([[0.9, 0.1, 0.1], [0.1, 0.2, 0.9]])
        res.pen_radius = np.full(2, 0.1)
    if "plotter" in page:
        pytest.importorskip("vpype")
    path = tmp_path / "a.svg"
    writer(path, res, **drawing, **page)
    area = svg_layout(60, 40, **page)["area"]
    assert _inside(_ink_boxes(path), area)


# ------------------------------------------------------------ sizes refused before the work

NO_DEVICE = "no-such-device"   # the host's memory alone limits the raster


def _largest_named(exc):
    return float(re.search(r"at most ([0-9.]+) here", str(exc)).group(1))


@settings(max_examples=60)
@given(width=st.integers(1, 5000), height=st.integers(1, 5000), supersample=st.integers(2, 64),
       free=st.integers(2 ** 20, 2 ** 36))
def test_the_supersample_named_as_fitting_fits_and_one_more_does_not(width, height, supersample,
                                                                     free):
    def check(s):
        check_stipple_memory(width, height, 1000, supersample=s, free=free, device=NO_DEVICE)

    assume(width * height * supersample ** 2 * HOST_BYTES_PER_CELL > free)
    with pytest.raises(MemoryLimit, match="supersample") as refused:
        check(supersample)
    assume("at most" in str(refused.value))   # else: downscale the image
    fit = int(_largest_named(refused.value))
    check(fit)
    with pytest.raises(MemoryLimit):
        check(fit + 1)


@settings(max_examples=60)
@given(width=st.integers(1, 5000), height=st.integers(1, 5000), scale=st.floats(1, 1e4),
       free=st.integers(2 ** 20, 2 ** 36))
def test_the_png_scale_named_as_fitting_fits(width, height, scale, free):
    def check(s):
        check_png_memory(width, height, s, ["a.png"], free=free)

    assume(width * height * scale ** 2 * HOST_BYTES_PER_PNG_PIXEL > 2 * free)
    with pytest.raises(MemoryLimit, match="png_scale") as refused:
        check(scale)
    fit = _largest_named(refused.value)
    assume(fit > 0)
    check(fit)


def test_export_names_a_png_too_large_before_writing_anything(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_stipple("dots.npz", _grid())
    assert cli.main(["export", "dots.npz", "-o", "a.svg", "-o", "a.png",
                     "--png-scale", "1e6"]) == 1
    assert re.search(r"--png-scale 1e\+06 makes a 60000000x40000000 PNG needing [0-9.e+]+ GiB"
                     r".*lower --png-scale", capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dots.npz"]


def test_a_tiled_run_names_a_png_too_large_before_the_tiles(tmp_path, capsys, monkeypatch):
    import diskpack_cl.jobs.tiles

    def no_tiles(*args, **kwargs):
        raise AssertionError("the tiles ran")

    monkeypatch.setattr(diskpack_cl.jobs.tiles, "stipple_tiled", no_tiles)
    out = tmp_path / "t.png"
    assert cli.main(["stipple", "sample", "-n", "2000", "--tiles", "2x2", "--png-scale", "1e4",
                     "-o", str(out)]) == 1
    assert re.search(r"--png-scale 10000 makes a 5120000x5120000 PNG needing [0-9.e+]+ GiB",
                     capsys.readouterr().err)
    assert list(tmp_path.iterdir()) == []
