"""Drawing rules shared by the writers: what fits the picture (:func:`check_fit`), and when
a plot is long or its dots crowded (:func:`long_plot`, :func:`crowded_dots`)."""

import numpy as np
import pytest

from diskpack_cl import stipple, write_stipple
from diskpack_cl.drawing.page import check_fit, crowded_dots, long_plot

PEN_TOO_WIDE = "the pen .* is as wide as the"
DOTS_TOO_WIDE = "wide do not fit the"


@pytest.mark.parametrize("picture", [(30.0, 40.0), (40.0, 30.0)])
def test_a_pen_as_wide_as_the_pictures_smaller_side_is_refused_one_ulp_less_is_not(picture):
    side = min(picture)
    with pytest.raises(ValueError, match=PEN_TOO_WIDE):
        check_fit(np.array([1.0]), picture, side)
    with pytest.raises(ValueError, match=PEN_TOO_WIDE):
        check_fit(np.array([1.0]), picture, np.nextafter(side, np.inf))
    check_fit(np.array([1.0]), picture, np.nextafter(side, 0.0))


@pytest.mark.parametrize("picture", [(30.0, 40.0), (40.0, 30.0)])
def test_dots_as_wide_as_the_pictures_smaller_side_fit_one_ulp_more_do_not(picture):
    side = min(picture)
    check_fit(np.array([1.0, side / 2]), picture)
    with pytest.raises(ValueError, match=DOTS_TOO_WIDE):
        check_fit(np.array([np.nextafter(side / 2, np.inf), 1.0]), picture)


def test_no_dots_and_no_pen_fit():
    check_fit(np.zeros(0), (1.0, 1.0))


@pytest.fixture(scope="module")
def result():
    return stipple(np.tile(np.linspace(0.0, 1.0, 32), (32, 1)), 40)


@pytest.mark.parametrize("suffix, options", [
    (".svg", {"width_mm": 20.0, "pen_mm": 20.0}),   # the 32 x 32 px picture 20 mm wide
    (".png", {"png_scale": 2.0, "width_mm": 20.0, "pen_mm": 20.0}),   # 64 px of 64 x 64
])
def test_writers_refuse_a_pen_as_wide_as_the_picture(tmp_path, result, suffix, options):
    with pytest.raises(ValueError, match=PEN_TOO_WIDE):
        write_stipple(tmp_path / f"a{suffix}", result, **options)
    assert list(tmp_path.iterdir()) == []


def test_a_plot_exactly_as_long_as_the_limit_is_not_warned_of():
    """0.25 s a lift and 100 s: 400 dots take the limit, 401 more."""
    assert long_plot(400, pen_lift_s=0.25, limit_s=100.0) is None
    assert long_plot(401, pen_lift_s=0.25, limit_s=100.0).startswith("401 dots take at least")


def test_dots_exactly_the_ratio_as_wide_as_their_spacing_are_not_crowded():
    assert crowded_dots(2.0, 1.0) is None
    assert crowded_dots(np.nextafter(2.0, 3.0), 1.0).startswith("dots of 2 mm overlap")
    assert crowded_dots(3.0, 1.0, ratio=3.0) is None
    assert crowded_dots(2.5, 1.0, ratio=3.0) is None
    assert crowded_dots(None, 1.0) is None and crowded_dots(5.0, None) is None
