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
from types import SimpleNamespace

import numpy as np

from diskpack_cl.io import atomic_write, check_writable

__all__ = [
    "WRITERS",
    "check_output_path",
    "mm_per_px",
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


# --------------------------------------------------------------------------
# Pen path
# --------------------------------------------------------------------------


def path_travel(points, order=None, *, start=(0.0, 0.0)):
    """Pen-up travel: from ``start`` through the points in ``order``.

    Examples
    --------
    >>> path_travel([[3.0, 4.0], [3.0, 0.0]])
    9.0
    """
    p = np.asarray(points, dtype=np.float64)
    if order is not None:
        p = p[np.asarray(order)]
    if len(p) == 0:
        return 0.0
    q = np.vstack([np.asarray(start, dtype=np.float64)[None, :], p])
    return float(np.sum(np.hypot(*np.diff(q, axis=0).T)))


def _hilbert_index(ix, iy, order):
    """Hilbert-curve index of integer cells (vectorized; cells in [0, 2^order))."""
    ix = ix.astype(np.int64).copy()
    iy = iy.astype(np.int64).copy()
    d = np.zeros_like(ix)
    s = 1 << (order - 1)
    while s > 0:
        rx = (ix & s) > 0
        ry = (iy & s) > 0
        d += s * s * ((3 * rx) ^ ry)
        # rotate the quadrant
        flip = ~ry
        swap_x = np.where(flip & rx, s - 1 - ix, ix)
        swap_y = np.where(flip & rx, s - 1 - iy, iy)
        ix = np.where(flip, swap_y, swap_x)
        iy = np.where(flip, swap_x, swap_y)
        ix &= s - 1
        iy &= s - 1
        s >>= 1
    return d


def _hilbert_order(p):
    lo = p.min(axis=0)
    span = max(float(np.max(p.max(axis=0) - lo)), 1e-300)
    order = 16
    cells = (1 << order) - 1
    ix = np.floor((p[:, 0] - lo[0]) / span * cells).astype(np.int64)
    iy = np.floor((p[:, 1] - lo[1]) / span * cells).astype(np.int64)
    return np.argsort(_hilbert_index(ix, iy, order), kind="stable")


def _greedy_order(p, start):
    """Greedy nearest-neighbour tour with a cKDTree of the unvisited points.

    The tree is rebuilt whenever half of its points have been visited, so a
    query for the 16 nearest almost always finds an unvisited one.
    """
    from scipy.spatial import cKDTree

    n = len(p)
    visited = np.zeros(n, dtype=bool)
    order = np.empty(n, dtype=np.int64)
    alive = np.arange(n)
    tree = cKDTree(p)
    cur = np.asarray(start, dtype=np.float64)
    in_tree = n
    for step in range(n):
        if step and (n - step) * 2 < in_tree:
            alive = np.flatnonzero(~visited)
            tree = cKDTree(p[alive])
            in_tree = alive.size
        kq = min(16, in_tree)
        while True:
            _, j = tree.query(cur, k=kq)
            j = np.atleast_1d(j)
            cand = alive[j]
            free = cand[~visited[cand]]
            if free.size or kq >= in_tree:
                break
            kq = min(kq * 4, in_tree)
        nxt = int(free[0])
        visited[nxt] = True
        order[step] = nxt
        cur = p[nxt]
    return order


def pen_path_order(points, *, method="auto", start=(0.0, 0.0)):
    """Order the dots along a short pen path.

    Parameters
    ----------
    points : (n, 2) array_like
    method : {"auto", "greedy", "hilbert", "none"}
        ``"greedy"``: nearest unvisited dot next (cKDTree), about 10% shorter
        than a Hilbert order on uniform points but a Python loop (about 40 us per dot);
        ``"hilbert"``: sort along a Hilbert curve (vectorized);
        ``"auto"``: greedy up to 100 000 dots, else Hilbert.
    start : (2,) array_like
        Where the pen starts (the SVG origin by default).

    Returns
    -------
    order : (n,) int64
        A permutation of ``range(n)``.
    travel_before, travel_after : float
        Pen-up travel (same units as ``points``) in the given order and in
        the new order, both from ``start``.

    Examples
    --------
    >>> import numpy as np
    >>> p = np.random.default_rng(0).random((500, 2))
    >>> order, before, after = pen_path_order(p)
    >>> sorted(order) == list(range(500)), after < before
    (True, True)
    """
    p = np.asarray(points, dtype=np.float64)
    n = len(p)
    if method not in ("auto", "greedy", "hilbert", "none"):
        raise ValueError(f"pen path method must be auto, greedy, hilbert or none, got {method!r}")
    before = path_travel(p, start=start)
    if n < 2 or method == "none":
        return np.arange(n), before, before
    if method == "auto":
        method = "greedy" if n <= 100_000 else "hilbert"
    order = _greedy_order(p, start) if method == "greedy" else _hilbert_order(p)
    return order, before, path_travel(p, order, start=start)


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
    :func:`diskpack_cl.analysis.tone_radius`); ``"packing"``: each dot its
    certified packing radius. Both times ``radius_scale``.
    """
    if dots not in DOTS:
        raise ValueError(f"dots must be 'tone' or 'packing', got {dots!r}")
    if not radius_scale > 0:
        raise ValueError(f"radius_scale must be > 0, got {radius_scale}")
    if dots == "packing":
        return radii * scale * float(radius_scale)
    tone = getattr(result, "tone_radius", None)
    if tone is None:
        raise ValueError("dots='tone' needs the result's tone_radius (a StippleResult has "
                         "it); pass dots='packing' or a fixed dot size")
    return np.full(len(radii), float(tone) * scale * float(radius_scale))


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
    if width_mm is not None or height_mm is not None:
        if dpi is not None:
            raise ValueError("give the physical size either by width_mm/height_mm or by dpi, not both")
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


def _fmt(v):
    return np.char.mod("%.4f", v)


def write_svg(
    path,
    result,
    *,
    width_mm=None,
    height_mm=None,
    dpi=None,
    dot_mm=None,
    radius_scale=1.0,
    pen_path="auto",
    layer="stipples",
    invert=False,
    pen_mm=None,
    dots="tone",
):
    """Write an SVG for pen plotters and Inkscape.

    The dots are ``<circle>`` elements in one Inkscape layer
    (``<g inkscape:groupmode="layer">``), user units are millimetres, and
    the document has the exact physical size of the image: ``width="..px"``
    (CSS pixels, 1/96 inch) when the size comes from ``dpi``, else
    ``width="..mm"``.

    Every dot lies inside the page: a dot that would stick out past an edge
    (its centre closer to the edge than its radius) is moved inward until it
    touches the edge, keeping its size (a dot wider than the page shrinks to
    it).  Only border dots move, by less than their radius.

    Plotting: a pen plotter traces each ``<circle>`` once along its outline,
    so a dot drawn with a pen of width W comes out its diameter plus W
    across.  With ``pen_mm=W`` the circles are outlines (``stroke-width`` W,
    no fill) of radius ``(dot diameter - W) / 2``, so the traced dot is the
    dot's size; a dot not wider than the pen becomes one pen touch (a path
    0.01 mm long, round caps).  Without ``pen_mm`` the circles are filled
    (for Inkscape and screens, or a plotter set to fill shapes).

    Parameters
    ----------
    width_mm, height_mm : float, optional
        Physical size; with both, the drawing fits inside the box keeping
        its aspect ratio.
    dpi : float, optional
        Physical size from the image's pixels (default 96 dpi, CSS pixels),
        when neither width_mm nor height_mm is given.
    dot_mm : float, optional
        Fixed dot diameter in mm, instead of ``dots``.
    radius_scale : float, optional
        Factor on the radii of ``dots``.
    pen_path : {"auto", "greedy", "hilbert", "none"}
        Dot order; see :func:`pen_path_order`.
    invert : bool, optional
        White dots on a black background rectangle.
    pen_mm : float, optional
        The plotter pen's line width in mm (see above).
    dots : {"tone", "packing"}
        Dot size (without ``dot_mm``): ``"tone"`` (default, as ``diskpack
        stipple`` draws) one size for all dots, chosen so that their ink is
        the image's darkness (``result.tone_radius``); ``"packing"`` each dot
        its certified packing disk (large where the image is light: it shows
        the packing, nearly the inverse of the tone).

    Returns
    -------
    dict
        ``width_mm``, ``height_mm``, ``n``, ``travel_before_mm``,
        ``travel_after_mm`` (pen-up travel from the origin), ``moved_inside``
        (dots moved inside the page) and, with ``pen_mm``, ``pen_touches``
        (dots drawn as one touch).

    Examples
    --------
    >>> import tempfile, os, types, numpy as np
    >>> res = types.SimpleNamespace(points=np.array([[0.0, 8.0], [8.0, 8.0]]),
    ...                             radii=np.array([1.0, 1.0]), width=16, height=16,
    ...                             tone_radius=1.0)
    >>> out = os.path.join(tempfile.mkdtemp(), "dots.svg")
    >>> info = write_svg(out, res, dpi=25.4, pen_mm=0.5)
    >>> info["moved_inside"], info["pen_touches"]
    (1, 0)
    >>> [line.strip() for line in Path(out).read_text().splitlines() if "<circle" in line][0]
    '<circle cx="1.0052" cy="8.0000" r="0.7500"/>'
    """
    p, r, W, H = _arrays(result)
    if pen_mm is not None and not pen_mm > 0:
        raise ValueError(f"pen_mm must be > 0, got {pen_mm}")
    s = mm_per_px(W, H, width_mm, height_mm, dpi)
    if dot_mm is not None:
        if not dot_mm > 0:
            raise ValueError(f"dot_mm must be > 0, got {dot_mm}")
        rad = np.full(len(p), 0.5 * float(dot_mm))
    else:
        rad = _dot_radii(result, r, s, dots, radius_scale)
    wmm, hmm = W * s, H * s
    pm, rad, moved = _inside_page(p * s, rad, wmm, hmm)
    order, before, after = pen_path_order(pm, method=pen_path)
    fg, bg = ("white", "black") if invert else ("black", None)
    if width_mm is None and height_mm is None:  # exact in CSS pixels (1/96 in)
        size = f'width="{W * s / MM_PER_INCH * 96:.10g}px" height="{H * s / MM_PER_INCH * 96:.10g}px"'
    else:
        size = f'width="{wmm:.10g}mm" height="{hmm:.10g}mm"'
    head = [
        '<?xml version="1.0" encoding="UTF-8" standalone="no"?>',
        '<svg xmlns="http://www.w3.org/2000/svg"',
        '     xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"',
        '     xmlns:sodipodi="http://sodipodi.sourceforge.net/DTD/sodipodi-0.dtd"',
        f'     {size} viewBox="0 0 {wmm:.10g} {hmm:.10g}"',
        '     version="1.1">',
        '  <sodipodi:namedview inkscape:document-units="mm"/>',
    ]
    if bg:
        head.append(f'  <rect x="0" y="0" width="{wmm:.10g}" height="{hmm:.10g}" fill="{bg}"/>')
    paint = (f'fill="{fg}" stroke="none"' if pen_mm is None else
             f'fill="none" stroke="{fg}" stroke-width="{pen_mm:.4f}" stroke-linecap="round"')
    head.append(
        f'  <g inkscape:groupmode="layer" inkscape:label="{layer}" id="layer1" {paint}>'
    )
    touch = np.zeros(len(p), bool) if pen_mm is None else 2.0 * rad <= pen_mm
    drawn = rad if pen_mm is None else rad - 0.5 * pen_mm
    with atomic_write(path, "w") as fh:
        fh.write("\n".join(head) + "\n")
        chunk = 100_000
        for a in range(0, len(order), chunk):
            o = order[a : a + chunk]
            fh.write(_svg_dots(pm[o], drawn[o], touch[o]))
        fh.write("  </g>\n</svg>\n")
    info = {
        "width_mm": wmm,
        "height_mm": hmm,
        "n": int(len(p)),
        "travel_before_mm": before,
        "travel_after_mm": after,
        "moved_inside": moved,
    }
    if pen_mm is not None:
        info["pen_touches"] = int(touch.sum())
    return info


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


def _svg_dots(c, r, touch):
    """``<circle>`` lines, and for ``touch`` dots a 0.01 mm path (one pen touch)."""
    x, y = c[:, 0], c[:, 1]
    circles = _join('    <circle cx="', _fmt(x), '" cy="', _fmt(y), '" r="', _fmt(r), '"/>\n')
    touches = _join('    <path d="M ', _fmt(x - 0.5 * _TOUCH_MM), ',', _fmt(y),
                    f' h {_TOUCH_MM}"/>\n')
    return "".join(np.where(touch, touches, circles).tolist())


def _join(*parts):
    out = parts[0]
    for part in parts[1:]:
        out = np.char.add(out, part)
    return out


def _coverage(c, rad, ow, oh, aa):
    """Ink coverage in [0, 1] per output pixel: fraction of aa x aa samples in a disk.

    Dots are stamped in windows of their own size (grouped by size, in
    chunks), and the coverages are summed with ``np.add.at``: exact sample
    counts for disjoint disks; overlapping dots (fixed or enlarged dot sizes)
    are summed and clipped at 1.
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
    return np.minimum(ink, 1.0).reshape(oh, ow)


def write_png(path, result, *, scale=1.0, radius_scale=1.0, dot_px=None, invert=False, aa=4,
              dots="tone"):
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

    Returns
    -------
    dict
        ``width``, ``height`` (output pixels), ``n``.
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
    ink = _coverage(p * scale, rad, ow, oh, aa)
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

    Also ``base_radii`` and a JSON ``params`` string when the result has them,
    and ``certificate_<field>`` for each scalar field of the certificate.
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
    """Write ``x,y,r`` rows (pixel units, 17 significant digits: exact round trip);
    a colour stippling adds a ``pen`` column (the pen's name)."""
    p, r, _, _ = _arrays(result)
    with atomic_write(path, "w") as fh:
        if getattr(result, "pen", None) is not None:
            rows = np.char.mod("%.17g", np.column_stack([p, r])).tolist()
            pens = np.asarray(result.names)[result.pen].tolist()
            fh.write("x,y,r,pen\n" + "".join(",".join(row + [q]) + "\n" for row, q in zip(rows, pens)))
            return {"n": int(len(p))}
        fh.write("x,y,r\n")
        np.savetxt(fh, np.column_stack([p, r]), fmt="%.17g", delimiter=",")
    return {"n": int(len(p))}


WRITERS = {".svg": write_svg, ".png": write_png, ".npz": write_npz, ".csv": write_csv}


def check_output_path(path):
    """Raise before any work if ``path`` cannot be written by :func:`write_stipple`.

    Raises
    ------
    ValueError
        Unknown extension (the message lists the supported ones), ``path`` is
        a folder, or its folder is not writable (a probe file is created
        there and removed, see :func:`diskpack_cl.io.check_writable`).
    FileNotFoundError
        The output directory does not exist.
    """
    path = Path(os.fspath(path))
    ext = path.suffix.lower()
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
    """
    ext = check_output_path(path)
    if getattr(result, "pen", None) is not None and ext in (".svg", ".png"):
        from diskpack_cl.color_export import COLOR_WRITERS

        return COLOR_WRITERS[ext](path, result, **opts)
    return WRITERS[ext](path, result, **opts)


def _read_pens(z):
    """A colour stippling's ``pen``, ``names``, ``colors``, ``pen_radius`` from an open .npz."""
    if "pen" not in z.files:
        return {}
    return {"pen": np.asarray(z["pen"], np.int64), "names": tuple(str(v) for v in z["pen_names"]),
            "colors": np.asarray(z["pen_colors"], np.float64),
            "pen_radius": np.asarray(z["pen_radius"], np.float64)}


def read_stipple(path):
    """Read a stippling ``.npz`` written by :func:`write_stipple` (:func:`write_npz`).

    Parameters
    ----------
    path : str or Path
        A ``.npz`` file.

    Returns
    -------
    types.SimpleNamespace or None
        ``points`` ((n, 2) float64, pixels), ``radii`` ((n,) float64),
        ``width`` and ``height`` (int pixels), ``k`` (float, nan when not
        stored), ``base_radii`` (or None) and ``params`` (a dict, empty when
        not stored or unreadable): a result :func:`write_stipple` writes
        again; a colour stippling also has ``pen``, ``names``, ``colors``
        and ``pen_radius`` (see :class:`diskpack_cl.multipen.ColorStippleResult`).
        None when the ``.npz`` lacks ``points``, ``radii``, ``width``
        or ``height`` (a point set, as :func:`diskpack_cl.io.write_points`
        writes it). The certificate is not read back: check the disks again
        with :func:`diskpack_cl.certify_disks`.

    Raises
    ------
    FileNotFoundError
        ``path`` does not exist.
    ValueError
        ``path`` is not a readable ``.npz`` file.

    Examples
    --------
    >>> import os, tempfile
    >>> res = SimpleNamespace(points=np.array([[2.0, 3.0]]), radii=np.array([1.0]),
    ...                       width=8, height=6)
    >>> out = os.path.join(tempfile.mkdtemp(), "s.npz")
    >>> write_stipple(out, res)
    {'n': 1}
    >>> back = read_stipple(out)
    >>> back.points.tolist(), back.width, back.height
    ([[2.0, 3.0]], 8, 6)
    """
    try:
        with np.load(path, allow_pickle=False) as z:
            if not {"points", "radii", "width", "height"} <= set(z.files):
                return None
            params = {}
            if "params" in z.files:
                try:
                    params = json.loads(str(z["params"]))
                except ValueError:
                    params = {}
            return SimpleNamespace(
                points=np.asarray(z["points"], np.float64), radii=np.asarray(z["radii"], np.float64),
                width=int(z["width"]), height=int(z["height"]),
                k=float(z["k"]) if "k" in z.files else float("nan"),
                base_radii=np.asarray(z["base_radii"], np.float64) if "base_radii" in z.files else None,
                params=params, **_read_pens(z))
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such file") from None
    except (OSError, ValueError, EOFError) as exc:
        raise ValueError(f"{path}: unreadable .npz file: {exc}") from None
