"""How a stippling is drawn: :class:`WriteOptions`, the one options object of every
writer (mono and colour, SVG and PNG), and what follows from it alone (the PNG's pixels,
the plot time, the preview's memory).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..memory import check_png_memory
from ..options import OptionConflict, check_fields, option
from .page import (DEFAULT_MARGIN_MM, PAPERS, PEN_LIFT_S, PLOT_SPEED_MM_S, check_size,
                   paper_size, plot_time, svg_layout)
from .pen_path import PEN_PATHS, TWO_OPT_WORK

__all__ = ["LAYOUT", "PREVIEWS", "PREVIEW_MAX_PX", "WriteOptions", "check_preview_memory",
           "plot_seconds", "preview_scale", "write_options"]

_OUTPUT = "output"

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
        return replace(self, **overrides) if overrides else self

    @property
    def dot_kind(self):
        """``dots``, or ``"tone"`` where neither it nor ``dot_mm`` is given."""
        return self.dots or "tone"

    def png_pixels(self, width, height):
        """``(scale, dot_px, pen_px)`` of a PNG preview of a `width` x `height` picture: its
        pixels per image pixel (:func:`preview_scale`), and the ``dot_mm`` dots' radius and
        the pen's width in its pixels (None where not given).

        Examples
        --------
        >>> WriteOptions(dpi=25.4, dot_mm=2.0, png_scale=3).png_pixels(10, 10)
        (3.0, 3.0, None)
        """
        scale = preview_scale(width, height, self.png_scale)
        if self.dot_mm is None and self.pen_mm is None:
            return scale, None, None
        mm = self.scale(width, height)
        return (scale, None if self.dot_mm is None else 0.5 * self.dot_mm / mm * scale,
                None if self.pen_mm is None else self.pen_mm / mm * scale)


def write_options(options=None, **overrides):
    """``options`` (None: the defaults) with the fields `overrides`: what every writer reads.

    Examples
    --------
    >>> write_options(WriteOptions(dpi=300), pen_mm=0.3).pen_mm
    0.3
    """
    return (options or WriteOptions()).replace(**overrides)


def plot_seconds(options, dots, draw_mm, travel_mm):
    """:func:`plot_time` at the speed and pen lift of `options`."""
    return plot_time(dots, draw_mm, travel_mm, speed_mm_s=options.plot_speed_mm_s,
                     pen_lift_s=options.pen_lift_s)
