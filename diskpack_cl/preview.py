"""A small picture of a result: what a notebook shows, and :func:`preview` from Python.

Stipplings (:class:`~diskpack_cl.StippleResult`, one pen or several) are
drawn as their writers draw them by default: every dot at its tone size
(``tone_radius``, or each pen's ``pen_radius``) in its pen's colour, on
white paper or, for a stippling made for dark paper, on black. Point sets
(:class:`~diskpack_cl.PoissonDiskResult`, :class:`~diskpack_cl.RelaxResult`)
are drawn as black dots a quarter of their median spacing wide; a 3D set
as the slice of it nearest ``z = 0``, two spacings deep.

The dots are drawn with numpy alone (anti-aliased coverage of each disk,
a dot smaller than a pixel as its area), so a preview of 20 000 dots takes
a few tens of milliseconds; the result classes' ``_repr_png_`` is this
picture as PNG bytes.
"""

from __future__ import annotations

import io

import numpy as np

__all__ = ["PREVIEW_SIZE", "Previewable", "preview", "preview_png"]

#: Pixels of the preview's longer side.
PREVIEW_SIZE = 400

#: Dots drawn in one array operation (with the offsets of a disk's pixels): bounds the memory.
_CHUNK = 1 << 21


def preview(result, size=PREVIEW_SIZE):
    """A picture of a stippling or a point set, `size` pixels on its longer side.

    Parameters
    ----------
    result : StippleResult, ColorStippleResult, PoissonDiskResult or RelaxResult
        Or anything with ``points`` (and, for a stippling, ``radii``,
        ``width`` and ``height``).
    size : int
        Pixels of the longer side (at least 8).

    Returns
    -------
    PIL.Image.Image
        Gray (``"L"``) for one pen and for point sets, RGB for several pens.

    Raises
    ------
    ValueError
        `size` below 8, or `result` has no points to draw.

    Examples
    --------
    >>> from diskpack_cl import stipple
    >>> g = np.tile(np.linspace(0.0, 1.0, 48), (32, 1))
    >>> res = stipple(g, 60, schedule=[("mix", 3, 0.5)], backend="exact")
    >>> im = preview(res)            # or res.preview(); a notebook shows res itself
    >>> im.size, im.mode
    ((400, 267), 'L')
    """
    from PIL import Image  # Pillow is not loaded at start-up

    if not (isinstance(size, (int, np.integer)) and size >= 8):
        raise ValueError(f"preview size must be an integer of at least 8 pixels, got {size!r}")
    points = np.asarray(getattr(result, "points", None), dtype=np.float64)
    if points.ndim != 2 or points.shape[1] not in (2, 3) or not len(points):
        raise ValueError(f"nothing to preview: {type(result).__name__} has no (n, 2) or (n, 3) "
                         "points")
    if hasattr(result, "radii") and hasattr(result, "width"):
        return Image.fromarray(_stippling_pixels(result, size))
    return Image.fromarray(_to_bytes(1.0 - _points_ink(points, getattr(result, "domain", None),
                                                       size)))


def preview_png(result, size=PREVIEW_SIZE):
    """The :func:`preview` of `result` as PNG bytes (a notebook's ``_repr_png_``).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> png = preview_png(SimpleNamespace(points=np.random.default_rng(0).random((500, 2))))
    >>> png[:8] == b"\\x89PNG\\r\\n\\x1a\\n", len(png) < 100_000
    (True, True)
    """
    image, buf = preview(result, size), io.BytesIO()
    if image.mode == "L":   # 16 grays: half the bytes, and a dot's edge still smooth
        from PIL import Image  # Pillow is not loaded at start-up

        levels = (np.asarray(image, dtype=np.uint16) + 8) // 17
        image = Image.fromarray(levels.astype(np.uint8))
        image.save(buf, format="PNG", bits=4, compress_level=3)
    else:
        image.save(buf, format="PNG", compress_level=3)
    return buf.getvalue()


class Previewable:
    """What the result classes share: their picture in a notebook and from Python.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> class Dots(SimpleNamespace, Previewable):
    ...     pass
    >>> Dots(points=np.random.default_rng(0).random((100, 2))).preview(64).size
    (64, 64)
    """

    def preview(self, size=PREVIEW_SIZE):
        """A picture of this result, `size` pixels on its longer side
        (:func:`diskpack_cl.preview.preview`)."""
        return preview(self, size)

    def _repr_png_(self):
        return preview_png(self)


def _frame(width, height, size):
    """``(scale, (h, w))``: preview pixels per unit, and the preview's shape."""
    scale = size / max(width, height)
    return scale, (max(1, int(round(height * scale))), max(1, int(round(width * scale))))


def _stippling_pixels(result, size):
    """The stippling's dots at their drawn size and colour, as an 8-bit array."""
    scale, shape = _frame(result.width, result.height, size)
    centres = np.asarray(result.points, dtype=np.float64) * scale
    dark_paper = bool(getattr(result, "params", {}).get("invert", False))
    pen = getattr(result, "pen", None)
    if pen is None:
        tone = getattr(result, "tone_radius", None)
        radii = np.full(len(centres), tone) if tone is not None else np.asarray(result.radii)
        ink = _coverage(centres, radii * scale, shape)
        return _to_bytes(ink if dark_paper else 1.0 - ink)
    pens = np.asarray(result.pen)
    out = np.zeros(shape + (3,)) if dark_paper else np.ones(shape + (3,))
    for p, colour in enumerate(np.asarray(result.colors, dtype=np.float64)):
        mine = pens == p
        ink = _coverage(centres[mine], np.full(mine.sum(), result.pen_radius[p] * scale),
                        shape)[..., None]
        # inks multiply on white paper; on black the pens' colours add
        out = out + ink * colour if dark_paper else out * (1.0 - ink * (1.0 - colour))
    return _to_bytes(out)


def _points_ink(points, domain, size):
    """The ink of a point set's dots (a 3D set's slice at its bottom) in its `domain` (a
    :class:`~diskpack_cl.domain.Domain`; None: the unit square or the points' box)."""
    if points.shape[1] == 3:
        extent = np.maximum(points.max(axis=0), 1e-300)
        depth = 2.0 * np.cbrt(np.prod(extent) / len(points))
        points = points[points[:, 2] < depth, :2]
    if domain is not None and hasattr(domain, "width"):
        extent = (domain.width, domain.height)
    else:
        extent = np.maximum(points.max(axis=0), 1.0) if len(points) else np.ones(2)
    scale, shape = _frame(extent[0], extent[1], size)
    r = 0.125 * _median_spacing(points) * scale
    return _coverage(points * scale, np.full(len(points), r), shape)


def _median_spacing(points):
    """Median distance from each point to its nearest other point (1 for fewer than two)."""
    if len(points) < 2:
        return 1.0
    from scipy.spatial import cKDTree  # not loaded at start-up

    return float(np.median(cKDTree(points).query(points, k=2)[0][:, 1]))


def _coverage(centres, radii, shape):
    """Ink in [0, 1] per pixel of `shape` of disks (preview pixels): a disk of radius at
    least half a pixel covers ``clip(r + 1/2 - distance)`` of each pixel, a smaller one
    puts its area into the pixel of its centre; overlapping ink adds up to 1 at most."""
    h, w = shape
    ink = np.zeros(h * w)
    small = radii < 0.5
    if small.any():
        _add(ink, centres[small], np.pi * radii[small] ** 2, shape)
    centres, radii = centres[~small], radii[~small]
    if len(radii):
        reach = int(np.ceil(radii.max() + 0.5))
        oy, ox = (o.ravel() for o in np.mgrid[-reach:reach + 1, -reach:reach + 1])
        base = np.floor(centres)
        # float32 distances from each pixel centre: a preview needs no more
        off = (centres - base - 0.5).astype(np.float32)
        rim = (radii + 0.5).astype(np.float32)
        step = max(1, _CHUNK // len(ox))
        for i in range(0, len(radii), step):
            part = slice(i, i + step)
            dist = np.hypot(ox - off[part, :1], oy - off[part, 1:])   # (dots, offsets)
            cover = np.clip(rim[part, None] - dist, 0.0, 1.0)
            dot, k = np.nonzero(cover)
            _add(ink, base[part][dot] + np.column_stack([ox[k], oy[k]]), cover[dot, k], shape)
    return np.minimum(ink, 1.0).reshape(h, w)


def _add(ink, where, amount, shape):
    """Add `amount` to the pixels holding the points `where` (x, y)."""
    h, w = shape
    ix, iy = np.floor(where).astype(np.int64).T
    inside = (ix >= 0) & (ix < w) & (iy >= 0) & (iy < h)
    ink += np.bincount(iy[inside] * w + ix[inside], weights=amount[inside], minlength=h * w)


def _to_bytes(values):
    """Values in [0, 1] as 8-bit pixels."""
    return np.round(np.clip(values, 0.0, 1.0) * 255.0).astype(np.uint8)
