"""CMYK black generation at settings other than 1, against grey-component replacement
computed here from its textbook definition (not with the library's helpers)."""

import numpy as np
import pytest

from diskpack_cl.separation import separate

# 8-bit sRGB, as separate() quantizes its input
COLOURS = {"grey": (128, 128, 128), "dark teal": (10, 64, 60), "orange": (255, 128, 0),
           "pale rose": (240, 220, 225), "white": (255, 255, 255), "black": (0, 0, 0)}
SETTINGS = (0.0, 0.3, 0.7, 1.0)


def _linear(srgb8):
    """IEC 61966-2-1 decoding of 8-bit sRGB."""
    v = np.asarray(srgb8, dtype=np.float64) / 255.0
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def _gcr(srgb8, g):
    """Grey-component replacement in linear light: the ideal inks' amounts C, M, Y = 1 - R,
    1 - G, 1 - B, black K = g min(C, M, Y), and what is left of C, M, Y."""
    cmy = 1.0 - _linear(srgb8)
    k = g * cmy.min()
    return k, cmy - k


def _project_capped_simplex(v, cap):
    """The nearest point to v of {a >= 0, sum(a) <= cap} (sort-based, Duchi et al. 2008)."""
    a = np.maximum(v, 0.0)
    if a.sum() <= cap:
        return a
    u = np.sort(v)[::-1]
    css = np.cumsum(u) - cap
    rho = np.nonzero(u - css / np.arange(1, len(u) + 1) > 0)[0][-1]
    return np.maximum(v - css[rho] / (rho + 1), 0.0)


def _layers(srgb8, g, model):
    sep = separate(np.array([[srgb8]], dtype=np.uint8), "cmyk", black_generation=g, model=model)
    return dict(zip(sep.names, sep.layers[:, 0, 0]))


@pytest.mark.parametrize("g", SETTINGS)
@pytest.mark.parametrize("name", COLOURS)
def test_area_cmyk_black_is_the_grey_component_times_the_setting(name, g):
    # dots side by side: black covers K, and R = 1 - K - cyan (cyan absorbs red), so the
    # coloured pens are the remaining C, M, Y, or where they do not fit in the area 1 - K
    # (dark colours with little black), the nearest amounts that do
    k, rest = _gcr(COLOURS[name], g)
    got = _layers(COLOURS[name], g, "area")
    want = _project_capped_simplex(rest, 1.0 - k)
    assert got["black"] == pytest.approx(k, abs=1e-9)
    assert [got["cyan"], got["magenta"], got["yellow"]] == pytest.approx(want.tolist(), abs=1e-7)


@pytest.mark.parametrize("g", SETTINGS)
@pytest.mark.parametrize("name", COLOURS)
def test_overprint_cmyk_black_is_the_grey_component_times_the_setting(name, g):
    # inks over each other: under-colour removal divides what is left by the light black passes
    k, rest = _gcr(COLOURS[name], g)
    got = _layers(COLOURS[name], g, "overprint")
    want = rest / (1.0 - k) if k < 1.0 - 1e-9 else np.zeros(3)
    assert got["black"] == pytest.approx(k, abs=1e-9)
    assert [got["cyan"], got["magenta"], got["yellow"]] == pytest.approx(want.tolist(), abs=1e-9)


def test_less_black_generation_leaves_dark_colours_to_the_coloured_pens():
    # the setting moves ink from black into cyan, magenta and yellow on a dark teal
    black = [_layers(COLOURS["dark teal"], g, "area")["black"] for g in SETTINGS]
    cyan = [_layers(COLOURS["dark teal"], g, "area")["cyan"] for g in SETTINGS]
    assert np.all(np.diff(black) > 0.05) and np.all(np.diff(cyan) < 0)
