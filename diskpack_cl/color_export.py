"""Writers for colour stipplings (:class:`diskpack_cl.multipen.ColorStippleResult`).

:func:`diskpack_cl.export.write_stipple` sends a result with a ``pen``
attribute here for ``.svg`` and ``.png``; ``.npz`` and ``.csv`` are the mono
writers with the pens added (a ``pen`` column, pen names and colours).

* SVG: one Inkscape layer per pen (``<g inkscape:groupmode="layer"
  inkscape:label="NAME">``, which vpype reads as one layer each), the pen's
  colour as stroke (and fill), lightest pen first (or ``pen_order``), each
  layer's dots along a short pen path.
* PNG: the inks composited (:func:`diskpack_cl.color.render_pens`'s model:
  coverages multiply in linear light), 8-bit sRGB.
"""

from __future__ import annotations

import numpy as np

from .color import linear_to_srgb, srgb_to_linear
from .export import MM_PER_INCH, _coverage, _inside_page, _svg_dots, mm_per_px, pen_path_order
from .io import atomic_write

__all__ = ["layer_order", "write_color_svg", "write_color_png"]


def layer_order(names, colors, pen_order=None):
    """Pen indices in drawing order: `pen_order` (names), else lightest first (luminance).

    Examples
    --------
    >>> layer_order(("black", "yellow"), np.array([[0, 0, 0], [1, 1, 0.0]]))
    [1, 0]
    >>> layer_order(("black", "yellow"), np.zeros((2, 3)), ["black", "yellow"])
    [0, 1]
    """
    if pen_order is None:
        lum = srgb_to_linear(np.asarray(colors)) @ np.array([0.2126, 0.7152, 0.0722])
        return [int(i) for i in np.argsort(-lum, kind="stable")]
    order = list(pen_order)
    if sorted(order) != sorted(names):
        raise ValueError(f"pen order must name every pen once ({', '.join(names)}), got "
                         f"{', '.join(order)}")
    return [names.index(name) for name in order]


def _radii(result, scale, dots, dot_mm, radius_scale):
    """Drawn radius per dot in output units: each pen's tone radius, the packing disks, or dot_mm."""
    if dot_mm is not None:
        return np.full(len(result.points), 0.5 * float(dot_mm))
    if dots == "packing":
        return np.asarray(result.radii) * scale * radius_scale
    return np.asarray(result.pen_radius)[result.pen] * scale * radius_scale


def write_color_svg(path, result, *, width_mm=None, height_mm=None, dpi=None, dot_mm=None,
                    radius_scale=1.0, pen_path="auto", pen_mm=None, dots="tone", pen_order=None,
                    invert=False):
    """Write an SVG with one named layer per pen (see the module docstring).

    The options are those of :func:`diskpack_cl.export.write_svg`, plus
    `pen_order` (pen names, first drawn first); ``dots="tone"`` draws each
    pen's dots at the radius that holds its layer's ink. `invert` is refused.

    Returns
    -------
    dict
        ``width_mm``, ``height_mm``, ``n``, ``layers`` (name, colour, n, in
        drawing order), ``travel_after_mm`` (pen-up travel of all layers),
        ``moved_inside``.
    """
    from .multipen import hex_color

    if invert:
        raise ValueError("invert has no meaning for colour stippling")
    W, H = float(result.width), float(result.height)
    s = mm_per_px(W, H, width_mm, height_mm, dpi)
    pm, rad, moved = _inside_page(np.asarray(result.points) * s,
                                  _radii(result, s, dots, dot_mm, radius_scale), W * s, H * s)
    size = (f'width="{W * s / MM_PER_INCH * 96:.10g}px" height="{H * s / MM_PER_INCH * 96:.10g}px"'
            if width_mm is None and height_mm is None else
            f'width="{W * s:.10g}mm" height="{H * s:.10g}mm"')
    parts = ['<?xml version="1.0" encoding="UTF-8" standalone="no"?>\n'
             '<svg xmlns="http://www.w3.org/2000/svg"\n'
             '     xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"\n'
             f'     {size} viewBox="0 0 {W * s:.10g} {H * s:.10g}" version="1.1">\n']
    layers, travel = [], 0.0
    for i, p in enumerate(layer_order(result.names, result.colors, pen_order)):
        mine = np.flatnonzero(result.pen == p)
        order, _, after = pen_path_order(pm[mine], method=pen_path)
        idx = mine[order]
        c = hex_color(result.colors[p])
        paint = (f'fill="{c}" stroke="{c}" stroke-width="0"' if pen_mm is None else
                 f'fill="none" stroke="{c}" stroke-width="{pen_mm:.4f}" stroke-linecap="round"')
        touch = np.zeros(len(idx), bool) if pen_mm is None else 2.0 * rad[idx] <= pen_mm
        drawn = rad[idx] if pen_mm is None else rad[idx] - 0.5 * pen_mm
        parts.append(f'  <g inkscape:groupmode="layer" inkscape:label="{result.names[p]}" '
                     f'id="layer{i + 1}" {paint}>\n' + _svg_dots(pm[idx], drawn, touch) + "  </g>\n")
        layers.append({"name": result.names[p], "color": c, "n": int(len(idx))})
        travel += after
    with atomic_write(path, "w") as fh:
        fh.write("".join(parts) + "</svg>\n")
    return {"width_mm": W * s, "height_mm": H * s, "n": int(len(pm)), "layers": layers,
            "travel_after_mm": travel, "moved_inside": moved}


def write_color_png(path, result, *, scale=1.0, radius_scale=1.0, dot_px=None, aa=4, dots="tone",
                    invert=False):
    """Write a colour PNG preview: every pen's dots, inks composited (8-bit sRGB).

    Options as :func:`diskpack_cl.export.write_png`; `invert` is refused.

    Returns
    -------
    dict
        ``width``, ``height`` (output pixels), ``n``.
    """
    from PIL import Image

    if invert:
        raise ValueError("invert has no meaning for colour stippling")
    ow, oh = max(1, round(result.width * scale)), max(1, round(result.height * scale))
    rad = (np.full(len(result.points), float(dot_px)) if dot_px is not None
           else _radii(result, scale, dots, None, radius_scale))
    lin = np.ones((oh, ow, 3))
    absorb = 1.0 - srgb_to_linear(result.colors)
    p = np.asarray(result.points) * scale
    for q in range(len(result.names)):
        mine = result.pen == q
        if np.any(mine):
            lin *= 1.0 - _coverage(p[mine], rad[mine], ow, oh, int(aa))[..., None] * absorb[q]
    img = Image.fromarray(np.round(linear_to_srgb(lin) * 255).astype(np.uint8), "RGB")
    with atomic_write(path, "wb") as fh:
        img.save(fh, format="PNG")
    return {"width": ow, "height": oh, "n": int(len(p))}


COLOR_WRITERS = {".svg": write_color_svg, ".png": write_color_png}
