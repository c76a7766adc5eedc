"""Every file a writer writes reads back: each format through the project's own reader.

A property test writes random certified packings (mono and colour, ``tone``
and ``packing`` dots, white and black paper) through :func:`write_stipple` to
every format it writes, and reads each back with :func:`read_stipple`
(``.npz``, ``.csv``, ``.svg``; a ``.png`` preview holds no dots and is
refused by name): the reader accepts it and the geometry is the written one
to the format's precision. A packing drawn in an SVG reads back certified
(its coordinates are rounded inward), so it writes again to an ``.npz``.
"""

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from PIL import Image

from diskpack_cl.domain import Domain
from diskpack_cl.drawing.writers import read_stipple, write_npz, write_stipple
from diskpack_cl.geometry import certify_disks

# the SVG writes mm with 4 decimals: a centre moves by up to 0.5e-4 mm an axis, a radius
# is written up to 2e-4 mm smaller (rounded inward), never larger, and a dot at the edge
# shrinks by up to 2e-4 mm more to keep that far from it (drawing.EDGE_MM)
SVG_MM = 4e-4


@st.composite
def stipplings(draw):
    """A certified packing: one disk in each cell of a grid (some cells empty), inside it."""
    nx, ny = draw(st.integers(2, 5)), draw(st.integers(2, 4))
    cell = draw(st.integers(4, 20))
    share = st.floats(0.05, 0.5)   # the radius as a share of the cell; 0.5: neighbours may touch
    where = st.floats(0.0, 1.0)
    points, radii = [], []
    for i in range(nx):
        for j in range(ny):
            if not draw(st.booleans()) and len(radii) > 1:
                continue
            r = cell * draw(share)
            points.append([i * cell + r + draw(where) * (cell - 2 * r),
                           j * cell + r + draw(where) * (cell - 2 * r)])
            radii.append(r)
    points, radii = np.array(points), np.array(radii)
    W, H = nx * cell, ny * cell
    assume(certify_disks(points, radii, Domain.rect(W, H)).valid)
    color, invert = draw(st.booleans()), draw(st.booleans())
    # tone dots no wider than the disks: none moves inward, each is where it was
    res = SimpleNamespace(points=points, radii=radii, width=W, height=H, k=0.5,
                          tone_radius=0.5 * float(radii.min()), params={"invert": invert})
    if color:
        # light pens on black paper, process inks on white (cmyk is refused on black)
        names, colors = (("white", "red"), [[1.0, 1.0, 1.0], [1.0, 0.0, 0.0]]) if invert else \
                        (("cyan", "black"), [[0.0, 1.0, 1.0], [0.0, 0.0, 0.0]])
        res.pen = np.arange(len(points)) % 2
        res.names, res.colors = names, np.array(colors)
        res.pen_radius = res.tone_radius * np.array([0.8, 1.0])
    return res


def _drawn_radii(res, dots):
    """The radius (px) each dot is drawn at."""
    if dots == "packing":
        return res.radii
    if getattr(res, "pen", None) is not None:
        return res.pen_radius[res.pen]
    return np.full(len(res.points), res.tone_radius)


def _check_packing_formats(res, tmp_path):
    for ext in (".npz", ".csv"):
        path = tmp_path / f"a{ext}"
        write_stipple(path, res)
        back = read_stipple(path)   # certified again
        np.testing.assert_array_equal(back.points, res.points)   # exact: 17 digits in a CSV
        np.testing.assert_array_equal(back.radii, res.radii)
        assert (back.width, back.height, back.tone_radius) == (res.width, res.height,
                                                                res.tone_radius)
        if getattr(res, "pen", None) is not None:
            np.testing.assert_array_equal(back.pen, res.pen)
            np.testing.assert_array_equal(back.pen_radius, res.pen_radius)
            assert back.names == res.names
            np.testing.assert_allclose(back.colors, res.colors, atol=0.5 / 255)
            assert bool(back.params["invert"]) == res.params["invert"]   # the pens' paper


def _check_svg(res, tmp_path, dots, scale):
    path = tmp_path / "a.svg"
    invert = res.params["invert"]
    write_stipple(path, res, width_mm=res.width * scale, dots=dots, invert=invert,
                  pen_path="greedy")
    back = read_stipple(path)
    assert (back.width, back.height, back.params["invert"]) == (res.width, res.height, invert)
    drawn = _drawn_radii(res, dots)
    # the dots come back in pen-path order: match them by their centres
    order = np.lexsort(back.points.T)
    key = np.lexsort(res.points.T)
    if getattr(res, "pen", None) is not None:   # the layers in drawing order
        assert sorted(back.names) == sorted(res.names)
        pen_of = lambda r: np.asarray(r.names)[r.pen]
        np.testing.assert_array_equal(pen_of(back)[order], pen_of(res)[key])
    np.testing.assert_allclose(back.points[order], res.points[key], atol=SVG_MM / scale)
    assert np.all(back.radii[order] <= drawn[key] + 1e-9)   # rounded inward, never up
    np.testing.assert_allclose(back.radii[order], drawn[key], atol=SVG_MM / scale)
    if dots == "packing":   # what the SVG drew is still a packing: it writes to an .npz
        write_npz(tmp_path / "again.npz", back)
        assert len(read_stipple(tmp_path / "again.npz").points) == len(res.points)


@settings(max_examples=30)
@given(res=stipplings(), dots=st.sampled_from(["tone", "packing"]),
       scale=st.sampled_from([0.25, 1.0, 3.7]))
def test_every_format_reads_back(tmp_path, res, dots, scale):
    _check_packing_formats(res, tmp_path)
    _check_svg(res, tmp_path, dots, scale)
    png = tmp_path / "a.png"
    write_stipple(png, res, png_scale=2.0, dots=dots, invert=res.params["invert"])
    with Image.open(png) as im:
        assert im.size == (2 * res.width, 2 * res.height)
    with pytest.raises(ValueError, match=r"a\.png: .*a \.png preview holds no dots"):
        read_stipple(png)
