"""Writers for stipplings: SVG (pen plotters, Inkscape), PNG preview, NPZ, CSV.

Every writer goes through :func:`diskpack_cl.io.atomic_write`: a failed
write leaves no partial file and an existing file untouched.

A "result" is a :class:`diskpack_cl.stipple.StippleResult` or any object with
``points`` ((n, 2), pixel units, x right, y down), ``radii`` ((n,)), ``width``
and ``height`` (pixels), and optionally ``k`` and ``certificate``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from dataclasses import dataclass, replace

import numpy as np

from diskpack_cl.io import atomic_write, check_writable
from diskpack_cl.options import OptionConflict, check_fields, option
from diskpack_cl.overlap import cap_radii, ink_figures
from diskpack_cl.pen_path import PEN_PATHS, path_travel, pen_path_order
from diskpack_cl.readers import CSV_TAG, csv_name, read_stipple

__all__ = [
    "WRITERS",
    "WriteOptions",
    "check_output_path",
    "check_size",
    "mm_per_px",
    "tone_dot_size",
    "pen_path_order",
    "path_travel",
    "read_stipple",
    "write_stipple",
    "write_svg",
    "write_png",
    "write_npz",
    "write_csv",
]

MM_PER_INCH = 25.4
_OUTPUT = "output"


# --------------------------------------------------------------------------
# Writers
# --------------------------------------------------------------------------


def _arrays(result):
    p = np.asarray(result.points, dtype=np.float64)
    r = np.asarray(result.radii, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or r.shape != (len(p),):
        raise ValueError(f"result must have points (n, 2) and radii (n,), got {p.shape}, {r.shape}")
    return p, r, float(result.width), float(result.height)


DOTS = ("tone", "packing")


def _dot_radii(result, radii, scale, dots, radius_scale):
    """Drawn radius per dot, in output units (``scale`` of them per pixel).

    ``"tone"``: one size for all dots, ``result.tone_radius`` (the radius at
    which the dots' ink equals the image's darkness, see
    :func:`diskpack_cl.picture_measures.tone_radius`); ``"packing"``: each dot its
    certified packing radius. Both times ``radius_scale``.
    """
    if dots not in DOTS:
        raise ValueError(f"dots must be 'tone' or 'packing', got {dots!r}")
    if not radius_scale > 0:
        raise ValueError(f"radius_scale must be > 0, got {radius_scale}")
    if dots == "packing":
        return radii * scale * float(radius_scale)
    return np.full(len(radii), 0.5 * tone_dot_size(result, scale, radius_scale))


def tone_dot_size(result, scale, radius_scale=1.0, *, gray=None, invert=False):
    """Diameter of the tone dots in output units (``scale`` of them per pixel).

    The one place it is derived: twice the radius at which ``n`` equal dots
    hold the image's darkness as ink (:func:`diskpack_cl.picture_measures.tone_radius`),
    from ``gray`` (the image stippled, before ``invert``) when given, else
    the result's own ``tone_radius``; times ``radius_scale``.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> tone_dot_size(SimpleNamespace(points=np.zeros((4, 2)), tone_radius=1.5), 0.2)
    0.6000000000000001
    """
    if gray is not None:
        from .picture_measures import tone_radius

        tone = tone_radius(len(result.points), gray if invert else 1.0 - gray)
    elif getattr(result, "tone_radius", None) is None:
        raise ValueError("dots='tone' needs the result's tone_radius (a StippleResult has it; "
                         "an older file may not): give the dot size (dot_mm, --dot-mm) or draw "
                         "the packing disks (dots='packing', --dots packing)")
    else:
        tone = float(result.tone_radius)
    return 2.0 * tone * float(radius_scale) * scale


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
    """Millimetres per image pixel for a physical size, as :func:`write_svg` uses it.

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


#: Long side (px) of the PNG preview when no scale is given.
PREVIEW_MAX_PX = 4096


def preview_scale(width, height, scale=None):
    """PNG pixels per image pixel: ``scale``, else 2 capped at :data:`PREVIEW_MAX_PX` px.

    Examples
    --------
    >>> preview_scale(512, 512), preview_scale(6000, 4000), preview_scale(6000, 4000, 1.0)
    (2.0, 0.6826666666666666, 1.0)
    """
    return float(scale) if scale is not None else min(2.0, PREVIEW_MAX_PX / max(width, height))


def tone_dot_count(darkness, scale, dot_mm):
    """The number of dots ``dot_mm`` wide whose ink equals the image's on paper.

    ``darkness`` is per pixel in [0, 1]; ``scale`` mm per pixel.

    Examples
    --------
    >>> tone_dot_count(np.full((100, 100), 0.5), 1.0, 2.0)  # 5000 mm^2 of ink
    1592
    """
    ink_mm2 = float(np.mean(darkness)) * np.size(darkness) * scale * scale
    return max(2, int(round(ink_mm2 / (0.25 * np.pi * dot_mm * dot_mm))))


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
    """Where :func:`write_svg` puts a ``width x height`` px picture, all in mm.

    Without ``page`` the page is the picture, sized by :func:`mm_per_px`.
    With ``page`` (see :func:`paper_size`) the picture is centred on it,
    sized by ``width_mm``/``height_mm``/``dpi`` when given, else fitted
    inside the margins (``margin_mm``, default :data:`DEFAULT_MARGIN_MM`).
    With ``plotter`` (a device of vpype's profiles) the margins are those
    of the part of the page it plots too
    (:func:`diskpack_cl.plotters.plotting_area`), and the picture is centred
    there.

    Returns
    -------
    dict
        ``scale`` (mm per px), ``picture`` and ``page`` ((w, h) mm),
        ``offset`` ((x, y) mm of the picture's corner on the page).

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
                "page": (width * s, height * s), "offset": (0.0, 0.0)}
    pw, ph = paper_size(page, landscape=landscape)
    margin = DEFAULT_MARGIN_MM if margin_mm is None else float(margin_mm)
    if not 0 <= margin < 0.5 * min(pw, ph):
        raise ValueError(f"margin_mm must be in [0, {0.5 * min(pw, ph):g}) on a "
                         f"{pw:g}x{ph:g} mm page, got {margin_mm}")
    x0, y0, x1, y1 = margin, margin, pw - margin, ph - margin
    if plotter is not None:
        from diskpack_cl.plotters import plotting_area

        ax0, ay0, ax1, ay1 = plotting_area(plotter, (pw, ph))
        x0, y0, x1, y1 = max(x0, ax0), max(y0, ay0), min(x1, ax1), min(y1, ay1)
    if width_mm is None and height_mm is None and dpi is None:
        s = mm_per_px(width, height, x1 - x0, y1 - y0)
    else:
        s = mm_per_px(width, height, width_mm, height_mm, dpi)
    w, h = width * s, height * s
    if w > x1 - x0 + 1e-9 or h > y1 - y0 + 1e-9:
        raise ValueError(f"the picture ({w:.1f}x{h:.1f} mm) does not fit inside the "
                         f"{margin:g} mm margins of the {pw:g}x{ph:g} mm page"
                         + ("" if plotter is None else f" and the plotting area of {plotter}"))
    return {"scale": s, "picture": (w, h), "page": (pw, ph),
            "offset": (0.5 * (x0 + x1 - w), 0.5 * (y0 + y1 - h))}


#: Plot-time model of :func:`plot_time`: pen-down and pen-up speed (mm/s)
#: and seconds to lower and raise the pen once per dot (AxiDraw-like).
PLOT_SPEED_MM_S = 50.0
PEN_LIFT_S = 0.3


def _pen_names(text):
    """The command line's pen order: ``NAME,...``."""
    return [v.strip() for v in text.split(",")]


def _check_page(page):
    paper_size(page)


def _check_plotter(name):
    from diskpack_cl.plotters import plotter_config

    plotter_config(name)


@dataclass(frozen=True)
class WriteOptions:
    """How a stippling is drawn (SVG, PNG): the options of
    :func:`diskpack_cl.jobs.write_stipple_outputs`, ``diskpack stipple`` and
    ``diskpack export``.

    Examples
    --------
    >>> WriteOptions(pen_mm=0.5, page="a4").layout()["page"]
    'a4'
    >>> WriteOptions(dpi=300, width_mm=100)
    Traceback (most recent call last):
    ...
    diskpack_cl.options.OptionConflict: give the SVG size either by width_mm/height_mm or by dpi, not both
    """

    width_mm: float = option(None, "picture width in mm (with --height-mm: fit inside the "
                             "box)", unit="mm", lo=0, lo_open=True, metavar="MM", group=_OUTPUT)
    height_mm: float = option(None, "picture height in mm", unit="mm", lo=0, lo_open=True,
                              metavar="MM", group=_OUTPUT)
    dpi: float = option(None, "picture size from the image's pixels at DPI (default 96 when "
                        "no mm size and no --page)", lo=0, lo_open=True, metavar="DPI",
                        group=_OUTPUT)
    page: str = option(None, f"the SVG's page is this paper: {', '.join(PAPERS)} or WxHmm "
                       f"(e.g. 300x200mm), portrait; the picture is centred on it and, without "
                       f"a size, fitted inside the margins", check=_check_page, metavar="PAPER",
                       group=_OUTPUT)
    landscape: bool = option(False, "turn the --page paper", group=_OUTPUT)
    margin_mm: float = option(None, f"margin around the picture on the --page paper "
                              f"(default {DEFAULT_MARGIN_MM:g})", unit="mm", lo=0,
                              metavar="MM", group=_OUTPUT)
    plotter: str = option(None, "a plotter of vpype's device profiles (vpype's --device, e.g. "
                          "hp7475a): the picture stays inside the part of the --page paper it "
                          "plots, so that vpype write --device NAME --page-size PAPER keeps "
                          "every dot", check=_check_plotter, metavar="NAME", group=_OUTPUT)
    dots: str = option(None, "dot size in SVG and PNG: tone (default) = one size for all "
                       "dots, chosen so that the total ink equals the image's total darkness; "
                       "packing = each dot its certified packing disk (large where the image "
                       "is light: it shows the packing, not the tone)",
                       choices=("tone", "packing"), group=_OUTPUT)
    dot_mm: float = option(None, "fixed dot diameter in mm instead of --dots; the PNG preview "
                           "shows the same dots", unit="mm", lo=0, lo_open=True, metavar="MM",
                           group=_OUTPUT)
    pen_mm: float = option(None, "plotter pen width in mm: the SVG draws each dot as the pen "
                           "draws it, one path per dot: a dot not wider than the pen is one "
                           "pen touch, a wider one is filled by concentric rings W apart (the "
                           "outermost of radius (dot diameter - W)/2); the PNG preview shows "
                           "the same ink (default: filled circles, which a plotter traces W "
                           "wider)", unit="mm", lo=0, lo_open=True, metavar="W", group=_OUTPUT)
    radius_scale: float = option(1.0, "factor on the dot radii of --dots in SVG and PNG "
                                 "(default 1.0)", lo=0, lo_open=True, metavar="F",
                                 group=_OUTPUT)
    pen_path: str = option("auto", "SVG dot order: auto (default) = the shorter of greedy and "
                           "Hilbert, then 2-opt for at most 2 s; hilbert = Hilbert curve; "
                           "greedy = nearest neighbour; none = as computed",
                           choices=PEN_PATHS, group=_OUTPUT)
    png_scale: float = option(None, f"PNG pixels per image pixel (default 2.0, at most a "
                              f"{PREVIEW_MAX_PX} px long side)", lo=0, lo_open=True,
                              metavar="F", group=_OUTPUT)
    plot_speed_mm_s: float = option(
        PLOT_SPEED_MM_S, f"plot-time estimate: pen speed V mm/s drawing and travelling, plus "
        f"{PEN_LIFT_S:g} s to lower and raise the pen per dot (default {PLOT_SPEED_MM_S:g})",
        unit="mm/s", lo=0, lo_open=True, metavar="V", group=_OUTPUT)
    no_overlap: bool = option(False, "drawn dots never touch, the pen's width included: each "
                              "dot at most its packing disk (lighter where the tone dots "
                              "are wider than the packing allows; the summary says how much "
                              "ink it keeps and which share of the dots touch without it)",
                              group=_OUTPUT)
    pen_order: object = option(None, "SVG layer order of a colour stippling (--colors, "
                               "--pens; first drawn first; default: lightest pen first)",
                               cli_type=_pen_names, metavar="NAME,...", group=_OUTPUT)
    invert: bool = option(False, "light dots on dark paper", cli=False)

    def __post_init__(self):
        check_fields(self)
        if self.dot_mm is not None and self.dots is not None:
            raise OptionConflict(f"{{}} {self.dot_mm:g} and {{}} {self.dots} both set the dot "
                                 f"size; give one", "dot_mm", "dots")
        check_size(self.width_mm, self.height_mm, self.dpi)
        for name in ("margin_mm", "landscape", "plotter"):
            if getattr(self, name) not in (None, False) and self.page is None:
                raise OptionConflict("{} is for a {} paper: give {} too (e.g. {} a4)",
                                     name, "page", "page", "page")

    def layout(self):
        """Where the picture goes on paper: the keyword arguments of :func:`svg_layout`."""
        return {k: getattr(self, k) for k in ("width_mm", "height_mm", "dpi", "page",
                                               "landscape", "margin_mm", "plotter")}

    def scale(self, width, height):
        """Millimetres per image pixel of a `width` x `height` picture on this paper."""
        return svg_layout(width, height, **self.layout())["scale"]

    def replace(self, **overrides):
        """A copy with ``overrides`` (field names), checked again."""
        return replace(self, **overrides)


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


def _pen_rings(rad, pen):
    """Ring radii (mm) that fill dots of radius ``rad`` with a pen ``pen`` wide.

    A ring of radius rho inks [rho - pen/2, rho + pen/2]: the outermost is
    at ``rad - pen/2``, each next one a pen width further in, the innermost
    at least ``pen/2`` (it inks the centre). Returns an (n, m) array, nan
    where a dot has fewer rings; a dot not wider than the pen has none (it
    is one pen touch).
    """
    m = np.where(2 * rad <= pen, 0, np.ceil(rad / pen - 1e-9)).astype(np.int64)
    j = np.arange(max(int(m.max(initial=0)), 1))
    outer = np.round(rad - 0.5 * pen, 4)  # as written: the rings follow from it when read back
    rho = np.maximum(outer[:, None] - j[None, :] * pen, 0.5 * pen)
    return np.where(j[None, :] < m[:, None], rho, np.nan)


def _svg_dots(c, rad, pen):
    """SVG lines of the dots, one element each, and their pen-down length (mm).

    Without a pen: filled ``<circle>``s. With a pen ``pen`` mm wide (see
    :func:`write_svg`): a ``<circle>`` outline for a one-ring dot, one
    ``<path>`` of concentric rings joined by short radial lines for a wider
    dot, a 0.01 mm ``<path>`` (a pen touch) for a dot not wider than the pen.
    """
    x, y = c[:, 0], c[:, 1]
    if pen is None:
        circles = _join('    <circle cx="', _fmt(x), '" cy="', _fmt(y), '" r="', _fmt(rad), '"/>\n')
        return "".join(circles.tolist()), float(2 * np.pi * rad.sum())
    rho = _pen_rings(rad, pen)
    m = np.count_nonzero(~np.isnan(rho), axis=1)
    lines = np.empty(len(c), dtype=object)
    touch = m == 0
    lines[touch] = _join('    <path d="M ', _fmt(x[touch] - 0.5 * _TOUCH_MM), ',', _fmt(y[touch]),
                         f' h {_TOUCH_MM}"/>\n')
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
            + _TOUCH_MM * np.count_nonzero(touch))
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
#: Label of the layer of the dots in :func:`write_svg`.
LAYER = "stipples"


def _svg_head(lay, size, meta, paint, invert):
    """Everything of the SVG before the dots: page, metadata, background, the dots' layer."""
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
        f'  <metadata id="diskpack_cl">{json.dumps(meta)}</metadata>',
    ]
    if invert:  # the black paper, in a layer that plotters skip (AxiDraw: a name with %)
        head += ['  <g inkscape:groupmode="layer" inkscape:label="% paper (not plotted)" '
                 'id="paper" sodipodi:insensitive="true">',
                 f'    <image x="0" y="0" width="{pw:.10g}" height="{ph:.10g}" '
                 f'preserveAspectRatio="none" xlink:href="{_BLACK_PNG}"/>', '  </g>']
    head.append(f'  <g inkscape:groupmode="layer" inkscape:label="{meta["layer"]}" '
                f'id="layer1" {paint}>')
    return "\n".join(head) + "\n"


def write_svg(path, result, *, width_mm=None, height_mm=None, dpi=None, dot_mm=None,
              radius_scale=1.0, pen_path="auto", layer=LAYER, invert=False, pen_mm=None,
              dots="tone", page=None, landscape=False, margin_mm=None, plotter=None,
              plot_speed_mm_s=PLOT_SPEED_MM_S, no_overlap=False):
    """Write an SVG for pen plotters, vpype and Inkscape.

    One element per dot, in pen-path order, in one Inkscape layer; user
    units are millimetres. The page is the picture (``width="..px"``, CSS
    pixels, for a ``dpi`` size, else ``..mm``) or the ``page`` paper with
    the picture centred (:func:`svg_layout`). A dot that would stick out of
    the picture moves inward until it touches the edge. A ``<metadata>``
    element records the layout for :func:`read_stipple`.

    Without ``pen_mm`` the dots are filled circles (a plotter traces their
    outline, a pen width wider). With ``pen_mm=W`` each dot is drawn as the
    pen draws it: a dot not wider than the pen is one touch (a 0.01 mm
    path, round caps), a wider one one path of concentric rings W apart
    (:func:`_pen_rings`), the outermost of radius ``(diameter - W) / 2``.

    Parameters
    ----------
    width_mm, height_mm, dpi : float, optional
        Picture size (:func:`mm_per_px`; with ``page``, by default fitted
        inside the margins).
    dot_mm : float, optional
        Fixed dot diameter in mm, instead of ``dots`` (``"tone"``: one size,
        ``result.tone_radius``, ink = the image's darkness; ``"packing"``:
        the certified disks) times ``radius_scale``.
    pen_path : {"auto", "hilbert", "greedy", "none"}
        See :func:`diskpack_cl.pen_path.pen_path_order`.
    invert : bool, optional
        White dots on black paper: a black image in the layer ``% paper
        (not plotted)``, which vpype and plotters skip.
    page, landscape, margin_mm, plotter : optional
        The paper and what of it the plotter reaches (:func:`paper_size`,
        :func:`svg_layout`).
    plot_speed_mm_s : float
        Speed of the plot-time estimate (:func:`plot_time`).
    no_overlap : bool
        No two drawn dots touch: each at most its packing disk
        (:func:`diskpack_cl.overlap.cap_radii`).

    Returns
    -------
    dict
        ``width_mm``, ``height_mm`` (picture), ``page_mm``, ``n``,
        ``travel_before_mm``, ``travel_after_mm`` (pen-up, from the origin),
        ``moved_inside``, ``pen_downs``, ``draw_mm``, ``plot_seconds``,
        the touching share and ink of :func:`diskpack_cl.overlap.ink_figures`
        and, with ``pen_mm``, ``pen_touches``.

    Examples
    --------
    >>> import tempfile, os, types
    >>> res = types.SimpleNamespace(points=np.array([[0.0, 8.0], [8.0, 8.0]]),
    ...                             radii=np.array([1.0, 1.0]), width=16, height=16,
    ...                             tone_radius=1.0)
    >>> out = os.path.join(tempfile.mkdtemp(), "dots.svg")
    >>> info = write_svg(out, res, dpi=25.4, pen_mm=0.5)
    >>> info["moved_inside"], info["pen_touches"]
    (1, 0)
    >>> [line.split()[:5] for line in Path(out).read_text().splitlines() if "<path" in line][0]
    ['<path', 'd="M', '1.7552,8.0000', 'a', '0.7500,0.7500']
    """
    p, r, W, H = _arrays(result)
    if pen_mm is not None and not pen_mm > 0:
        raise ValueError(f"pen_mm must be > 0, got {pen_mm}")
    lay = svg_layout(W, H, width_mm=width_mm, height_mm=height_mm, dpi=dpi, page=page,
                     landscape=landscape, margin_mm=margin_mm, plotter=plotter)
    rad = _svg_radii(result, r, lay["scale"], dot_mm, dots, radius_scale)
    pm, drawn, moved = _inside_page(p * lay["scale"],
                                    cap_radii(rad, r * lay["scale"]) if no_overlap else rad,
                                    *lay["picture"])
    ink = ink_figures(pm, rad, r * lay["scale"], pen=pen_mm, no_overlap=no_overlap)
    rad = drawn
    pm += lay["offset"]
    order, before, after = pen_path_order(pm, method=pen_path)
    meta = _svg_meta(result, lay, rad, pen_mm, invert, layer)
    head = _svg_head(lay, _svg_size(lay, W, H, width_mm, height_mm, page), meta,
                     _svg_paint(pen_mm, invert), invert)
    draw = _write_svg_file(path, head, pm[order], rad[order], pen_mm)
    info = {"width_mm": lay["picture"][0], "height_mm": lay["picture"][1],
            "page_mm": list(lay["page"]), "n": int(len(p)), "travel_before_mm": before,
            "travel_after_mm": after, "moved_inside": moved, "pen_downs": int(len(p)),
            "draw_mm": draw, **ink,
            "plot_seconds": plot_time(len(p), draw, after, speed_mm_s=plot_speed_mm_s)}
    if pen_mm is not None:
        info["pen_touches"] = int(np.count_nonzero(2 * rad <= pen_mm))
    return info


def _svg_paint(pen_mm, invert):
    """The dots' paint: filled circles, or the pen's stroke."""
    if pen_mm is None:
        return f'fill="{"white" if invert else "black"}" stroke="none"'
    return (f'fill="none" stroke="{"white" if invert else "black"}" '
            f'stroke-width="{pen_mm:.4f}" stroke-linecap="round" stroke-linejoin="round"')


def _write_svg_file(path, head, centres, rad, pen_mm):
    """Write the SVG (atomically) in chunks of dots; the pen-down drawing length (mm)."""
    draw = 0.0
    with atomic_write(path, "w") as fh:
        fh.write(head)
        for a in range(0, len(centres), 100_000):
            text, length = _svg_dots(centres[a : a + 100_000], rad[a : a + 100_000], pen_mm)
            fh.write(text)
            draw += length
        fh.write("  </g>\n</svg>\n")
    return draw


def _svg_radii(result, radii, scale, dot_mm, dots, radius_scale):
    """Drawn radius per dot in mm: ``dot_mm / 2``, else :func:`_dot_radii`."""
    if dot_mm is None:
        return _dot_radii(result, radii, scale, dots, radius_scale)
    if not dot_mm > 0:
        raise ValueError(f"dot_mm must be > 0, got {dot_mm}")
    return np.full(len(radii), 0.5 * float(dot_mm))


def _svg_size(lay, W, H, width_mm, height_mm, page):
    """The ``width``/``height`` attributes: CSS pixels (exact) for a dpi size, else mm."""
    if page is None and width_mm is None and height_mm is None:
        s = lay["scale"] / MM_PER_INCH * 96
        return f'width="{W * s:.10g}px" height="{H * s:.10g}px"'
    return f'width="{lay["page"][0]:.10g}mm" height="{lay["page"][1]:.10g}mm"'


def _svg_meta(result, lay, rad, pen_mm, invert, layer):
    """What :func:`read_stipple` needs to read the dots back (JSON in ``<metadata>``)."""
    same = len(rad) > 0 and bool(np.all(rad == rad[0]))
    tone = getattr(result, "tone_radius", None)
    k = float(getattr(result, "k", np.nan))
    return {"width": int(result.width), "height": int(result.height), "mm_per_px": lay["scale"],
            "offset_mm": list(lay["offset"]), "pen_mm": pen_mm,
            "dot_mm": 2 * float(rad[0]) if same else None,
            "tone_radius": None if tone is None else float(tone),
            "k": None if np.isnan(k) else k, "invert": bool(invert), "layer": layer}


# coordinates are written with 4 decimals: keep dots this far inside the page
_EDGE_MM = 2e-4
# a pen touch: a path this long (mm), centred on the dot
_TOUCH_MM = 0.01


def _inside_page(c, rad, wmm, hmm):
    """Move dots that stick out of the page inward; return (centres, radii, moved)."""
    rad = np.minimum(rad, 0.5 * min(wmm, hmm) - 2 * _EDGE_MM - _TOUCH_MM)
    ext = rad + _EDGE_MM + 0.5 * _TOUCH_MM
    inside = np.column_stack([np.clip(c[:, 0], ext, wmm - ext), np.clip(c[:, 1], ext, hmm - ext)])
    moved = int(np.count_nonzero(np.any(inside != c, axis=1)))
    return inside, rad, moved


def _coverage(c, rad, ow, oh, aa, progress=None):
    """Ink coverage in [0, 1] per output pixel: fraction of aa x aa samples in a disk.

    Dots are stamped in windows of their own size (grouped by size, in
    chunks), and the coverages are summed with ``np.add.at``: exact sample
    counts for disjoint disks; overlapping dots (fixed or enlarged dot sizes)
    are summed and clipped at 1. ``progress(k)`` is called after each chunk
    of ``k`` dots.
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
            t0 = (px * aa).astype(np.float64)[:, None, :]  # (k, 1, m) first column
            cnt = np.minimum(hi[:, :, None], t0 + (aa - 1)) - np.maximum(lo[:, :, None], t0) + 1
            cnt = np.maximum(cnt, 0.0).reshape(len(i), m, aa, m).sum(axis=2)
            cov = cnt / float(aa * aa)  # (k, m_y, m_x)
            gx = np.broadcast_to(px[:, None, :], cov.shape)
            gy = np.broadcast_to(py[:, :, None], cov.shape)
            ok = (cov > 0) & (gx >= 0) & (gx < ow) & (gy >= 0) & (gy < oh)
            np.add.at(ink, gy[ok] * ow + gx[ok], cov[ok])
            if progress is not None:
                progress(len(i))
    return np.minimum(ink, 1.0).reshape(oh, ow)


def write_png(path, result, *, scale=1.0, radius_scale=1.0, dot_px=None, invert=False, aa=4,
              dots="tone", pen_px=None, progress=None, no_overlap=False):
    """Write an anti-aliased PNG preview (8-bit gray).

    Each output pixel's ink is the fraction of its ``aa x aa`` sample
    points that fall inside a dot (stratified super-sampling of the exact
    disks, no rounding of centres or radii).

    Parameters
    ----------
    scale : float, optional
        Output pixels per image pixel.
    radius_scale : float, optional
        Factor on the radii of ``dots``.
    dot_px : float, optional
        Fixed dot radius in output pixels, instead of ``dots``.
    invert : bool, optional
        White dots on black.
    aa : int, optional
        Samples per output pixel side.
    dots : {"tone", "packing"}
        As for :func:`write_svg`: equal-ink dots by default (what ``diskpack
        stipple`` draws), or the packing disks.
    pen_px : float, optional
        The plotter pen's width in output pixels: show what the pen draws
        (:func:`write_svg` with ``pen_mm``): a dot narrower than the pen as a
        pen touch, a wider one filled (its rings ink the whole disk).
    progress : callable, optional
        ``progress(k)`` after each ``k`` dots stamped (a progress bar).
    no_overlap : bool
        As for :func:`write_svg`.

    Returns
    -------
    dict
        ``width``, ``height`` (output pixels), ``n``.

    Examples
    --------
    >>> import os, tempfile
    >>> from PIL import Image
    >>> from types import SimpleNamespace
    >>> res = SimpleNamespace(points=np.array([[1.0, 1.0], [3.0, 1.0]]),
    ...                       radii=np.array([0.5, 0.5]), width=4, height=2)
    >>> path = os.path.join(tempfile.mkdtemp(), "dots.png")
    >>> info = write_png(path, res, scale=4.0, dots="packing")
    >>> with Image.open(path) as im:
    ...     im.size
    (16, 8)
    """
    from PIL import Image

    p, r, W, H = _arrays(result)
    if not scale > 0:
        raise ValueError(f"scale must be > 0, got {scale}")
    aa = int(aa)
    if aa < 1:
        raise ValueError(f"aa must be >= 1, got {aa}")
    ow, oh = max(1, int(round(W * scale))), max(1, int(round(H * scale)))
    if dot_px is not None:
        if not dot_px > 0:
            raise ValueError(f"dot_px must be > 0, got {dot_px}")
        rad = np.full(len(p), float(dot_px))
    else:
        rad = _dot_radii(result, r, scale, dots, radius_scale)
    if no_overlap:
        rad = cap_radii(rad, r * scale)
    if pen_px is not None:
        if not pen_px > 0:
            raise ValueError(f"pen_px must be > 0, got {pen_px}")
        rad = np.maximum(rad, 0.5 * pen_px)
    ink = _coverage(p * scale, rad, ow, oh, aa, progress)
    val = ink if invert else 1.0 - ink
    img = Image.fromarray(np.round(val * 255).astype(np.uint8))
    with atomic_write(path, "wb") as fh:
        img.save(fh, format="PNG")
    return {"width": ow, "height": oh, "n": int(len(p))}


def _certificate_fields(result):
    out = {}
    cert = getattr(result, "certificate", None)
    if cert is None:
        return out
    for name in dir(cert):
        if name.startswith("_"):
            continue
        try:
            v = getattr(cert, name)
        except Exception:  # pragma: no cover - odd properties
            continue
        if callable(v):
            continue
        if isinstance(v, (bool, int, float, np.bool_, np.integer, np.floating)):
            out[f"certificate_{name}"] = np.asarray(v)
    return out


def write_npz(path, result):
    """Write ``points``, ``radii``, ``k``, ``width``, ``height`` (+ certificate fields).

    Also ``base_radii``, ``tone_radius`` and a JSON ``params`` string when
    the result has them, and ``certificate_<field>`` for each scalar field
    of the certificate.

    Examples
    --------
    >>> import os, tempfile
    >>> from types import SimpleNamespace
    >>> res = SimpleNamespace(points=np.array([[1.0, 1.0], [3.0, 1.0]]),
    ...                       radii=np.array([0.5, 0.5]), width=4, height=2)
    >>> path = os.path.join(tempfile.mkdtemp(), "dots.npz")
    >>> _ = write_npz(path, res)
    >>> np.load(path)["radii"].tolist()
    [0.5, 0.5]
    """
    p, r, W, H = _arrays(result)
    data = {
        "points": p,
        "radii": r,
        "k": np.asarray(float(getattr(result, "k", np.nan))),
        "width": np.asarray(int(W)),
        "height": np.asarray(int(H)),
    }
    if getattr(result, "base_radii", None) is not None:
        data["base_radii"] = np.asarray(result.base_radii, dtype=np.float64)
    if getattr(result, "tone_radius", None) is not None:
        data["tone_radius"] = np.asarray(float(result.tone_radius))
    if getattr(result, "params", None):
        data["params"] = np.asarray(json.dumps(result.params, default=str))
    data.update(_certificate_fields(result))
    data.update(_pen_fields(result))
    with atomic_write(path, "wb") as fh:
        np.savez_compressed(fh, **data)
    return {"n": int(len(p))}


def _pen_fields(result):
    """A colour stippling's ``pen``, ``pen_names``, ``pen_colors``, ``pen_radius`` (else none)."""
    if getattr(result, "pen", None) is None:
        return {}
    return {"pen": np.asarray(result.pen, np.int64), "pen_names": np.asarray(result.names, str),
            "pen_colors": np.asarray(result.colors, np.float64),
            "pen_radius": np.asarray(result.pen_radius, np.float64)}


def write_csv(path, result):
    """Write ``x,y,r`` rows (pixel units, 17 significant digits: exact round trip).

    The first line is a ``#`` comment without commas (:data:`CSV_TAG`,
    then ``width=W height=H`` and, when known, ``k=`` and ``tone_radius=``),
    so that :func:`read_stipple` reads the stippling back; CSV readers skip
    it with ``comment="#"`` (numpy, pandas).

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "dots.csv"
    >>> from types import SimpleNamespace
    >>> res = SimpleNamespace(points=np.array([[1.0, 1.0], [3.0, 1.0]]),
    ...                       radii=np.array([0.5, 0.5]), width=4, height=2)
    >>> _ = write_csv(path, res)
    >>> path.read_text().splitlines()[1:]
    ['x,y,r', '1,1,0.5', '3,1,0.5']
    """
    p, r, W, H = _arrays(result)
    tone = getattr(result, "tone_radius", None)
    meta = {"width": int(W), "height": int(H), "k": float(getattr(result, "k", np.nan)),
            "tone_radius": None if tone is None else float(tone)}
    tag = " ".join(f"{key}={v!r}" for key, v in meta.items() if v is not None and v == v)
    with atomic_write(path, "w") as fh:
        if getattr(result, "pen", None) is not None:
            _write_pen_csv(fh, f"{CSV_TAG}{tag}", p, r, result)
            return {"n": int(len(p))}
        fh.write(f"{CSV_TAG}{tag}\nx,y,r\n")
        np.savetxt(fh, np.column_stack([p, r]), fmt="%.17g", delimiter=",")
    return {"n": int(len(p))}


def _write_pen_csv(fh, tag, p, r, result):
    """A colour stippling's CSV: the tag line with ``pens=NAME:#rrggbb;...``, then
    ``x,y,r,pen`` rows (the pen's name); names percent-encoded (:func:`~diskpack_cl.readers.csv_name`)."""
    from diskpack_cl.multipen import hex_color

    coded = [csv_name(name) for name in result.names]
    pens = ";".join(f"{name}:{hex_color(c)}" for name, c in zip(coded, result.colors))
    rows = np.char.mod("%.17g", np.column_stack([p, r])).tolist()
    names = np.asarray(coded)[np.asarray(result.pen)].tolist()
    fh.write(f"{tag} pens={pens}\nx,y,r,pen\n"
             + "".join(",".join(row + [q]) + "\n" for row, q in zip(rows, names)))


WRITERS = {".svg": write_svg, ".png": write_png, ".npz": write_npz, ".csv": write_csv}


def check_output_path(path):
    """Raise before any work if ``path`` cannot be written by :func:`write_stipple`.

    Raises
    ------
    ValueError
        ``path`` is a folder, an unknown extension (the message lists the
        supported ones), or its folder is not writable (a probe file is created
        there and removed, see :func:`diskpack_cl.io.check_writable`).
    FileNotFoundError
        The output directory does not exist.

    Examples
    --------
    >>> import os, tempfile
    >>> check_output_path(os.path.join(tempfile.mkdtemp(), "out.svg"))
    '.svg'
    >>> check_output_path("out.bmp")
    Traceback (most recent call last):
    ...
    ValueError: ...
    """
    path = Path(os.fspath(path))
    ext = path.suffix.lower()
    if path.is_dir():
        raise ValueError(f"{path} is a folder, not a file name: give one in it, such as "
                         f"{path / 'out.svg'}")
    if ext not in WRITERS:
        raise ValueError(
            f"unknown output extension {ext or '(none)'!r} for {path}; supported: "
            + ", ".join(sorted(WRITERS))
        )
    check_writable(path)
    return ext


def write_stipple(path, result, **opts):
    """Write ``result`` in the format named by the extension of ``path``.

    ``.svg`` (:func:`write_svg`), ``.png`` (:func:`write_png`), ``.npz``
    (:func:`write_npz`), ``.csv`` (:func:`write_csv`); ``opts`` go to the
    writer. Returns the writer's info dict.

    Examples
    --------
    >>> import os, tempfile
    >>> from types import SimpleNamespace
    >>> res = SimpleNamespace(points=np.array([[1.0, 1.0], [3.0, 1.0]]),
    ...                       radii=np.array([0.5, 0.5]), width=4, height=2)
    >>> path = os.path.join(tempfile.mkdtemp(), "dots.svg")
    >>> info = write_stipple(path, res, width_mm=40, dots="packing")
    >>> read_stipple(path).points.tolist()
    [[1.0, 1.0], [3.0, 1.0]]
    """
    ext = check_output_path(path)
    if getattr(result, "pen", None) is not None and ext in (".svg", ".png"):
        from diskpack_cl.color_export import COLOR_WRITERS

        return COLOR_WRITERS[ext](path, result, **opts)
    return WRITERS[ext](path, result, **opts)
