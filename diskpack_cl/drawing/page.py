"""The pieces of a drawing that the mono and the colour writers share.

The page (:func:`paper_size`, :func:`svg_layout`, :func:`mm_per_px`), the
plot-time model (:func:`plot_time`), the SVG's elements (:func:`svg_head`,
:func:`svg_dots`, :func:`svg_meta`, :func:`svg_size`, :func:`inside_page`)
with every name escaped (:func:`xml_attr`, :func:`xml_text`), and the ink of
the dots in a raster preview (:func:`ink_coverage`).
:mod:`diskpack_cl.drawing.writers` and :mod:`diskpack_cl.drawing.color_writers` both build on
this module, and neither imports the other's private names.
"""

from __future__ import annotations

import json
from xml.sax.saxutils import escape

import numpy as np

from diskpack_cl.options import NamedOptionError, OptionConflict

__all__ = [
    "DEFAULT_MARGIN_MM", "EDGE_MM", "FRAME_INK", "MM_PER_INCH", "PAPERS", "PEN_LIFT_S", "PLOT_SPEED_MM_S",
    "LONG_PLOT_S", "TOUCH_MM", "CROWDED_RATIO", "check_fit", "check_size", "crowded_dots",
    "long_plot", "ink_coverage", "inside_page", "mm_per_px", "paper_size",
    "on_grid", "page_frame", "pen_rings", "place_dots", "plot_time", "save_png", "svg_dots", "svg_head", "svg_layout", "svg_meta", "svg_size",
    "xml_attr", "xml_text",
]


def xml_attr(value):
    """`value` as a double-quoted XML attribute value, read back unchanged by any XML parser.

    ``<&>"`` and the white space that parsers would normalize (tab, line
    breaks) are escaped.

    Raises
    ------
    ValueError
        `value` holds a character XML 1.0 cannot carry (a control character).

    Examples
    --------
    >>> print(xml_attr('c<d> & "e"'))
    "c&lt;d&gt; &amp; &quot;e&quot;"
    """
    text = str(value)
    bad = [c for c in text if ord(c) < 32 and c not in "\t\n\r" or c in "\ufffe\uffff"]
    if bad:
        raise ValueError(f"name {text!r} holds a character an SVG cannot carry ({bad[0]!r})")
    return '"' + escape(text, {'"': "&quot;", "\t": "&#9;", "\n": "&#10;", "\r": "&#13;"}) + '"'


def xml_text(value):
    """`value` as XML character data (``<&>`` escaped).

    Examples
    --------
    >>> xml_text('{"layer": "a<b>&c"}')
    '{"layer": "a&lt;b&gt;&amp;c"}'
    """
    return escape(str(value))


MM_PER_INCH = 25.4


def check_size(width_mm=None, height_mm=None, dpi=None):
    """The one check of a physical size: by width/height or by dpi, not both.

    Raises :class:`~diskpack_cl.options.OptionConflict` (a ValueError that
    the command line spells with its flags).

    Examples
    --------
    >>> check_size(dpi=300, width_mm=100)
    Traceback (most recent call last):
    ...
    diskpack_cl.options.OptionConflict: give the SVG size either by width_mm/height_mm or by dpi, not both
    """
    if dpi is not None and (width_mm is not None or height_mm is not None):
        raise OptionConflict("give the SVG size either by {}/{} or by {}, not both",
                             "width_mm", "height_mm", "dpi")


def mm_per_px(width, height, width_mm=None, height_mm=None, dpi=None):
    """Millimetres per image pixel for a physical size, as :func:`diskpack_cl.drawing.writers.write_svg` uses it.

    ``width_mm`` and/or ``height_mm`` (both: fit inside the box, keeping the
    aspect ratio), else ``dpi`` (default 96).

    Examples
    --------
    >>> mm_per_px(512, 256, width_mm=200, height_mm=200)
    0.390625
    >>> mm_per_px(512, 512, dpi=25.4)
    1.0
    """
    check_size(width_mm, height_mm, dpi)
    if width_mm is not None or height_mm is not None:
        scales = []
        if width_mm is not None:
            if not width_mm > 0:
                raise ValueError(f"width_mm must be > 0, got {width_mm}")
            scales.append(width_mm / width)
        if height_mm is not None:
            if not height_mm > 0:
                raise ValueError(f"height_mm must be > 0, got {height_mm}")
            scales.append(height_mm / height)
        return min(scales)  # fit inside the box, keeping the aspect ratio
    dpi = 96.0 if dpi is None else float(dpi)
    if not dpi > 0:
        raise ValueError(f"dpi must be > 0, got {dpi}")
    return MM_PER_INCH / dpi


# float noise of a value read back and written again (mm): within it, a radius already on the
# 4-decimal grid stays there, so that an SVG read back writes again identically
_NOISE_MM = 1e-12


def on_grid(centres, rad):
    """Centres and radii (mm) as the SVG writes them: what is drawn, and read back.

    The centres rounded to the grid, each radius rounded inward by what its
    centre moved (:func:`svg_radii`); dots of one size keep one size, rounded
    inward (they read back at the metadata's ``dot_mm``, not at the radius
    written).

    Examples
    --------
    >>> c, r = on_grid(np.array([[1.00003, 2.0], [3.0, 2.0]]), np.array([0.5, 0.7]))
    >>> c.tolist(), r.tolist()
    ([[1.0, 2.0], [3.0, 2.0]], [0.4999, 0.7])
    """
    c = np.asarray(centres, np.float64)
    grid = _grid(c).reshape(c.shape)
    if len(rad) and np.all(rad == rad[0]):
        return grid, svg_radii(rad)
    return grid, svg_radii(rad, np.hypot(*(grid - c).T))


def svg_radii(rad, moved=0.0):
    """Radii (mm) as the SVG writes them: rounded inward on its 4-decimal grid.

    Each is less than `rad` by at least `moved` (how far rounding its centre
    to the grid moved it), so that dots apart stay apart and inside the
    picture once read back (:func:`diskpack_cl.read_stipple`): a packing
    drawn with its disks reads back certified. A value on the grid (an SVG
    read back) stays as it is.

    Raises
    ------
    ValueError
        A radius this leaves at or below 0: the dots are finer than the SVG draws.

    Examples
    --------
    >>> svg_radii(np.array([0.25, 1.23456])).tolist(), svg_radii(np.array([0.25]), 3e-5).tolist()
    ([0.25, 1.2345], [0.2499])
    """
    out = _inward(rad, moved)
    if not np.all(out > 0):
        raise ValueError(f"dots {2 * float(np.min(rad)):.3g} mm wide are finer than the SVG's "
                         f"0.0001 mm: give larger dots (--dot-mm, --radius-scale) or a larger "
                         f"picture (--width-mm, --height-mm, --dpi)")
    return out


def _inward(rad, moved=0.0):
    """`rad` - `moved` on the grid, rounded down (to the nearest, then one step in if that
    went out)."""
    want = np.asarray(rad, np.float64) - moved
    out = _grid(want)
    return np.where(out > want + _NOISE_MM, _grid(out - 1e-4), out)


def _grid(v):
    """`v` (mm) on the SVG's grid: the double nearest a whole number of 0.0001 mm, which
    ``%.4f`` writes as that number and a reader reads back as this double."""
    return np.round(np.asarray(v, np.float64) * 1e4) / 1e4


def _fmt(v):
    # numpy 1.x returns an empty input in its own dtype, which np.char.add refuses
    return np.char.mod("%.4f", v).astype(str)


#: Paper sizes (portrait, mm) of ``page=``; ``"WxH"`` or ``"WxHmm"`` gives any other.
PAPERS = {"a3": (297.0, 420.0), "a4": (210.0, 297.0), "a5": (148.0, 210.0),
          "letter": (215.9, 279.4)}


#: Margin (mm) around the picture on a page when none is given.
DEFAULT_MARGIN_MM = 10.0


def paper_size(page, *, landscape=False):
    """Width and height (mm) of a paper: a name of :data:`PAPERS` or ``"WxH[mm]"``.

    Examples
    --------
    >>> paper_size("a4"), paper_size("A4", landscape=True), paper_size("300x200mm")
    ((210.0, 297.0), (297.0, 210.0), (300.0, 200.0))
    """
    text = str(page).strip().lower()
    if text in PAPERS:
        w, h = PAPERS[text]
    else:
        try:
            w, h = (float(v) for v in text.removesuffix("mm").split("x"))
        except ValueError:
            raise ValueError(f"page must be {', '.join(PAPERS)} or WxHmm (e.g. 300x200mm), "
                             f"got {page!r}") from None
        if not (0 < w < float("inf") and 0 < h < float("inf")):
            raise ValueError(f"page sides must be > 0 mm, got {page!r}")
    return (max(w, h), min(w, h)) if landscape else (w, h)


def svg_layout(width, height, *, width_mm=None, height_mm=None, dpi=None, page=None,
               landscape=False, margin_mm=None, plotter=None):
    """Where :func:`diskpack_cl.drawing.writers.write_svg` puts a ``width x height`` px picture, all in mm.

    Without ``page`` the page is the picture, sized by :func:`mm_per_px`.
    With ``page`` (see :func:`paper_size`) the picture is centred on it,
    sized by ``width_mm``/``height_mm``/``dpi`` when given, else fitted
    inside the margins (``margin_mm``, default :data:`DEFAULT_MARGIN_MM`).
    With ``plotter`` (a device of vpype's profiles) the margins are those
    of the part of the page it plots too
    (:func:`diskpack_cl.drawing.plotters.plotting_area`), and the picture is centred
    there.

    Returns
    -------
    dict
        ``scale`` (mm per px), ``picture`` and ``page`` ((w, h) mm),
        ``offset`` ((x, y) mm of the picture's corner on the page),
        ``area`` ((x0, y0, x1, y1) mm: the usable part of the page, inside
        the margins and the plotter's reach).

    Examples
    --------
    >>> lay = svg_layout(400, 300, page="a4", landscape=True, margin_mm=20)
    >>> [round(v, 2) for v in (*lay["picture"], *lay["offset"])]
    [226.67, 170.0, 35.17, 20.0]
    """
    if page is None:
        if margin_mm is not None or plotter is not None:
            raise ValueError("a margin or a plotter needs a page: give page (e.g. 'a4') too")
        s = mm_per_px(width, height, width_mm, height_mm, dpi)
        return {"scale": s, "picture": (width * s, height * s),
                "page": (width * s, height * s), "offset": (0.0, 0.0),
                "area": (0.0, 0.0, width * s, height * s)}
    pw, ph = paper_size(page, landscape=landscape)
    margin = DEFAULT_MARGIN_MM if margin_mm is None else float(margin_mm)
    if not 0 <= margin < 0.5 * min(pw, ph):
        given = "the default" if margin_mm is None else "given"
        raise NamedOptionError(f"{{}} must be in [0, {0.5 * min(pw, ph):g}) on a {pw:g}x{ph:g} "
                               f"mm page, got {margin:g} ({given})", "margin_mm")
    x0, y0, x1, y1 = margin, margin, pw - margin, ph - margin
    reach = ""
    if plotter is not None:
        from diskpack_cl.drawing.plotters import area_text, plotting_area

        ax0, ay0, ax1, ay1 = plotting_area(plotter, (pw, ph))
        reach = f" and the plotting area of {plotter} ({area_text((ax0, ay0, ax1, ay1))})"
        x0, y0, x1, y1 = max(x0, ax0), max(y0, ay0), min(x1, ax1), min(y1, ay1)
        if x0 >= x1 or y0 >= y1:
            raise ValueError(f"the {margin:g} mm margins{reach} leave no room on the "
                             f"{pw:g}x{ph:g} mm page")
    if width_mm is None and height_mm is None and dpi is None:
        s = mm_per_px(width, height, x1 - x0, y1 - y0)
    else:
        s = mm_per_px(width, height, width_mm, height_mm, dpi)
    w, h = width * s, height * s
    if w > x1 - x0 + 1e-9 or h > y1 - y0 + 1e-9:
        raise ValueError(f"the picture ({w:.1f}x{h:.1f} mm) does not fit inside the "
                         f"{margin:g} mm margins of the {pw:g}x{ph:g} mm page{reach}")
    return {"scale": s, "picture": (w, h), "page": (pw, ph),
            "offset": (0.5 * (x0 + x1 - w), 0.5 * (y0 + y1 - h)), "area": (x0, y0, x1, y1)}


#: Plot-time model of :func:`plot_time`: pen-down and pen-up speed (mm/s)
#: and seconds to lower and raise the pen once per dot (AxiDraw-like).
PLOT_SPEED_MM_S = 50.0


PEN_LIFT_S = 0.3


def plot_time(pen_downs, draw_mm, travel_mm, *, speed_mm_s=PLOT_SPEED_MM_S,
              pen_lift_s=PEN_LIFT_S):
    """Estimated plot time in seconds: all lines at ``speed_mm_s``, plus a pen lift per dot.

    Examples
    --------
    >>> plot_time(100, 400.0, 600.0)
    50.0
    """
    if not speed_mm_s > 0:
        raise ValueError(f"plot speed must be > 0 mm/s, got {speed_mm_s}")
    return (draw_mm + travel_mm) / speed_mm_s + pen_downs * pen_lift_s


def pen_rings(rad, pen, moved=0.0):
    """Ring radii (mm) that fill dots of radius ``rad`` with a pen ``pen`` wide.

    A ring of radius rho inks [rho - pen/2, rho + pen/2]: the outermost is
    at ``rad - pen/2``, each next one a pen width further in, the innermost
    at least ``pen/2`` (it inks the centre; an outermost ring below ``pen/2``
    inks it already, and stays where it is: raised, it would ink past
    ``rad``). The outermost is rounded inward as the SVG writes it
    (:func:`svg_radii`, `moved` as there). Returns an (n, m) array, nan where a dot has fewer
    rings; a dot not wider than the pen has none (it is one pen touch).

    Examples
    --------
    >>> pen_rings(np.array([0.2, 0.4, 1.0]), 0.5).tolist()   # a touch, one ring, two rings
    [[nan, nan], [0.15, nan], [0.75, 0.25]]
    """
    m = np.where(2 * rad <= pen, 0, np.ceil(rad / pen - 1e-9)).astype(np.int64)
    j = np.arange(max(int(m.max(initial=0)), 1))
    outer = _inward(rad - 0.5 * pen, moved)  # as written: the rings follow from it when read back
    # the inner rings at least pen/2; the outermost at least what 4 decimals write
    least = np.where(j == 0, 1e-4, 0.5 * pen)
    rho = np.maximum(outer[:, None] - j[None, :] * pen, least[None, :])
    return np.where(j[None, :] < m[:, None], rho, np.nan)


def svg_dots(c, rad, pen):
    """SVG lines of the dots, one element each, and their pen-down length (mm).

    Without a pen: filled ``<circle>``s. With a pen ``pen`` mm wide (see
    :func:`diskpack_cl.drawing.writers.write_svg`): a ``<circle>`` outline for a one-ring dot, one
    ``<path>`` of concentric rings joined by short radial lines for a wider
    dot, a 0.01 mm ``<path>`` (a pen touch) for a dot not wider than the pen.

    Examples
    --------
    >>> text, length = svg_dots(np.array([[1.0, 2.0]]), np.array([0.5]), None)
    >>> text.strip(), round(length, 4)
    ('<circle cx="1.0000" cy="2.0000" r="0.5000"/>', 3.1416)
    """
    x, y = c[:, 0], c[:, 1]
    if pen is None:
        rad = svg_radii(rad)
        circles = _join('    <circle cx="', _fmt(x), '" cy="', _fmt(y), '" r="', _fmt(rad), '"/>\n')
        return "".join(circles.tolist()), float(2 * np.pi * rad.sum())
    rho = pen_rings(rad, pen)
    m = np.count_nonzero(~np.isnan(rho), axis=1)
    lines = np.empty(len(c), dtype=object)
    touch = m == 0
    lines[touch] = _join('    <path d="M ', _fmt(x[touch] - 0.5 * TOUCH_MM), ',', _fmt(y[touch]),
                         f' h {TOUCH_MM}"/>\n')
    one = m == 1
    lines[one] = _join('    <circle cx="', _fmt(x[one]), '" cy="', _fmt(y[one]), '" r="',
                       _fmt(rho[one, 0]), '"/>\n')
    for k in np.unique(m[m > 1]):  # M to the outer ring, then relative arcs and steps in
        sel = np.flatnonzero(m == k)
        d = _join('    <path d="M ', _fmt(x[sel] + rho[sel, 0]), ",", _fmt(y[sel]))
        for j in range(k):
            r = _fmt(rho[sel, j])
            if j:
                d = _join(d, " l ", _fmt(rho[sel, j] - rho[sel, j - 1]), ",0")
            d = _join(d, " a ", r, ",", r, " 0 1 0 ", _fmt(-2 * rho[sel, j]), ",0 a ", r, ",",
                      r, " 0 1 0 ", _fmt(2 * rho[sel, j]), ",0")
        lines[sel] = _join(d, '"/>\n')
    rings = np.nan_to_num(rho)
    draw = (2 * np.pi * rings.sum() + np.sum(rings[:, :-1] - rings[:, 1:], where=rings[:, 1:] > 0)
            + TOUCH_MM * np.count_nonzero(touch))
    return "".join(lines.tolist()), float(draw)


def _join(*parts):
    out = parts[0]
    for part in parts[1:]:
        out = np.char.add(np.asarray(out, dtype=str), part)
    return out


# the paper, for --invert: a black 1x1 PNG stretched over the page. vpype and
# plotters ignore raster images, so the plot and its path count hold the dots only
_BLACK_PNG = ("data:image/png;base64,iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAAAAAA6fptVAAAACklE"
              "QVR4nGNgAAAAAgABSK+kcQAAAABJRU5ErkJggg==")


def svg_head(lay, size, meta, paint, invert):
    """Everything of the SVG before the dots: page, metadata, background, the dots' layer.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> lay = svg_layout(4, 2, width_mm=40)
    >>> meta = svg_meta(SimpleNamespace(width=4, height=2), lay, np.array([1.0]), None, False, "a<b>")
    >>> svg_head(lay, svg_size(lay, 4, 2, 40, None, None), meta, 'fill="black"', False).splitlines()[-1]
    '  <g inkscape:groupmode="layer" inkscape:label="a&lt;b&gt;" id="layer1" fill="black">'
    """
    pw, ph = lay["page"]
    head = [
        '<?xml version="1.0" encoding="UTF-8" standalone="no"?>',
        '<svg xmlns="http://www.w3.org/2000/svg"',
        '     xmlns:xlink="http://www.w3.org/1999/xlink"',
        '     xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"',
        '     xmlns:sodipodi="http://sodipodi.sourceforge.net/DTD/sodipodi-0.dtd"',
        f'     {size} viewBox="0 0 {pw:.10g} {ph:.10g}"',
        '     version="1.1">',
        '  <sodipodi:namedview inkscape:document-units="mm"/>',
        f'  <metadata id="diskpack_cl">{xml_text(json.dumps(meta))}</metadata>',
    ]
    if invert:  # the black paper, in a layer that plotters skip (AxiDraw: a name with %)
        head += ['  <g inkscape:groupmode="layer" inkscape:label="% paper (not plotted)" '
                 'id="paper" sodipodi:insensitive="true">',
                 f'    <image x="0" y="0" width="{pw:.10g}" height="{ph:.10g}" '
                 f'preserveAspectRatio="none" xlink:href="{_BLACK_PNG}"/>', '  </g>']
    head.append(f'  <g inkscape:groupmode="layer" inkscape:label={xml_attr(meta["layer"])} '
                f'id="layer1" {paint}>')
    return "\n".join(head) + "\n"


def svg_size(lay, W, H, width_mm, height_mm, page):
    """The ``width``/``height`` attributes: CSS pixels (exact) for a dpi size, else mm.

    Examples
    --------
    >>> svg_size(svg_layout(4, 2, width_mm=40), 4, 2, 40, None, None)
    'width="40mm" height="20mm"'
    """
    if page is None and width_mm is None and height_mm is None:
        s = lay["scale"] / MM_PER_INCH * 96
        return f'width="{W * s:.10g}px" height="{H * s:.10g}px"'
    return f'width="{lay["page"][0]:.10g}mm" height="{lay["page"][1]:.10g}mm"'


def svg_meta(result, lay, rad, pen_mm, invert, layer):
    """What :func:`diskpack_cl.read_stipple` needs to read the dots back (JSON in ``<metadata>``).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> lay = svg_layout(4, 2, width_mm=40)
    >>> svg_meta(SimpleNamespace(width=4, height=2), lay, np.array([1.0]), None, False, "dots")["dot_mm"]
    2.0
    """
    same = len(rad) > 0 and bool(np.all(rad == rad[0]))
    tone = getattr(result, "tone_radius", None)
    k = float(getattr(result, "k", np.nan))
    return {"width": int(result.width), "height": int(result.height), "mm_per_px": lay["scale"],
            "offset_mm": list(lay["offset"]), "pen_mm": pen_mm,
            "dot_mm": 2 * float(rad[0]) if same else None,
            "tone_radius": None if tone is None else float(tone),
            "k": None if np.isnan(k) else k, "invert": bool(invert), "layer": layer}


# coordinates are written with 4 decimals: keep dots this far inside the page
EDGE_MM = 2e-4


# a pen touch: a path this long (mm), centred on the dot
TOUCH_MM = 0.01


def inside_page(c, rad, wmm, hmm, pen=None):
    """Move dots whose ink sticks out of the page inward; return (centres, radii, moved).

    A dot's ink reaches its radius, or with a `pen` wider than the dot
    (one pen touch) half the pen: such a dot keeps half the pen from the
    edge, and the touch's length besides, so that no ink crosses it. Every
    dot keeps :data:`EDGE_MM` from the edge (vpype crops what touches it); a
    dot out by no more than that shrinks to it in place (a certified packing
    reads back certified), one out by more moves.

    Examples
    --------
    >>> centres, radii, moved = inside_page(np.array([[0.0, 1.0]]), np.array([0.5]), 4.0, 2.0)
    >>> centres.tolist(), moved
    ([[0.5002, 1.0]], 1)
    >>> inside_page(np.array([[0.5, 1.0]]), np.array([0.5]), 4.0, 2.0)[1].tolist()
    [0.4998]
    >>> inside_page(np.array([[0.2, 1.0]]), np.array([0.1]), 4.0, 2.0, pen=1.0)[0].tolist()
    [[0.5052, 1.0]]
    """
    most = 0.5 * min(wmm, hmm) - 2 * EDGE_MM - TOUCH_MM
    if not most > 0:
        raise ValueError(f"the picture ({wmm:.3g} x {hmm:.3g} mm) is too small to draw: its "
                         f"sides must be more than {2 * (2 * EDGE_MM + TOUCH_MM):g} mm "
                         f"(--width-mm, --height-mm, --dpi)")
    rad = np.minimum(rad, most)
    touch = np.zeros(len(rad), bool) if pen is None else 2 * rad <= pen
    # a dot drawn by its outline that is out by no more than the margin shrinks to it instead
    # of moving: a packing's disks (inside the picture) stay where they are, and apart
    room = np.minimum.reduce([c[:, 0], wmm - c[:, 0], c[:, 1], hmm - c[:, 1]]) - EDGE_MM
    shrink = ~touch & (rad > room) & (rad <= room + EDGE_MM) & (room > 0)
    rad = np.where(shrink, room, rad)
    ink = rad if pen is None else np.minimum(np.maximum(rad, 0.5 * pen), most)
    ext = ink + EDGE_MM + np.where(touch, 0.5 * TOUCH_MM, 0.0)
    inside = np.column_stack([np.clip(c[:, 0], ext, wmm - ext), np.clip(c[:, 1], ext, hmm - ext)])
    inside[shrink] = c[shrink]
    moved = int(np.count_nonzero(np.any(inside != c, axis=1)))
    return inside, rad, moved


def place_dots(points, rad, packing, lay, *, no_overlap=False, pen=None):
    """Where the SVG draws the dots: centres on the page and drawn radii (mm).

    ``points`` are in image pixels, ``rad`` and ``packing`` (the drawn and
    the packing radii) in mm, ``lay`` is :func:`svg_layout`'s; with
    ``no_overlap`` each drawn radius is at most its packing radius
    (:func:`diskpack_cl.drawing.overlap.cap_radii`), and dots that would still touch
    (a pen wider than the disks) are refused
    (:func:`diskpack_cl.drawing.overlap.check_apart`). Dots whose ink (with a `pen`
    wider than the dot, half the pen's width around its centre) would stick
    out of the picture move inward (:func:`inside_page`): the ink stays in
    the picture, and so inside the margins and the plotter's area.

    Returns
    -------
    centres : (n, 2) array
        On the page, mm, as the SVG writes them (:func:`on_grid`).
    radii : (n,) array
        As the SVG writes them.
    moved : int
        How many dots moved inward.

    Examples
    --------
    >>> lay = svg_layout(4, 2, width_mm=40, page="a5", margin_mm=10)
    >>> centres, radii, moved = place_dots(np.array([[2.0, 1.0]]), np.array([1.0]), np.array([2.0]), lay)
    >>> centres.tolist(), moved
    ([[74.0, 105.0]], 0)
    """
    from .overlap import cap_radii, check_apart  # its KD-tree is not loaded at start-up

    pm, drawn, moved = inside_page(points * lay["scale"],
                                   cap_radii(rad, packing) if no_overlap else rad,
                                   *lay["picture"], pen)
    pm, drawn = on_grid(pm + lay["offset"], drawn)
    if no_overlap:
        check_apart(pm, drawn, packing, pen=pen)
    return pm, drawn, moved


#: How dark (as ink coverage) the margin line of :func:`page_frame` is.
FRAME_INK = 0.2


def page_frame(lay, px_per_mm):
    """The whole-page preview's pixels: the page, and a line around its usable area.

    The line runs on the pixels just outside ``lay["area"]`` (the margins'
    inner edge), so that it never covers a place a dot may ink; a side
    without a margin has none.

    Returns
    -------
    (oh, ow) bool array
        True on the line; its shape is the page at ``px_per_mm``.

    Examples
    --------
    >>> lay = svg_layout(4, 4, page="10x8mm", margin_mm=2)
    >>> page_frame(lay, 1.0).astype(int)[:3].tolist()
    [[0, 0, 0, 0, 0, 0, 0, 0, 0, 0], [0, 1, 1, 1, 1, 1, 1, 1, 1, 0], [0, 1, 0, 0, 0, 0, 0, 0, 1, 0]]
    >>> bool(page_frame(svg_layout(4, 4, dpi=25.4), 1.0).any())   # the page is the picture
    False
    """
    ow, oh = (max(1, round(v * px_per_mm)) for v in lay["page"])
    x0, y0, x1, y1 = lay["area"]
    # on a page padded by 2 pixels, where the line of a side without a margin falls
    i0, j0 = (int(np.floor(v * px_per_mm)) + 1 for v in (x0, y0))
    i1, j1 = (int(np.ceil(v * px_per_mm)) + 2 for v in (x1, y1))
    line = np.zeros((oh + 4, ow + 4), dtype=bool)
    line[j0 : j1 + 1, [i0, i1]] = True
    line[[j0, j1], i0 : i1 + 1] = True
    return line[2:-2, 2:-2]


def save_png(path, values, dpi=None):
    """Write values in [0, 1] as an 8-bit PNG (gray for (h, w), sRGB for (h, w, 3)), atomically.

    ``dpi`` is recorded in the file (its printed size).

    Examples
    --------
    >>> import os, tempfile
    >>> from PIL import Image
    >>> path = os.path.join(tempfile.mkdtemp(), "a.png")
    >>> save_png(path, np.ones((2, 3)), dpi=150)
    >>> with Image.open(path) as im:
    ...     im.mode, im.size, round(im.info["dpi"][0])
    ('L', (3, 2), 150)
    """
    from PIL import Image

    from ..io import atomic_write

    img = Image.fromarray(np.round(np.asarray(values) * 255).astype(np.uint8))
    with atomic_write(path, "wb") as fh:
        img.save(fh, format="PNG", **({} if dpi is None else {"dpi": (dpi, dpi)}))


def ink_coverage(c, rad, ow, oh, aa, progress=None):
    """Ink coverage in [0, 1] per output pixel: fraction of aa x aa samples in a disk.

    Dots are stamped in windows of their own size (grouped by size, in
    chunks), and the coverages are summed with ``np.add.at``: exact sample
    counts for disjoint disks; overlapping dots (fixed or enlarged dot sizes)
    are summed and clipped at 1. ``progress(k)`` is called after each chunk
    of ``k`` dots.

    Examples
    --------
    >>> ink_coverage(np.array([[2.0, 2.0]]), np.array([1.0]), 4, 4, 4)[1].round(2).tolist()
    [0.0, 0.81, 0.81, 0.0]
    """
    ink = np.zeros(ow * oh)
    sub = (np.arange(aa) + 0.5) / aa
    m_all = 2 * np.ceil(rad).astype(np.int64) + 2
    for m in np.unique(m_all):
        sel = np.flatnonzero(m_all == m)
        step = max(1, int(2e7 // (m * m * aa * aa)))
        off = np.arange(m)
        for s0 in range(0, sel.size, step):
            i = sel[s0 : s0 + step]
            cx, cy, R = c[i, 0], c[i, 1], rad[i]
            bx = np.floor(cx - R).astype(np.int64)
            by = np.floor(cy - R).astype(np.int64)
            px = bx[:, None] + off[None, :]  # (k, m) pixel columns
            py = by[:, None] + off[None, :]
            # sample rows: y = py + (a + 0.5)/aa; each cuts the disk in [xl, xr]
            sy = (py[:, :, None] + sub).reshape(len(i), m * aa)  # (k, m*aa)
            h2 = (R * R)[:, None] - (sy - cy[:, None]) ** 2
            h = np.sqrt(np.maximum(h2, 0.0))
            # sample columns t (x = (t + 0.5)/aa) inside: t in [lo, hi]
            lo = np.ceil((cx[:, None] - h) * aa - 0.5)
            hi = np.floor((cx[:, None] + h) * aa - 0.5)
            hi = np.where(h2 >= 0, hi, lo - 1)
            # samples a pixel per sample row, as int32: exact counts, in half float64's
            # memory (this tensor of every dot's window is most of the work)
            t0 = (px * aa).astype(np.int32)[:, None, :]  # (k, 1, m) first column
            cnt = np.minimum(hi.astype(np.int32)[:, :, None], t0 + (aa - 1))
            cnt -= np.maximum(lo.astype(np.int32)[:, :, None], t0)
            cnt += 1
            np.maximum(cnt, 0, out=cnt)
            cnt = cnt.reshape(len(i), m, aa, m).sum(axis=2, dtype=np.int32)  # (k, m_y, m_x)
            inside = ((px >= 0) & (px < ow))[:, None, :] & ((py >= 0) & (py < oh))[:, :, None]
            ok = np.flatnonzero(((cnt > 0) & inside).ravel())
            at = (py[:, :, None] * ow + px[:, None, :]).ravel()[ok]
            np.add.at(ink, at, cnt.ravel()[ok] / float(aa * aa))
            if progress is not None:
                progress(len(i))
    return np.minimum(ink, 1.0).reshape(oh, ow)


def check_fit(rad, picture, pen=None, *, unit="mm"):
    """Refuse drawn dots, or a pen, that do not fit the picture: before any ink is laid.

    A dot wider than the picture's smaller side, or a pen at least that
    wide, would put its ink off the picture (and off the page); the message
    gives the figures and the options that set them.

    Parameters
    ----------
    rad : array_like
        Drawn dot radii, in `unit`.
    picture : (float, float)
        The picture's width and height, in `unit`.
    pen : float, optional
        The pen's width, in `unit`.

    Raises
    ------
    ValueError
        A dot or the pen does not fit.

    Examples
    --------
    >>> check_fit(np.array([1.0, 2.0]), (40.0, 30.0), 0.5)
    >>> check_fit(np.array([20.0]), (40.0, 30.0))
    Traceback (most recent call last):
    ...
    ValueError: dots 40 mm wide do not fit the 40 x 30 mm picture: give smaller dots (--dot-mm, --radius-scale) or a larger picture
    """
    w, h = picture
    side = min(w, h)
    if pen is not None and pen >= side:
        raise ValueError(f"the pen ({pen:.4g} {unit}) is as wide as the {w:.4g} x {h:.4g} {unit} "
                         f"picture: its ink would leave the picture (--pen-mm)")
    widest = 2 * float(np.max(rad, initial=0.0))
    if widest > side:
        raise ValueError(f"dots {widest:.4g} {unit} wide do not fit the {w:.4g} x {h:.4g} {unit} "
                         f"picture: give smaller dots (--dot-mm, --radius-scale) or a larger "
                         f"picture")


#: A plan whose pen lifts alone take longer than this (seconds) is warned of before the work.
LONG_PLOT_S = 10 * 3600.0


def long_plot(n, *, pen_lift_s=PEN_LIFT_S, limit_s=LONG_PLOT_S):
    """The warning for `n` dots whose pen lifts alone take longer than `limit_s`, else None.

    Examples
    --------
    >>> long_plot(1000) is None
    True
    >>> long_plot(1_000_000)
    '1000000 dots take at least 83 h to plot (0.3 s to lower and raise the pen per dot)'
    """
    least = n * pen_lift_s
    if least <= limit_s:
        return None
    return (f"{n} dots take at least {least / 3600:.0f} h to plot ({pen_lift_s:g} s to lower "
            f"and raise the pen per dot)")



#: Drawn dots whose ink is more than this many times as wide as the median
#: spacing of their centres are warned of: each covers its neighbours' centres.
CROWDED_RATIO = 2.0


def crowded_dots(ink_mm, spacing_mm, *, ratio=CROWDED_RATIO):
    """The warning for dots whose ink, `ink_mm` wide (median), is more than `ratio`
    times the median spacing `spacing_mm` of their centres, else None.

    The packing keeps the dots' disks apart, but a fixed dot size, a radius
    scale or a pen can draw them far wider; up to `ratio` (2) neighbouring
    dots' ink may overlap without covering each other's centres, as the
    tone dots do where the image is dark.

    Examples
    --------
    >>> crowded_dots(1.5, 1.2) is None
    True
    >>> crowded_dots(50.0, 1.2)
    'dots of 50 mm overlap their neighbours: median spacing of their centres on paper 1.2 mm (warned above 2 x); see --no-overlap'
    """
    if ink_mm is None or spacing_mm is None or not ink_mm > ratio * spacing_mm:
        return None
    return (f"dots of {ink_mm:.3g} mm overlap their neighbours: median spacing of their "
            f"centres on paper {spacing_mm:.3g} mm (warned above {ratio:g} x); see --no-overlap")
