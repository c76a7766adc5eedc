"""Results that show themselves: ``_repr_png_`` and ``preview()`` of stipplings and point sets."""

import io

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from PIL import Image

from diskpack_cl import StippleResult, poisson_disk, preview, stipple, stipple_colors
from diskpack_cl.poisson3 import dart_throwing3
from diskpack_cl.relax import RelaxResult

PNG = b"\x89PNG\r\n\x1a\n"


def _png(result):
    data = result._repr_png_()
    assert data[:8] == PNG
    with Image.open(io.BytesIO(data)) as im:
        im.load()
        return data, im.convert("RGB")


def _dots(points, radii, width, height, **extra):
    return StippleResult(points=np.asarray(points, float), radii=np.asarray(radii, float), k=1.0,
                         base_radii=np.asarray(radii, float), certificate=None, history=[],
                         width=width, height=height, **extra)


@settings(max_examples=40)
@given(st.integers(20, 900), st.integers(20, 900), st.integers(1, 40), st.data())
def test_dark_pixels_are_where_the_dots_are(width, height, n, data):
    scale = 400 / max(width, height)
    assume(min(width, height) * scale >= 8)
    # dots at least 1.5 preview pixels wide, apart by more than their reach
    r = data.draw(st.floats(1.5, 4.0)) / scale
    points = np.array(data.draw(st.lists(
        st.tuples(st.floats(0, width), st.floats(0, height)), min_size=n, max_size=n)))
    _, im = _png(_dots(points, np.full(n, r), width, height))
    gray = np.asarray(im.convert("L"), dtype=float)
    assert max(im.size) == 400
    h, w = gray.shape
    yy, xx = np.mgrid[0:h, 0:w] + 0.5
    reach = np.min(np.hypot(xx[..., None] - points[:, 0] * scale,
                            yy[..., None] - points[:, 1] * scale), axis=-1)
    assert np.all(gray[reach > r * scale + 1.0] == 255)   # paper away from every dot
    centre = np.clip((points * scale).astype(int), 0, [w - 1, h - 1])
    assert np.all(gray[centre[:, 1], centre[:, 0]] < 80)   # ink under every dot's centre


def test_a_real_stippling_shows_its_tone():
    g = np.tile(np.linspace(0.0, 1.0, 96), (64, 1))   # dark on the left
    res = stipple(g, 400, schedule=[("mix", 3, 0.5)], backend="exact")
    data, im = _png(res)
    gray = np.asarray(im.convert("L"), dtype=float) / 255
    assert im.size == (400, 267) and len(data) < 60_000
    left, right = gray[:, :100].mean(), gray[:, -100:].mean()
    assert left < 0.4 and right > 0.8   # the dots' ink follows the picture
    assert res.preview(100).size == (100, 67)


def test_twenty_thousand_dots_make_a_small_png():
    rng = np.random.default_rng(0)
    res = _dots(rng.random((20_000, 2)) * 512, np.full(20_000, 1.2), 512, 512,
                tone_radius=1.2)
    data, im = _png(res)
    assert im.size == (400, 400) and len(data) < 120_000


def test_dark_paper_draws_light_dots():
    res = _dots([[10.0, 10.0]], [3.0], 20, 20, params={"invert": True})
    gray = np.asarray(res.preview().convert("L"))
    assert gray[200, 200] == 255 and gray[5, 5] == 0


def test_colour_stippling_draws_each_pen_in_its_colour():
    y, x = np.mgrid[0:48, 0:64] / 64.0
    res = stipple_colors(np.dstack([x, y, 1 - x]).clip(0, 1), 300, "cmyk", backend="exact",
                         schedule=[("mix", 2, 0.5)])
    _, im = _png(res)
    rgb = np.asarray(im, dtype=float) / 255
    scale = 400 / 64
    for p, colour in enumerate(res.colors):
        at = (res.points[res.pen == p] * scale).astype(int)
        if len(at):
            seen = rgb[np.minimum(at[:, 1], rgb.shape[0] - 1), np.minimum(at[:, 0], 399)]
            # the pen's colour where its dots are (another pen's dot may lie over a few)
            assert np.median(np.abs(seen - colour).max(axis=1)) < 0.2, res.names[p]


def test_point_sets_show_their_points():
    res = poisson_disk(300, backend="exact", seed=1)
    _, im = _png(res)
    gray = np.asarray(im.convert("L"))
    at = np.minimum((res.points * 400).astype(int), 399)
    assert im.size == (400, 400) and np.all(gray[at[:, 1], at[:, 0]] < 128)
    assert np.mean(gray == 255) > 0.8   # dots, not a fill


def test_a_3d_set_shows_a_slice():
    points = dart_throwing3(2000, seed=1)
    res = RelaxResult(points, np.array([0.5]), 0, "eps", 0.0, {}, "exact", "")
    _, im = _png(res)
    gray = np.asarray(im.convert("L"))
    near = points[points[:, 2] < 0.05]
    at = np.minimum((near[:, :2] * 400).astype(int), 399)
    assert np.all(gray[at[:, 1], at[:, 0]] < 128)
    assert np.mean(gray < 255) < 0.2   # a slice of the set, not its whole shadow


@pytest.mark.parametrize("size", [0, 7, 2.5, "400"])
def test_bad_size_is_refused(size):
    res = _dots([[1.0, 1.0]], [0.5], 4, 4)
    with pytest.raises(ValueError, match=f"must be an integer of at least 8 pixels, got {size!r}"):
        preview(res, size)


def test_nothing_to_preview_is_refused():
    res = RelaxResult(np.zeros((0, 2)), np.array([0.0]), 0, "eps", 0.0, {}, "exact", "")
    with pytest.raises(ValueError, match="nothing to preview: RelaxResult has no"):
        res.preview()
