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

from diskpack_cl.drawing.page import (DEFAULT_MARGIN_MM, FRAME_INK, PAPERS, PEN_LIFT_S, PLOT_SPEED_MM_S,
                                  MM_PER_INCH, check_fit, check_size, ink_coverage, mm_per_px,
                                  page_frame, paper_size, place_dots, plot_time, save_png, svg_dots,
                                  svg_head, svg_layout, svg_meta, svg_size)
from diskpack_cl.io import atomic_write, check_writable
from diskpack_cl.memory import check_png_memory
from diskpack_cl.options import OptionConflict, check_fields, option
from diskpack_cl.drawing.overlap import cap_radii, check_apart, ink_figures
from diskpack_cl.drawing.pen_path import PEN_PATHS, TWO_OPT_WORK, path_travel, pen_path_order
from diskpack_cl.drawing.readers import CSV_TAG, check_stippling, csv_name, read_stipple

__all__ = [
    "WRITERS",
    "WriteOptions",
    "check_output_path",
    "check_preview_memory",
    "check_size",
    "mm_per_px",
    "tone_dot_size",
    "pen_path_order",
    "path_travel",
    "read_stipple",
    "write_stipple",
    "write_svg",
    "write_png",
    "write_page_png",
    "write_npz",
    "write_csv",
]

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
        from ..picture_measures import tone_radius

        tone = tone_radius(len(result.points), gray if invert else 1.0 - gray)
    elif getattr(result, "tone_radius", None) is None:
        raise ValueError("dots='tone' needs the result's tone_radius (a StippleResult has it; "
                         "an older file may not): give the dot size (dot_mm, --dot-mm) or draw "
                         "the packing disks (dots='packing', --dots packing)")
    else:
        tone = float(result.tone_radius)
    return 2.0 * tone * float(radius_scale) * scale


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


def check_preview_memory(write, width, height, outputs, *, free=None):
    """Refuse, before the work, a PNG among `outputs` of a `width` x `height` picture drawn
    as `write` (:class:`WriteOptions`) draws it that memory cannot hold.

    Raises
    ------
    diskpack_cl.memory.MemoryLimit
        As :func:`diskpack_cl.memory.check_png_memory`.

    Examples
    --------
    >>> check_preview_memory(WriteOptions(), 4000, 3000, ["a.png"], free=8 * 2**30)
    >>> check_preview_memory(WriteOptions(png_scale=100), 4000, 3000, ["a.png"], free=8 * 2**30)
    Traceback (most recent call last):
    ...
    diskpack_cl.memory.MemoryLimit: png_scale 100 makes a 400000x300000 PNG needing 3.58e+03 GiB, more than the memory available (8 GiB): lower png_scale (at most 4.7 here)
    """
    area = write.preview_area(width, height)
    check_png_memory(*area, preview_scale(*area, write.png_scale), outputs, free=free)


def tone_dot_count(darkness, scale, dot_mm):
    """The number of dots ``dot_mm`` wide whose ink equals the image's on paper.

    ``darkness`` is per pixel in [0, 1]; ``scale`` mm per pixel. Fewer
    than 2 dots is a ``ValueError`` (the dots are too large for the ink).

    Examples
    --------
    >>> tone_dot_count(np.full((100, 100), 0.5), 1.0, 2.0)  # 5000 mm^2 of ink
    1592
    """
    ink_mm2 = float(np.mean(darkness)) * np.size(darkness) * scale * scale
    count = ink_mm2 / (0.25 * np.pi * dot_mm * dot_mm)
    if count < 2:
        raise ValueError(f"the image's ink holds {count:.2g} dots {dot_mm:g} mm wide, fewer than "
                         f"2: give a smaller --dot-mm or -n N")
    return int(round(count))


#: The keywords of :func:`svg_layout`: where the picture goes on paper.
LAYOUT = ("width_mm", "height_mm", "dpi", "page", "landscape", "margin_mm", "plotter")


#: What a PNG output shows (:attr:`WriteOptions.preview`).
PREVIEWS = ("picture", "page")


def _pen_names(text):
    """The command line's pen order: ``NAME,...``."""
    return [v.strip() for v in text.split(",")]


def _check_page(page):
    paper_size(page)


def _check_plotter(name):
    from diskpack_cl.drawing.plotters import plotter_config

    plotter_config(name)


@dataclass(frozen=True)
class WriteOptions:
    """How a stippling is drawn (SVG, PNG): the options of
    :func:`diskpack_cl.jobs.items.write_stipple_outputs`, ``diskpack stipple`` and
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
                           "shows the same dots (a warning when the dots drawn are more than "
                           "2 x as wide as the median spacing of their centres)", unit="mm",
                           lo=0, lo_open=True, metavar="MM", group=_OUTPUT)
    pen_mm: float = option(None, "plotter pen width in mm: the SVG draws each dot as the pen "
                           "draws it, one path per dot: a dot not wider than the pen is one "
                           "pen touch, a wider one is filled by concentric rings W apart (the "
                           "outermost of radius (dot diameter - W)/2); the PNG preview shows "
                           "the same ink (default: filled circles, which a plotter traces W "
                           "wider)", unit="mm", lo=0, lo_open=True, metavar="W", group=_OUTPUT)
    radius_scale: float = option(1.0, "factor on the dot radii of --dots in SVG and PNG "
                                 "(default 1.0)", lo=0, lo_open=True, metavar="F",
                                 group=_OUTPUT)
    pen_path: str = option("auto", f"SVG dot order: auto (default) = the shorter of greedy and "
                           f"Hilbert, then ceil({TWO_OPT_WORK} / dots) rounds of 2-opt (a fixed "
                           f"work, not a time bound: the same order on every machine; seconds "
                           f"for 20000 dots); hilbert = Hilbert curve; greedy = nearest "
                           f"neighbour; none = as computed",
                           choices=PEN_PATHS, group=_OUTPUT)
    png_scale: float = option(None, f"PNG pixels per image pixel (default 2.0, at most a "
                              f"{PREVIEW_MAX_PX} px long side)", lo=0, lo_open=True,
                              metavar="F", group=_OUTPUT)
    preview: str = option("picture", "what a .png output shows: picture (default) = the "
                          "picture alone; page = the whole page as the SVG lays it out: the "
                          "paper, a light line at the margins, each dot where the SVG draws "
                          "it and as wide as its ink (the pen's width included)",
                          choices=PREVIEWS, group=_OUTPUT)
    plot_speed_mm_s: float = option(
        PLOT_SPEED_MM_S, f"plot-time estimate: pen speed V mm/s drawing and travelling, plus "
        f"--pen-lift-s per dot (default {PLOT_SPEED_MM_S:g})",
        unit="mm/s", lo=0, lo_open=True, metavar="V", group=_OUTPUT)
    pen_lift_s: float = option(
        PEN_LIFT_S, f"plot-time estimate: seconds to lower and raise the pen once per dot "
        f"(default {PEN_LIFT_S:g})", unit="s", lo=0, metavar="S", group=_OUTPUT)
    no_overlap: bool = option(False, "drawn dots never touch, the pen's width included: each "
                              "dot at most its packing disk (lighter where the tone dots "
                              "are wider than the packing allows; the summary says how much "
                              "ink it keeps and which share of the dots touch without it); "
                              "refused where it cannot hold: a pen wider than the packing "
                              "disks, or an .svg input (its dots are the drawn ones)",
                              group=_OUTPUT)
    pen_order: object = option(None, "SVG layer order of a colour stippling (--colors, "
                               "--pens; first drawn first; default: lightest pen first)",
                               cli_type=_pen_names, metavar="NAME,...", group=_OUTPUT)
    invert: bool = option(False, "light dots on dark paper (diskpack export: by default as the "
                          "stippling was made)", group=_OUTPUT)

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
        return {k: getattr(self, k) for k in LAYOUT}

    def scale(self, width, height):
        """Millimetres per image pixel of a `width` x `height` picture on this paper."""
        return svg_layout(width, height, **self.layout())["scale"]

    def preview_area(self, width, height):
        """The size, in image pixels, of what a PNG output of a `width` x `height` picture shows.

        Examples
        --------
        >>> WriteOptions(page="100x50mm", margin_mm=0).preview_area(20, 10)
        (20, 10)
        >>> WriteOptions(page="100x50mm", margin_mm=0, preview="page").preview_area(10, 10)
        (20.0, 10.0)
        """
        if self.preview == "picture":
            return width, height
        lay = svg_layout(width, height, **self.layout())
        return tuple(v / lay["scale"] for v in lay["page"])

    def replace(self, **overrides):
        """A copy with ``overrides`` (field names), checked again."""
        return replace(self, **overrides)


#: Label of the layer of the dots in :func:`write_svg`.
LAYER = "stipples"


def write_svg(path, result, *, width_mm=None, height_mm=None, dpi=None, dot_mm=None,
              radius_scale=1.0, pen_path="auto", layer=LAYER, invert=False, pen_mm=None,
              dots="tone", page=None, landscape=False, margin_mm=None, plotter=None,
              plot_speed_mm_s=PLOT_SPEED_MM_S, no_overlap=False, pen_lift_s=PEN_LIFT_S):
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
    (:func:`~diskpack_cl.drawing.page.pen_rings`), the outermost of radius ``(diameter - W) / 2``.

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
        See :func:`diskpack_cl.drawing.pen_path.pen_path_order`.
    invert : bool, optional
        White dots on black paper: a black image in the layer ``% paper
        (not plotted)``, which vpype and plotters skip.
    page, landscape, margin_mm, plotter : optional
        The paper and what of it the plotter reaches (:func:`paper_size`,
        :func:`svg_layout`).
    plot_speed_mm_s, pen_lift_s : float
        Speed and pen lift of the plot-time estimate (:func:`plot_time`).
    no_overlap : bool
        No two drawn dots touch: each at most its packing disk
        (:func:`diskpack_cl.drawing.overlap.cap_radii`); dots that still touch (a pen
        wider than the disks) are refused (:func:`diskpack_cl.drawing.overlap.check_apart`).

    Returns
    -------
    dict
        ``width_mm``, ``height_mm`` (picture), ``page_mm``, ``n``,
        ``travel_before_mm``, ``travel_after_mm`` (pen-up, from the origin),
        ``moved_inside``, ``pen_downs``, ``draw_mm``, ``plot_seconds``,
        the touching share and ink of :func:`diskpack_cl.drawing.overlap.ink_figures`
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
    ['<path', 'd="M', '1.7502,8.0000', 'a', '0.7500,0.7500']
    """
    check_stippling(result, path, packing=False)
    p, r, W, H = _arrays(result)
    lay, pm, rad, drawn, moved = _drawn_dots(
        result, width_mm=width_mm, height_mm=height_mm, dpi=dpi, dot_mm=dot_mm,
        radius_scale=radius_scale, dots=dots, page=page, landscape=landscape,
        margin_mm=margin_mm, plotter=plotter, pen_mm=pen_mm, no_overlap=no_overlap)
    # the figures of the dots drawn (their radii on the SVG's grid), or of those capped
    ink = ink_figures(pm, rad if no_overlap else drawn, r * lay["scale"], pen=pen_mm,
                      no_overlap=no_overlap)
    rad = drawn
    order, before, after = pen_path_order(pm, method=pen_path)
    meta = svg_meta(result, lay, rad, pen_mm, invert, layer)
    head = svg_head(lay, svg_size(lay, W, H, width_mm, height_mm, page), meta,
                     _svg_paint(pen_mm, invert), invert)
    draw = _write_svg_file(path, head, pm[order], rad[order], pen_mm)
    info = {"width_mm": lay["picture"][0], "height_mm": lay["picture"][1],
            "page_mm": list(lay["page"]), "n": int(len(p)), "travel_before_mm": before,
            "travel_after_mm": after, "moved_inside": moved, "pen_downs": int(len(p)),
            "draw_mm": draw, **ink,
            "plot_seconds": plot_time(len(p), draw, after, speed_mm_s=plot_speed_mm_s,
                                      pen_lift_s=pen_lift_s)}
    if pen_mm is not None:
        info["pen_touches"] = int(np.count_nonzero(2 * rad <= pen_mm))
    return info


def _drawn_dots(result, *, width_mm=None, height_mm=None, dpi=None, dot_mm=None,
                radius_scale=1.0, dots="tone", page=None, landscape=False, margin_mm=None,
                plotter=None, pen_mm=None, no_overlap=False):
    """The page and the dots of :func:`write_svg`: ``(layout, centres, radii, drawn radii, moved)``.

    Centres on the page and radii in mm; ``radii`` before ``no_overlap``
    and the move inward, ``drawn radii`` after (what the SVG draws).
    """
    p, r, W, H = _arrays(result)
    if pen_mm is not None and not pen_mm > 0:
        raise ValueError(f"pen_mm must be > 0, got {pen_mm}")
    lay = svg_layout(W, H, width_mm=width_mm, height_mm=height_mm, dpi=dpi, page=page,
                     landscape=landscape, margin_mm=margin_mm, plotter=plotter)
    rad = _svg_radii(result, r, lay["scale"], dot_mm, dots, radius_scale)
    check_fit(rad, lay["picture"], pen_mm)
    pm, drawn, moved = place_dots(p, rad, r * lay["scale"], lay, no_overlap=no_overlap,
                                  pen=pen_mm)
    return lay, pm, rad, drawn, moved


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
            text, length = svg_dots(centres[a : a + 100_000], rad[a : a + 100_000], pen_mm)
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
    check_stippling(result, path, packing=False)
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
        check_apart(p * scale, rad, r * scale, pen=pen_px, unit="px")
    if pen_px is not None:
        if not pen_px > 0:
            raise ValueError(f"pen_px must be > 0, got {pen_px}")
        rad = np.maximum(rad, 0.5 * pen_px)
    check_fit(rad, (ow, oh), pen_px, unit="px")
    ink = ink_coverage(p * scale, rad, ow, oh, aa, progress)
    save_png(path, ink if invert else 1.0 - ink)
    return {"width": ow, "height": oh, "n": int(len(p))}


def write_page_png(path, result, *, scale=None, aa=4, progress=None, invert=False, **drawing):
    """Write a PNG of the whole page as :func:`write_svg` lays it out (8-bit gray, or sRGB
    for a colour stippling).

    The paper, a light line just outside its usable area (inside the
    margins and the plotter's reach, :func:`~diskpack_cl.drawing.page.page_frame`),
    and each dot where the SVG draws it, filled as far as its ink reaches:
    its drawn radius, and at least half the pen (a pen touch). The file
    records its dpi, so that it prints at the paper's size.

    Parameters
    ----------
    scale : float, optional
        PNG pixels per image pixel, as for :func:`write_png` (the dots are as
        many pixels wide); default 2.0, at most a :data:`PREVIEW_MAX_PX` px
        long side of the page.
    aa, progress :
        As for :func:`write_png`.
    invert : bool
        Light dots on dark paper, as :func:`write_svg` draws them.
    **drawing
        The options of :func:`write_svg` that lay out the page and size the
        dots (``page``, ``margin_mm``, ``pen_mm``, ``dot_mm``, ...); a colour
        stippling takes those of :func:`diskpack_cl.drawing.color_writers.write_color_svg`.

    Returns
    -------
    dict
        ``width``, ``height`` (output pixels), ``n``, ``dpi``.

    Examples
    --------
    >>> import os, tempfile
    >>> from types import SimpleNamespace
    >>> res = SimpleNamespace(points=np.array([[1.0, 1.0]]), radii=np.array([0.5]), width=4, height=2)
    >>> info = write_page_png(os.path.join(tempfile.mkdtemp(), "page.png"), res, page="20x10mm",
    ...                       margin_mm=2, dpi=25.4, dots="packing", scale=4.0)  # a 4 x 2 mm picture
    >>> info["width"], info["height"], round(info["dpi"], 1)
    (80, 40, 101.6)
    """
    check_stippling(result, path, packing=False)
    lay = svg_layout(float(result.width), float(result.height),
                     **{k: v for k, v in drawing.items() if k in LAYOUT})
    ppm = _page_px_per_mm(lay, scale)
    if getattr(result, "pen", None) is not None:
        from diskpack_cl.drawing.color_writers import write_color_page_png

        return write_color_page_png(path, result, px_per_mm=ppm, aa=aa, progress=progress,
                                    invert=invert, **drawing)
    lay, pm, _, rad, _ = _drawn_dots(result, **drawing)
    line = page_frame(lay, ppm)
    pen = drawing.get("pen_mm")
    ink_rad = rad if pen is None else np.maximum(rad, 0.5 * pen)
    ink = ink_coverage(pm * ppm, ink_rad * ppm, line.shape[1], line.shape[0], int(aa), progress)
    ink = np.maximum(ink, FRAME_INK * line)
    save_png(path, ink if invert else 1.0 - ink, dpi=ppm * MM_PER_INCH)
    return {"width": line.shape[1], "height": line.shape[0], "n": int(len(pm)),
            "dpi": ppm * MM_PER_INCH}


def _page_px_per_mm(lay, scale):
    """PNG pixels per mm of the whole-page preview (``scale``: per image pixel)."""
    pw, ph = (v / lay["scale"] for v in lay["page"])
    return preview_scale(pw, ph, scale) / lay["scale"]


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
    check_stippling(result, path, packing=True)
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
    fields = {"pen": np.asarray(result.pen, np.int64), "pen_names": np.asarray(result.names, str),
              "pen_colors": np.asarray(result.colors, np.float64)}
    if getattr(result, "pen_radius", None) is not None:   # not in a stippling read from an .svg
        fields["pen_radius"] = np.asarray(result.pen_radius, np.float64)
    return fields


def write_csv(path, result):
    """Write ``x,y,r`` rows (pixel units, 17 significant digits: exact round trip).

    The first line is a ``#`` comment without commas (:data:`CSV_TAG`,
    then ``width=W height=H`` and, when known, ``k=`` and ``tone_radius=``,
    and ``invert=1`` for light dots on dark paper), so that
    :func:`read_stipple` reads the stippling back; CSV readers skip it with
    ``comment="#"`` (numpy, pandas).

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
    check_stippling(result, path, packing=True)
    p, r, W, H = _arrays(result)
    tone = getattr(result, "tone_radius", None)
    color = getattr(result, "pen", None) is not None
    invert = bool((getattr(result, "params", None) or {}).get("invert"))
    meta = {"width": int(W), "height": int(H), "k": float(getattr(result, "k", np.nan)),
            "tone_radius": None if tone is None else float(tone),
            # the paper it was made for: an export of the file draws on it (as of an .npz);
            # a colour stippling's pens were separated for one paper, so it always says
            "invert": int(invert) if color or invert else None}
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
    ``x,y,r,pen`` rows (the pen's name); names percent-encoded (:func:`~diskpack_cl.drawing.readers.csv_name`)."""
    from diskpack_cl.multipen import hex_color

    coded = [csv_name(name) for name in result.names]
    pens = ";".join(f"{name}:{hex_color(c)}" for name, c in zip(coded, result.colors))
    if getattr(result, "pen_radius", None) is not None:   # each pen's tone dots' size
        pens += " pen_radius=" + ";".join(f"{v:.17g}" for v in result.pen_radius)
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
        from diskpack_cl.drawing.color_writers import COLOR_WRITERS

        return COLOR_WRITERS[ext](path, result, **opts)
    return WRITERS[ext](path, result, **opts)
