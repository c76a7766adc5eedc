"""Pens: the named palettes, the pen texts of ``--colors``, ``--pens`` and
``--pen-dots``, the paper they are made for, and the colour options
(:class:`ColorOptions`).
"""

from __future__ import annotations

from dataclasses import dataclass
import re

import numpy as np

from .options import OptionConflict, check_fields, option

__all__ = ["PALETTES", "parse_pens", "parse_pen_dots", "AUTO_MAX_PENS", "parse_auto",
           "check_colors", "palette_pens", "palette_of", "check_paper", "PEN_SHARE_EXPONENT",
           "ColorOptions"]


#: Named palettes: (name, sRGB hex) per pen, lightest first.
PALETTES = {
    "cmyk": (("yellow", "#ffff00"), ("cyan", "#00ffff"), ("magenta", "#ff00ff"), ("black", "#000000")),
    "cmy": (("yellow", "#ffff00"), ("cyan", "#00ffff"), ("magenta", "#ff00ff")),
}


def _color(text):
    from PIL import ImageColor  # not loaded at start-up

    try:
        return np.array(ImageColor.getrgb(text)[:3], dtype=np.float64) / 255.0
    except ValueError:
        raise ValueError(f"unknown colour {text!r}: give #rgb, #rrggbb or a CSS colour name") from None


def parse_pens(text):
    """``"black=#000,red=#c00"`` to ``(names, colors)``, colours sRGB in [0, 1].

    Examples
    --------
    >>> names, colors = parse_pens("black=#000,red=#c00")
    >>> names, colors.round(1).tolist()
    (('black', 'red'), [[0.0, 0.0, 0.0], [0.8, 0.0, 0.0]])
    """
    names, colors = [], []
    for item in str(text).split(","):
        name, sep, value = item.strip().partition("=")
        if not sep or not name.strip() or not value.strip():
            raise ValueError(f"bad pen {item.strip()!r}: give NAME=COLOR, e.g. red=#c00")
        names.append(name.strip())
        colors.append(_color(value.strip()))
    if len(set(names)) != len(names):
        raise ValueError(f"pen names must differ, got {', '.join(names)}")
    return tuple(names), np.array(colors)


def parse_pen_dots(text):
    """``"cyan=12000,black=8000"`` to ``{"cyan": 12000, "black": 8000}``: dots per pen.

    Raises
    ------
    ValueError
        An item that is not ``NAME=N``, a count that is not a non-negative
        integer, or a pen named twice.

    Examples
    --------
    >>> parse_pen_dots("cyan=12000, black=8000")
    {'cyan': 12000, 'black': 8000}
    """
    out = {}
    for item in str(text).split(","):
        name, sep, value = (part.strip() for part in item.partition("="))
        if not sep or not name or not value:
            raise ValueError(f"bad pen count {item.strip()!r}: give NAME=N, e.g. cyan=12000")
        try:
            count = int(value)
        except ValueError:
            raise ValueError(f"the dots of pen {name} must be an integer, got {value!r}") from None
        if count < 0:
            raise ValueError(f"the dots of pen {name} must be >= 0, got {count}")
        if name in out:
            raise ValueError(f"pen {name} is given twice")
        out[name] = count
    return out


#: The most pens ``auto:N`` chooses (a plotter's carousel holds about 8).
AUTO_MAX_PENS = 8


def parse_auto(text):
    """The number of pens N of an automatic palette ``"auto:N"``; None for other pens.

    Raises
    ------
    ValueError
        ``auto`` with an N that is not a whole number from 2 to :data:`AUTO_MAX_PENS`.

    Examples
    --------
    >>> parse_auto("auto:4"), parse_auto("cmyk"), parse_auto("auto=#f00")
    (4, None, None)
    >>> parse_auto("auto:1")
    Traceback (most recent call last):
    ...
    ValueError: auto:N takes N = 2 to 8 pens (black and N - 1 colours of the image), got 'auto:1'
    """
    if not isinstance(text, str) or not re.fullmatch(r"auto(:.*)?", text.strip(), re.IGNORECASE):
        return None
    value = text.strip().partition(":")[2].strip()
    if not re.fullmatch(r"[0-9]+", value) or not 2 <= int(value) <= AUTO_MAX_PENS:
        raise ValueError(f"auto:N takes N = 2 to {AUTO_MAX_PENS} pens (black and N - 1 colours of "
                         f"the image), got {text!r}")
    return int(value)


def check_colors(text):
    """Refuse a ``colors`` that is not a palette name or ``auto:N`` (one line).

    Examples
    --------
    >>> check_colors("auto:3")
    >>> check_colors("rgb")
    Traceback (most recent call last):
    ...
    ValueError: colors must be 'cmyk', 'cmy' or 'auto:N' (N = 2 to 8), got 'rgb'
    """
    if text not in PALETTES and parse_auto(text) is None:
        raise ValueError(f"colors must be {', '.join(map(repr, PALETTES))} or 'auto:N' "
                         f"(N = 2 to {AUTO_MAX_PENS}), got {text!r}")


def palette_pens(colors):
    """``(names, colors)`` of a palette name, a ``NAME=COLOR,...`` text or
    ``(name, colour)`` pairs (a colour named as CSS does or sRGB in [0, 1]).

    Examples
    --------
    >>> palette_pens("cmy")[0]
    ('yellow', 'cyan', 'magenta')
    >>> names, colors = palette_pens([("ink", "#000"), ("red", (1.0, 0.0, 0.0))])
    >>> names, colors.tolist()
    (('ink', 'red'), [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    """
    if isinstance(colors, str) and colors.lower() in PALETTES:
        pens = PALETTES[colors.lower()]
        return tuple(p[0] for p in pens), np.array([_color(p[1]) for p in pens])
    if isinstance(colors, str):
        return parse_pens(colors)
    names, rgb = zip(*colors)
    return tuple(names), np.array([_color(c) if isinstance(c, str) else np.asarray(c, float) for c in rgb])


def _pens_before_image(colors):
    """The pen names known before the image is read and the number of pens: all of them,
    except for ``auto:N`` (black only; N pens)."""
    n = parse_auto(colors)
    if n is not None:
        return ("black",), n
    names = palette_pens(colors)[0]
    return names, len(names)


def palette_of(names, colors):
    """What :func:`~diskpack_cl.separation.separate` takes for pens read back from a file:
    ``"cmyk"`` or ``"cmy"`` where they are that palette (so that CMYK separates black first),
    else the pairs.

    Examples
    --------
    >>> palette_of(("yellow", "cyan", "magenta"), [[1, 1, 0], [0, 1, 1], [1, 0, 1]])
    'cmy'
    >>> palette_of(("ink",), [[0.0, 0.0, 0.0]])
    [('ink', (0.0, 0.0, 0.0))]
    """
    colors = np.asarray(colors, dtype=np.float64)
    for key in PALETTES:
        names_p, colors_p = palette_pens(key)
        if tuple(names) == names_p and colors.shape == colors_p.shape and np.allclose(colors, colors_p):
            return key
    return [(name, tuple(float(v) for v in c)) for name, c in zip(names, colors)]


def check_paper(colors, invert):
    """Refuse a named palette made for white paper (``cmyk``, ``cmy``) on black paper (one line).

    Examples
    --------
    >>> check_paper("auto:3", True)
    >>> check_paper("cmyk", True)
    Traceback (most recent call last):
    ...
    ValueError: cmyk is for white paper: on black paper give auto:N (white and N - 1 of the image's hues) or light pens, e.g. white=#fff,red=#f00,green=#0f0,blue=#00f
    """
    if invert and isinstance(colors, str) and colors.strip().lower() in PALETTES:
        raise ValueError(f"{colors.strip()} is for white paper: on black paper give auto:N "
                         f"(white and N - 1 of the image's hues) or light pens, e.g. "
                         f"white=#fff,red=#f00,green=#0f0,blue=#00f")


#: Dots per pen in proportion to their layer's ink to this power unless given
#: (:func:`diskpack_cl.multipen.pen_counts`); measured in docs/color.md.
PEN_SHARE_EXPONENT = 0.7


_COLOUR = "colour (several pens, one certified packing of all dots)"


@dataclass(frozen=True)
class ColorOptions:
    """The separation options of :func:`diskpack_cl.stipple_colors` (``diskpack stipple
    --colors/--pens``); neither ``colors`` nor ``pens``: one pen.

    Examples
    --------
    >>> ColorOptions(colors="cmy").separation()["colors"]
    'cmy'
    >>> ColorOptions().separation() is None
    True
    """

    colors: str = option(None, "separate the image into pen layers: cmyk (black generation "
                         "K = G (1 - max(R, G, B)) in linear light, the other inks separate "
                         "the rest side by side), cmy, or auto:N (N = 2 to 8 pens: black and "
                         "N - 1 of the image's hues at full strength, chosen to fit its colours; "
                         "each pen named by its #rrggbb in the summary and the SVG layers); "
                         "one SVG layer per pen", check=check_colors, metavar="cmyk|cmy|auto:N",
                         group=_COLOUR)
    pens: str = option(None, "any set of pens, e.g. black=#000,red=#c00,blue=#06c: the nearest "
                       "mix of paper and pens side by side (linear RGB)", metavar="NAME=COLOR,...",
                       group=_COLOUR)
    black_generation: float = option(1.0, "cmyk: share of the grey component drawn in black "
                                     "(default 1)", lo=0, hi=1, metavar="G", group=_COLOUR)
    clean_black: float = option(0.0, "pixels with R, G, B all within T of black are pure black "
                                "(default 0)", lo=0, hi=1, metavar="T", group=_COLOUR)
    clean_white: float = option(0.0, "pixels with R, G, B all within T of white get no ink "
                                "(default 0)", lo=0, hi=1, metavar="T", group=_COLOUR)
    pen_share_exponent: float = option(
        PEN_SHARE_EXPONENT, "dots per pen in proportion to its layer's ink to the power A: below 1 "
        "the pens with little ink get more, smaller dots; every pen's dots hold its ink "
        f"(default {PEN_SHARE_EXPONENT:g})", lo=0, hi=1, metavar="A", group=_COLOUR)
    pen_dots: str = option(None, "dots of some or all pens, e.g. cyan=12000,black=8000: the pens "
                           "named get that many, the others share the rest by their ink to "
                           "the power of the pen share exponent (default: all pens share them so)",
                           metavar="NAME=N,...", check=parse_pen_dots, group=_COLOUR)

    def __post_init__(self):
        check_fields(self)
        if self.colors is not None and self.pens is not None:
            raise OptionConflict(f"{{}} {self.colors} and {{}} both name the pens; give one",
                                 "colors", "pens")
        if self.pen_dots is not None and self.colors is None and self.pens is None:
            raise OptionConflict("{} needs the pens: give {} or {}", "pen_dots", "colors", "pens")
        if self.pen_dots is not None:
            names = _pens_before_image(self.pens or self.colors)[0]
            unknown = [name for name in parse_pen_dots(self.pen_dots) if name not in names]
            if unknown:
                text = f"{', '.join(unknown)}, not one of the pens ({', '.join(names)}" + \
                    (", the only pen of auto:N known before the image)" if
                     parse_auto(self.colors) else ")")
                raise OptionConflict("{} names " + text.replace("{", "{{").replace("}", "}}"),
                                     "pen_dots")

    def check_pen_dots(self, n):
        """Refuse dots per pen that cannot add up to `n` dots in all (more than n, or every
        pen named and another sum), before any work.

        Examples
        --------
        >>> ColorOptions(colors="cmy", pen_dots="cyan=10,yellow=5,magenta=5").check_pen_dots(20)
        >>> ColorOptions(colors="cmy", pen_dots="cyan=30").check_pen_dots(20)
        Traceback (most recent call last):
        ...
        diskpack_cl.options.OptionConflict: pen_dots gives 30 dots, more than the 20 in all
        """
        if self.pen_dots is None:
            return
        dots = parse_pen_dots(self.pen_dots)
        given, every = sum(dots.values()), len(dots) == _pens_before_image(self.pens or self.colors)[1]
        if given > n or (every and given != n):
            raise OptionConflict(f"{{}} gives {given} dots, {'more than' if given > n else 'not'} "
                                 f"the {n} in all" + ("; leave a pen out to give it the rest"
                                                      if every and given < n else ""), "pen_dots")

    def separation(self):
        """The arguments of :func:`diskpack_cl.stipple_colors` (pens, separation and dots per
        pen), or None (one pen)."""
        if self.colors is None and self.pens is None:
            return None
        counts = None if self.pen_dots is None else parse_pen_dots(self.pen_dots)
        return dict(colors=self.pens or self.colors, black_generation=self.black_generation,
                    clean_black=self.clean_black, clean_white=self.clean_white, counts=counts,
                    pen_share_exponent=self.pen_share_exponent)
