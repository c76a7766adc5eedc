"""Writers for colour stipplings (:class:`diskpack_cl.multipen.ColorStippleResult`).

:func:`diskpack_cl.drawing.writers.write_stipple` sends a result with a ``pen``
attribute here for ``.svg`` and ``.png``; ``.npz`` and ``.csv`` are the mono
writers with the pens added (a ``pen`` column, pen names and colours).

* SVG: one Inkscape layer per pen (``<g inkscape:groupmode="layer"
  inkscape:label="NAME">``, which vpype reads as one layer each), the pen's
  colour as stroke (and fill), lightest pen first (or ``pen_order``), each
  layer's dots along a short pen path.
* PNG: the inks composited (:func:`diskpack_cl.color_measures.render_pens`'s model:
  coverages multiply in linear light), 8-bit sRGB.

A stippling made with ``invert`` (light pens on black paper, its
``params["invert"]``) is drawn on black: the SVG's paper is a black image
in a layer that plotters skip (as for one pen), the PNG's paper black,
each pen's light added as :func:`diskpack_cl.color_measures.render_pens` adds it.
The pens go darkest first and white last: as on white paper, the pen
that stands out least from the paper first, so that where dots touch the
one that carries the most light is on top.
"""

from __future__ import annotations

import numpy as np

from ..colorspace import linear_negative, linear_to_srgb, srgb_to_linear
from ..pens import check_paper, palette_of
from .page import (FRAME_INK, MM_PER_INCH, check_fit, ink_coverage, page_frame, place_dots,
                   save_png, svg_dots, svg_head, svg_layout, svg_meta, svg_size, xml_attr)
from .pen_path import pen_path_order, two_opt_rounds
from ..io import atomic_write
from .overlap import cap_radii, check_apart, ink_figures
from .readers import check_stippling
from .write_options import plot_seconds, write_options

__all__ = ["layer_order", "on_black", "write_color_svg", "write_color_png", "write_color_page_png"]


def layer_order(names, colors, pen_order=None, invert=False):
    """Pen indices in drawing order: `pen_order` (names), else lightest first (luminance), on
    black paper (`invert`) darkest first.

    Examples
    --------
    >>> layer_order(("black", "yellow"), np.array([[0, 0, 0], [1, 1, 0.0]]))
    [1, 0]
    >>> layer_order(("white", "blue"), np.array([[1, 1, 1], [0, 0, 1.0]]), invert=True)
    [1, 0]
    >>> layer_order(("black", "yellow"), np.zeros((2, 3)), ["black", "yellow"])
    [0, 1]
    """
    if pen_order is None:
        lum = srgb_to_linear(np.asarray(colors)) @ np.array([0.2126, 0.7152, 0.0722])
        return [int(i) for i in np.argsort(lum if invert else -lum, kind="stable")]
    order = list(pen_order)
    if sorted(order) != sorted(names):
        raise ValueError(f"pen order must name every pen once ({', '.join(names)}), got "
                         f"{', '.join(order)}")
    return [names.index(name) for name in order]


def on_black(result, invert=False):
    """Whether a colour stippling is drawn on black paper: as its pens were separated
    (``params["invert"]``), or where it does not say (read from a CSV) as `invert` says.

    Raises
    ------
    ValueError
        `invert` for pens separated for white paper, or black paper for the pens of a
        white-paper palette (``cmyk``, ``cmy``: :func:`~diskpack_cl.pens.check_paper`).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> light = dict(names=("white",), colors=np.ones((1, 3)))
    >>> on_black(SimpleNamespace(params={"invert": True}, **light)), on_black(SimpleNamespace(params={}, **light), True)
    (True, True)
    """
    made = (getattr(result, "params", None) or {}).get("invert")
    if invert and made is not None and not made:
        raise ValueError("invert: this colour stippling's pens were separated for white paper; "
                         "stipple it with invert for light pens on black paper")
    black = bool(invert if made is None else made)
    if black:   # a file that does not say its paper: its pens may
        try:
            check_paper(palette_of(result.names, result.colors), True)
        except ValueError as exc:
            raise ValueError(f"invert: black paper for pens {', '.join(result.names)}: "
                             f"{exc}") from None
    return black


def _radii(result, scale, dots, radius_scale):
    """Drawn radius per dot in output units (``scale`` of them per pixel): each pen's tone
    radius (the one tone radius of a stippling read from CSV), or the packing disks."""
    if dots == "packing":
        return np.asarray(result.radii) * scale * radius_scale
    per_pen = getattr(result, "pen_radius", None)
    tone = np.full(len(result.names), result.tone_radius) if per_pen is None else per_pen
    return np.asarray(tone)[result.pen] * scale * radius_scale


def _paint(color, pen_mm):
    return (f'fill="{color}" stroke="{color}" stroke-width="0"' if pen_mm is None else
            f'fill="none" stroke="{color}" stroke-width="{pen_mm:.4f}" stroke-linecap="round" '
            f'stroke-linejoin="round"')


def _drawn_dots(result, o):
    """The page and the dots of :func:`write_color_svg`: ``(layout, centres, radii, drawn
    radii, moved)``, in mm (``radii`` before ``no_overlap`` and the move inward)."""
    lay = svg_layout(float(result.width), float(result.height), **o.layout())
    rad = (np.full(len(result.points), 0.5 * float(o.dot_mm)) if o.dot_mm is not None
           else _radii(result, lay["scale"], o.dot_kind, o.radius_scale))
    check_fit(rad, lay["picture"], o.pen_mm)
    pm, drawn, moved = place_dots(np.asarray(result.points), rad,
                                  np.asarray(result.radii) * lay["scale"], lay,
                                  no_overlap=o.no_overlap, pen=o.pen_mm)
    return lay, pm, rad, drawn, moved


def write_color_svg(path, result, options=None, **overrides):
    """Write an SVG with one named layer per pen (see the module docstring).

    The options (:class:`~diskpack_cl.drawing.write_options.WriteOptions`, and
    `overrides` of its fields) are those of
    :func:`~diskpack_cl.drawing.writers.write_svg`, and ``pen_order`` (pen names,
    first drawn first); ``dots="tone"`` draws each pen's dots at the radius that
    holds its layer's ink; black paper where the pens were separated for it
    (:func:`on_black`).

    Returns
    -------
    dict
        As :func:`diskpack_cl.drawing.writers.write_svg`'s (all layers together), and
        ``layers`` (name, colour, n and plot seconds, in drawing order).

    Examples
    --------
    >>> import os, tempfile
    >>> from diskpack_cl import stipple_colors
    >>> img = np.dstack([np.tile(np.linspace(0, 1, 32), (24, 1)), np.full((24, 32), 0.3), np.full((24, 32), 0.8)])
    >>> res = stipple_colors(img, 80, "cmyk", backend="exact", schedule=[("mix", 3, 0.5)])
    >>> path = os.path.join(tempfile.mkdtemp(), "dots.svg")
    >>> _ = write_color_svg(path, res, width_mm=64)
    >>> with open(path, encoding="utf-8") as fh:
    ...     text = fh.read()
    >>> [name for name in res.names if f'inkscape:label="{name}"' in text] == list(res.names)
    True
    """
    from ..multipen import hex_color

    o = write_options(options, **overrides)
    pen_mm = o.pen_mm
    check_stippling(result, path, packing=False)
    black = on_black(result, o.invert)
    W, H = float(result.width), float(result.height)
    lay, pm, rad, drawn, moved = _drawn_dots(result, o)
    # the figures of the dots drawn (their radii on the SVG's grid), or of those capped
    ink = ink_figures(pm, rad if o.no_overlap else drawn,
                      np.asarray(result.radii) * lay["scale"], pen=pen_mm,
                      no_overlap=o.no_overlap)
    rad = drawn
    order = layer_order(result.names, result.colors, o.pen_order, black)
    meta = dict(svg_meta(result, lay, rad, pen_mm, black, result.names[order[0]]),
                pens=[result.names[p] for p in order])
    parts = [svg_head(lay, svg_size(lay, W, H, o.width_mm, o.height_mm, o.page), meta,
                      _paint(hex_color(result.colors[order[0]]), pen_mm), black)]
    layers, before, after, draw = [], 0.0, 0.0, 0.0
    for i, p in enumerate(order):
        idx = np.flatnonzero(result.pen == p)
        # the 2-opt work of one mono drawing of all the dots, shared by the pens
        path_order, b, a = pen_path_order(pm[idx], method=o.pen_path,
                                          rounds=two_opt_rounds(len(pm)))
        idx = idx[path_order]
        c = hex_color(result.colors[p])
        if i:
            parts.append(f'  </g>\n  <g inkscape:groupmode="layer" inkscape:label={xml_attr(result.names[p])} '
                         f'id="layer{i + 1}" {_paint(c, pen_mm)}>\n')
        text, length = svg_dots(pm[idx], rad[idx], pen_mm)
        parts.append(text)
        layers.append({"name": result.names[p], "color": c, "n": int(len(idx)),
                       "plot_seconds": plot_seconds(o, len(idx), length, a)})
        before, after, draw = before + b, after + a, draw + length
    with atomic_write(path, "w") as fh:
        fh.write("".join(parts) + "  </g>\n</svg>\n")
    info = {"width_mm": lay["picture"][0], "height_mm": lay["picture"][1],
            "page_mm": list(lay["page"]), "n": int(len(pm)), "layers": layers,
            "travel_before_mm": before, "travel_after_mm": after, "moved_inside": moved,
            "pen_downs": int(len(pm)), "draw_mm": draw, **ink,
            "plot_seconds": plot_seconds(o, len(pm), draw, after)}
    if pen_mm is not None:
        info["pen_touches"] = int(np.count_nonzero(2 * rad <= pen_mm))
    return info


def write_color_png(path, result, options=None, *, aa=4, progress=None, **overrides):
    """Write a colour PNG preview: every pen's dots, inks composited (8-bit sRGB).

    Options and the returned dict as :func:`diskpack_cl.drawing.writers.write_png`;
    black paper as :func:`on_black` says.

    Examples
    --------
    >>> import os, tempfile
    >>> from PIL import Image
    >>> from diskpack_cl import stipple_colors
    >>> img = np.dstack([np.tile(np.linspace(0, 1, 32), (24, 1)), np.full((24, 32), 0.3), np.full((24, 32), 0.8)])
    >>> res = stipple_colors(img, 80, "cmyk", backend="exact", schedule=[("mix", 3, 0.5)])
    >>> path = os.path.join(tempfile.mkdtemp(), "dots.png")
    >>> _ = write_color_png(path, res, png_scale=2.0)
    >>> with Image.open(path) as im:
    ...     im.mode, im.size
    ('RGB', (64, 48))
    """
    o = write_options(options, **overrides)
    check_stippling(result, path, packing=False)
    black = on_black(result, o.invert)
    scale, dot_px, pen_px = o.png_pixels(float(result.width), float(result.height))
    ow, oh = max(1, round(result.width * scale)), max(1, round(result.height * scale))
    p = np.asarray(result.points) * scale
    rad = (np.full(len(result.points), dot_px) if dot_px is not None
           else _radii(result, scale, o.dot_kind, o.radius_scale))
    if o.no_overlap:
        rad = cap_radii(rad, np.asarray(result.radii) * scale)
        check_apart(p, rad, np.asarray(result.radii) * scale, pen=pen_px, unit="px")
    if pen_px is not None:   # what the pen draws: at least a touch a pen wide
        rad = np.maximum(rad, 0.5 * pen_px)
    check_fit(rad, (ow, oh), pen_px, unit="px")
    paper = np.full((oh, ow, 3), 0.0 if black else 1.0)
    save_png(path, linear_to_srgb(_composite(result, p, rad, paper, aa, progress, black)))
    return {"width": ow, "height": oh, "n": int(len(p))}


def _composite(result, centres, rad, paper, aa, progress, black=False):
    """The paper (linear light) under every pen's dots (centres and radii in its pixels); on
    black paper the negative of the negative pens on the negative paper."""
    oh, ow = paper.shape[:2]
    lin = 1.0 - paper if black else paper
    absorb = 1.0 - srgb_to_linear(linear_negative(result.colors) if black else result.colors)
    for q in range(len(result.names)):
        mine = result.pen == q
        if np.any(mine):
            cover = ink_coverage(centres[mine], rad[mine], ow, oh, int(aa), progress)
            lin *= 1.0 - cover[..., None] * absorb[q]
    return 1.0 - lin if black else lin


def write_color_page_png(path, result, options=None, *, px_per_mm, aa=4, progress=None,
                         **overrides):
    """Write a colour PNG of the whole page as :func:`write_color_svg` lays it out (8-bit sRGB).

    What :func:`diskpack_cl.drawing.writers.write_page_png` writes for a colour
    stippling: the paper, a light line at the margins, each pen's dots where
    the SVG draws them, as far as their ink reaches, inks composited as in
    :func:`write_color_png`. The options (`options` and `overrides`) are those of
    :func:`write_color_svg`; black paper and a light line as :func:`on_black` says.

    Examples
    --------
    >>> import os, tempfile
    >>> from types import SimpleNamespace
    >>> res = SimpleNamespace(points=np.array([[2.0, 2.0], [6.0, 2.0]]), radii=np.array([1.0, 1.0]),
    ...                       width=8, height=4, pen=np.array([0, 1]), names=("red", "blue"),
    ...                       colors=np.array([[1, 0, 0], [0, 0, 1.0]]))
    >>> info = write_color_page_png(os.path.join(tempfile.mkdtemp(), "page.png"), res,
    ...                             px_per_mm=2.0, page="a5", dots="packing")
    >>> info["width"], info["height"], round(info["dpi"], 1)
    (296, 420, 50.8)
    """
    o = write_options(options, **overrides)
    check_stippling(result, path, packing=False)
    black = on_black(result, o.invert)
    lay, pm, _, rad, _ = _drawn_dots(result, o)
    line = page_frame(lay, px_per_mm)
    ink_rad = rad if o.pen_mm is None else np.maximum(rad, 0.5 * o.pen_mm)
    frame = np.repeat(FRAME_INK * line[..., None], 3, axis=2)
    lin = _composite(result, pm * px_per_mm, ink_rad * px_per_mm,
                     frame if black else 1.0 - frame, aa, progress, black)
    save_png(path, linear_to_srgb(lin), dpi=px_per_mm * MM_PER_INCH)
    return {"width": line.shape[1], "height": line.shape[0], "n": int(len(pm)),
            "dpi": px_per_mm * MM_PER_INCH}


COLOR_WRITERS = {".svg": write_color_svg, ".png": write_color_png}
