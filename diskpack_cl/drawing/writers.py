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

import numpy as np

from diskpack_cl.drawing.page import (FRAME_INK, MM_PER_INCH, check_fit, check_size, ink_coverage,
                                      mm_per_px, page_frame, place_dots, save_png, svg_dots,
                                      svg_head, svg_layout, svg_meta, svg_size)
from diskpack_cl.drawing.write_options import (WriteOptions, check_preview_memory, plot_seconds,
                                               preview_scale, write_options)
from diskpack_cl.io import atomic_write, check_writable
from diskpack_cl.drawing.overlap import cap_radii, check_apart, ink_figures
from diskpack_cl.drawing.pen_path import path_travel, pen_path_order
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


def tone_dot_count(darkness, scale, dot_mm):
    """The number of dots ``dot_mm`` wide whose ink equals the image's on paper.

    ``darkness`` is per pixel in [0, 1], or its sum over the image (a
    number); ``scale`` mm per pixel. Fewer than 2 dots is a ``ValueError``
    (the dots are too large for the ink).

    Examples
    --------
    >>> tone_dot_count(np.full((100, 100), 0.5), 1.0, 2.0)  # 5000 mm^2 of ink
    1592
    >>> tone_dot_count(5000.0, 1.0, 2.0)
    1592
    """
    ink_mm2 = float(np.sum(darkness)) * scale * scale
    count = ink_mm2 / (0.25 * np.pi * dot_mm * dot_mm)
    if count < 2:
        raise ValueError(f"the image's ink holds {count:.2g} dots {dot_mm:g} mm wide, fewer than "
                         f"2: give a smaller --dot-mm or -n N")
    return int(round(count))


#: Label of the layer of the dots in :func:`write_svg`.
LAYER = "stipples"


def write_svg(path, result, options=None, *, layer=LAYER, **overrides):
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
    options : WriteOptions, optional
        How the dots are drawn. Among them: the picture's size (``width_mm``,
        ``height_mm``, ``dpi``: :func:`mm_per_px`; with ``page``, by default
        fitted inside the margins); ``dot_mm``, a fixed dot diameter, or
        ``dots`` (``"tone"``: one size, ``result.tone_radius``, ink = the
        image's darkness; ``"packing"``: the certified disks) times
        ``radius_scale``; ``pen_path`` (:func:`~diskpack_cl.drawing.pen_path.pen_path_order`);
        ``invert`` (white dots on black paper: a black image in the layer
        ``% paper (not plotted)``, which vpype and plotters skip); the paper and
        what of it the plotter reaches (``page``, ``landscape``,
        ``margin_mm``, ``plotter``: :func:`svg_layout`); the plot-time
        estimate's ``plot_speed_mm_s`` and ``pen_lift_s`` (:func:`~diskpack_cl.drawing.page.plot_time`);
        ``no_overlap`` (no two drawn dots touch: each at most its packing disk,
        :func:`~diskpack_cl.drawing.overlap.cap_radii`; dots that still touch, a pen
        wider than the disks, are refused: :func:`~diskpack_cl.drawing.overlap.check_apart`).
    layer : str
        The Inkscape layer's label.
    **overrides
        Fields of :class:`WriteOptions` replacing those of `options`.

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
    o = write_options(options, **overrides)
    check_stippling(result, path, packing=False)
    p, r, W, H = _arrays(result)
    lay, pm, rad, drawn, moved = _drawn_dots(result, o)
    # the figures of the dots drawn (their radii on the SVG's grid), or of those capped
    ink = ink_figures(pm, rad if o.no_overlap else drawn, r * lay["scale"], pen=o.pen_mm,
                      no_overlap=o.no_overlap)
    rad = drawn
    order, before, after = pen_path_order(pm, method=o.pen_path)
    meta = svg_meta(result, lay, rad, o.pen_mm, o.invert, layer)
    head = svg_head(lay, svg_size(lay, W, H, o.width_mm, o.height_mm, o.page), meta,
                    _svg_paint(o.pen_mm, o.invert), o.invert)
    draw = _write_svg_file(path, head, pm[order], rad[order], o.pen_mm)
    info = {"width_mm": lay["picture"][0], "height_mm": lay["picture"][1],
            "page_mm": list(lay["page"]), "n": int(len(p)), "travel_before_mm": before,
            "travel_after_mm": after, "moved_inside": moved, "pen_downs": int(len(p)),
            "draw_mm": draw, **ink, "plot_seconds": plot_seconds(o, len(p), draw, after)}
    if o.pen_mm is not None:
        info["pen_touches"] = int(np.count_nonzero(2 * rad <= o.pen_mm))
    return info


def _drawn_dots(result, o):
    """The page and the dots of :func:`write_svg`: ``(layout, centres, radii, drawn radii, moved)``.

    Centres on the page and radii in mm; ``radii`` before ``no_overlap``
    and the move inward, ``drawn radii`` after (what the SVG draws).
    """
    p, r, W, H = _arrays(result)
    lay = svg_layout(W, H, **o.layout())
    rad = _svg_radii(result, r, lay["scale"], o)
    check_fit(rad, lay["picture"], o.pen_mm)
    pm, drawn, moved = place_dots(p, rad, r * lay["scale"], lay, no_overlap=o.no_overlap,
                                  pen=o.pen_mm)
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


def _svg_radii(result, radii, scale, o):
    """Drawn radius per dot in mm: ``dot_mm / 2``, else :func:`_dot_radii`."""
    if o.dot_mm is None:
        return _dot_radii(result, radii, scale, o.dot_kind, o.radius_scale)
    return np.full(len(radii), 0.5 * float(o.dot_mm))


def write_png(path, result, options=None, *, aa=4, progress=None, **overrides):
    """Write an anti-aliased PNG preview (8-bit gray).

    Each output pixel's ink is the fraction of its ``aa x aa`` sample
    points that fall inside a dot (stratified super-sampling of the exact
    disks, no rounding of centres or radii).

    Parameters
    ----------
    options : WriteOptions, optional
        The dots as :func:`write_svg` draws them (``dots``, ``dot_mm``,
        ``radius_scale``, ``no_overlap``; ``invert``: white dots on black;
        ``pen_mm``: what the pen draws, a dot narrower than the pen as a pen
        touch, a wider one filled), at ``png_scale`` PNG pixels per image
        pixel (:meth:`WriteOptions.png_pixels`).
    aa : int, optional
        Samples per output pixel side.
    progress : callable, optional
        ``progress(k)`` after each ``k`` dots stamped (a progress bar).
    **overrides
        Fields of :class:`WriteOptions` replacing those of `options`.

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
    >>> info = write_png(path, res, png_scale=4.0, dots="packing")
    >>> with Image.open(path) as im:
    ...     im.size
    (16, 8)
    """
    o = write_options(options, **overrides)
    check_stippling(result, path, packing=False)
    p, r, W, H = _arrays(result)
    aa = int(aa)
    if aa < 1:
        raise ValueError(f"aa must be >= 1, got {aa}")
    scale, dot_px, pen_px = o.png_pixels(W, H)
    ow, oh = max(1, int(round(W * scale))), max(1, int(round(H * scale)))
    rad = (np.full(len(p), dot_px) if dot_px is not None
           else _dot_radii(result, r, scale, o.dot_kind, o.radius_scale))
    if o.no_overlap:
        rad = cap_radii(rad, r * scale)
        check_apart(p * scale, rad, r * scale, pen=pen_px, unit="px")
    if pen_px is not None:
        rad = np.maximum(rad, 0.5 * pen_px)
    check_fit(rad, (ow, oh), pen_px, unit="px")
    ink = ink_coverage(p * scale, rad, ow, oh, aa, progress)
    save_png(path, ink if o.invert else 1.0 - ink)
    return {"width": ow, "height": oh, "n": int(len(p))}


def write_page_png(path, result, options=None, *, aa=4, progress=None, **overrides):
    """Write a PNG of the whole page as :func:`write_svg` lays it out (8-bit gray, or sRGB
    for a colour stippling).

    The paper, a light line just outside its usable area (inside the
    margins and the plotter's reach, :func:`~diskpack_cl.drawing.page.page_frame`),
    and each dot where the SVG draws it, filled as far as its ink reaches:
    its drawn radius, and at least half the pen (a pen touch). The file
    records its dpi, so that it prints at the paper's size.

    Parameters
    ----------
    options : WriteOptions, optional
        The page and the dots as :func:`write_svg` draws them (a colour
        stippling: :func:`~diskpack_cl.drawing.color_writers.write_color_svg`),
        ``png_scale`` PNG pixels per image pixel (default 2.0, at most a
        :data:`~diskpack_cl.drawing.write_options.PREVIEW_MAX_PX` px long side of the page).
    aa, progress :
        As for :func:`write_png`.
    **overrides
        Fields of :class:`WriteOptions` replacing those of `options`.

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
    ...                       margin_mm=2, dpi=25.4, dots="packing", png_scale=4.0)  # 4 x 2 mm
    >>> info["width"], info["height"], round(info["dpi"], 1)
    (80, 40, 101.6)
    """
    o = write_options(options, **overrides)
    check_stippling(result, path, packing=False)
    lay = svg_layout(float(result.width), float(result.height), **o.layout())
    ppm = _page_px_per_mm(lay, o.png_scale)
    if getattr(result, "pen", None) is not None:
        from diskpack_cl.drawing.color_writers import write_color_page_png

        return write_color_page_png(path, result, o, px_per_mm=ppm, aa=aa, progress=progress)
    lay, pm, _, rad, _ = _drawn_dots(result, o)
    line = page_frame(lay, ppm)
    ink_rad = rad if o.pen_mm is None else np.maximum(rad, 0.5 * o.pen_mm)
    ink = ink_coverage(pm * ppm, ink_rad * ppm, line.shape[1], line.shape[0], int(aa), progress)
    ink = np.maximum(ink, FRAME_INK * line)
    save_png(path, ink if o.invert else 1.0 - ink, dpi=ppm * MM_PER_INCH)
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
        # not compressed: float64 coordinates and radii shrink by 8 % in zlib, which takes
        # 1.2 s for a million dots against 0.04 s
        np.savez(fh, **data)
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


def write_stipple(path, result, options=None, *, progress=None, **overrides):
    """Write ``result`` in the format named by the extension of ``path``: the one route of
    every output, mono and colour.

    ``.svg`` (:func:`write_svg`; a colour stippling:
    :func:`~diskpack_cl.drawing.color_writers.write_color_svg`), ``.png``
    (:func:`write_png`, :func:`~diskpack_cl.drawing.color_writers.write_color_png`;
    ``preview="page"``: :func:`write_page_png`), ``.npz`` (:func:`write_npz`),
    ``.csv`` (:func:`write_csv`). Returns the writer's info dict.

    Parameters
    ----------
    options : WriteOptions, optional
        How the dots are drawn (the SVG and PNG writers read it).
    progress : callable, optional
        ``progress(k)`` after each ``k`` dots a PNG writer stamped.
    **overrides
        Fields of :class:`WriteOptions` replacing those of `options`.

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
    o = write_options(options, **overrides)
    if ext in (".npz", ".csv"):
        return WRITERS[ext](path, result)
    if ext == ".png":
        if o.preview == "page":
            return write_page_png(path, result, o, progress=progress)
        return _writers_of(result)[ext](path, result, o, progress=progress)
    return _writers_of(result)[ext](path, result, o)


def _writers_of(result):
    """The SVG and PNG writers of a mono or a colour (``result.pen``) stippling."""
    if getattr(result, "pen", None) is None:
        return WRITERS
    from diskpack_cl.drawing.color_writers import COLOR_WRITERS

    return COLOR_WRITERS
