"""Stipple radii: the radius mappings (gray, density) and the certified scale ``k``.

A point's base radius ``r_i`` is the value of a radius field at its pixel;
its disk is ``k r_i``.  :func:`largest_valid_k` is the largest ``k`` for which
all disks lie inside the image and are pairwise disjoint, and
:func:`certified_k` checks it with :func:`diskpack_cl.geometry.certify_disks`.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from ._cores import on_cores
from .geometry import CertificateError, certify_disks, radius_octaves

__all__ = ["base_radii", "radius_field", "density_radius", "detail_scale", "detail_ell", "detail_fields",
           "detail_sigmas", "detail_blend", "detail_weight", "dilation_radius", "DETAIL_GAIN", "DETAIL_FINE", "disk_dilation", "field_at",
           "fields_at", "largest_valid_k", "certified_k", "in_bands", "gaussian_blur", "blurs", "median_above",
           "TRUNCATE"]

#: Gaussian blurs reach ``int(TRUNCATE * sigma + 0.5)`` pixels (scipy.ndimage's default).
TRUNCATE = 4.0


def in_bands(func, image, reach, *, rows=512):
    """``func(image)`` for a filter `func` that reaches `reach` rows, in bands of rows on
    every core: the same values.

    Each band is filtered with `reach` rows of the image on either side of it
    and keeps its own rows, so that it sees what the whole image's filter
    sees (scipy.ndimage's filters release the GIL); an image of fewer than
    four bands is filtered whole.  The filter must make each value from the
    pixels within its reach alone, as a correlation or a maximum does (a
    running sum along the columns, as ``uniform_filter``'s, would round
    differently from a band's first row).

    Examples
    --------
    >>> a = np.random.default_rng(0).random((2000, 30))
    >>> f = lambda x: ndimage.maximum_filter(x, 5, mode="reflect")
    >>> bool(np.array_equal(in_bands(f, a, 2, rows=100), f(a)))
    True
    """
    H = image.shape[0]
    if H < 4 * rows:
        return func(image)
    out = np.empty(image.shape, np.float64)

    def band(y0):
        y1 = min(y0 + rows, H)
        lo, hi = max(y0 - reach, 0), min(y1 + reach, H)
        out[y0:y1] = func(image[lo:hi])[y0 - lo:y1 - lo]

    with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
        list(pool.map(band, range(0, H, rows)))
    return out


def gaussian_blur(image, sigma, *, cols=64, rows=512):
    """``scipy.ndimage.gaussian_filter(image, sigma, mode="reflect")`` of a float64 image, the
    same values, faster on a large image and on every core.

    scipy's filter blurs along the columns, then along the rows, each pass
    in place of the last.  Here the column pass runs on copies of bands of
    `cols` columns, so that it walks a few MiB instead of the whole image
    (scipy's own column pass strides across it), and both passes run in
    bands on a thread pool (scipy.ndimage releases the GIL); every value is
    made from the same pixels in the same order as scipy's.

    Examples
    --------
    >>> a = np.random.default_rng(0).random((300, 200))
    >>> blur = gaussian_blur(a, 2.0, cols=16, rows=32)
    >>> bool(np.array_equal(blur, ndimage.gaussian_filter(a, 2.0, mode="reflect")))
    True
    """
    image = np.asarray(image, np.float64)
    if not float(sigma) > 1e-15:   # as scipy: no blur
        return image.copy()
    out = np.empty(image.shape)
    H, W = image.shape
    blur = dict(sigma=float(sigma), mode="reflect", truncate=TRUNCATE)

    def column_band(c0):
        band = np.ascontiguousarray(image[:, c0:c0 + cols])
        out[:, c0:c0 + cols] = ndimage.gaussian_filter1d(band, axis=0, **blur)

    def row_band(r0):
        part = out[r0:r0 + rows]
        ndimage.gaussian_filter1d(part, axis=1, output=part, **blur)

    with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
        list(pool.map(column_band, range(0, W, cols)))
        list(pool.map(row_band, range(0, H, rows)))
    return out


def blurs(blur, image, sigmas):
    """``[blur(image, s) for s in sigmas]``: a blur's ``many`` where it has one (a
    :class:`~diskpack_cl.device.blur.DeviceBlur` sends `image` to its device once).

    Examples
    --------
    >>> a = np.random.default_rng(0).random((20, 30))
    >>> fine, coarse = blurs(gaussian_blur, a, [0.5, 2.0])
    >>> bool(np.array_equal(coarse, gaussian_blur(a, 2.0)))
    True
    """
    many = getattr(blur, "many", None)
    return many(image, sigmas) if many is not None else [blur(image, s) for s in sigmas]


def _pixel_of(points, W, H):
    # the cast truncates, which is the floor wherever the clip keeps the value (x >= 0;
    # between -1 and 0 both give 0): a pass over the points saved; clipped in place
    col = points[:, 0].astype(np.int64)
    row = points[:, 1].astype(np.int64)
    return np.clip(row, 0, H - 1, out=row), np.clip(col, 0, W - 1, out=col)


def base_radii(gray, points, *, gamma=3.0, floor=0.1):
    """``r_i = max(I_i, floor) ** (gamma / 2)``, ``I_i`` the gray of the pixel holding point i.

    The paper's mapping (w_i = k^2 I_i^gamma) with a floor so that black
    regions keep a positive radius.

    Examples
    --------
    The paper's mapping: a black pixel gets ``floor ** 1.5``, a white one 1.

    >>> gray = np.array([[0.0, 1.0]])
    >>> base_radii(gray, np.array([[0.5, 0.5], [1.5, 0.5]])).round(4).tolist()
    [0.0316, 1.0]
    """
    g = np.asarray(gray, dtype=np.float64)
    H, W = g.shape
    row, col = _pixel_of(np.asarray(points, dtype=np.float64), W, H)
    return np.maximum(g[row, col], floor) ** (0.5 * gamma)


def radius_field(gray, *, radii="gray", gamma=3.0, floor=0.1, sigma=2.0, blur=None):
    """Base radius per pixel: ``r_i`` of a point is the value at its pixel.

    Parameters
    ----------
    gray : (H, W) array_like
        Gray image in [0, 1], 1 = white.
    radii : {"gray", "density"}
        ``"gray"``: the paper's ``max(I, floor) ** (gamma / 2)``.
        ``"density"``: ``sqrt(floor / max(D, floor))`` with ``D`` the darkness
        ``1 - I`` blurred with a Gaussian of ``sigma`` pixels; a packing of
        disks with these radii has local point density ~ ``1 / r^2`` ~ ``D``,
        the density Lloyd's centroids (and the tone measure) aim at, so
        packing and Lloyd moves agree on the tone curve. ``gamma`` is unused.
    gamma : float
        Contrast exponent of the ``"gray"`` mapping.
    floor : float
        ``"gray"``: floor on the gray value; ``"density"``: floor on the
        blurred darkness (largest/smallest radius ratio ``floor ** -0.5``).
    sigma : float
        Blur of the darkness for ``"density"`` (pixels; 0 = none).
    blur : callable, optional
        ``blur(image, sigma)`` with the values of :func:`gaussian_blur` (the
        default), such as a :class:`~diskpack_cl.device.blur.DeviceBlur`.

    Returns
    -------
    (H, W) float64, largest value 1 or less.

    Examples
    --------
    >>> g = np.tile(np.linspace(0, 1, 16), (4, 1))
    >>> f = radius_field(g, radii="density", floor=0.01, sigma=0)
    >>> bool(f[0, 0] < f[0, 8] < f[0, 15])
    True
    """
    g = np.asarray(gray, dtype=np.float64)
    if radii == "gray":
        return np.maximum(g, floor) ** (0.5 * gamma)
    if radii == "density":
        d = 1.0 - g
        if sigma and sigma > 0:
            d = (blur or gaussian_blur)(d, sigma)
        return density_radius(d, floor)
    raise ValueError(f"radii must be 'gray' or 'density', got {radii!r}")


def density_radius(darkness, floor):
    """``sqrt(floor / max(darkness, floor))``, the ``"density"`` radius field of a (blurred)
    float64 darkness, made in place of it (each temporary would be another whole image).

    Examples
    --------
    >>> density_radius(np.array([0.0, 0.04, 1.0]), 0.01).tolist()
    [1.0, 0.5, 0.1]
    """
    np.maximum(darkness, floor, out=darkness)
    np.divide(floor, darkness, out=darkness)
    return np.sqrt(darkness, out=darkness)


def detail_scale(ink, n, dmed):
    """The scale ``ell`` of :func:`detail_fields`: the dot spacing (px) at the median darkness.

    ``sqrt(ink / (n dmed))``, `ink` the picture's summed darkness and `dmed`
    the median darkness of its pixels darker than 0.05.

    Examples
    --------
    >>> detail_scale(400.0, 100, 0.25)
    4.0
    """
    return float(np.sqrt(ink / (max(int(n), 1) * max(dmed, 1e-3))))


def _darkness_scale(d, n):
    """:func:`detail_scale` of a darkness image `d` (its median over the pixels darker than 0.05)."""
    dark = d[d > 0.05]
    dmed = float(np.median(dark, overwrite_input=True)) if dark.size else float(d.mean())
    del dark
    return detail_scale(float(d.sum()), n, dmed)


def detail_ell(gray, n):
    """The scale ``ell`` :func:`detail_fields` finds for a whole gray image and `n` dots.

    Examples
    --------
    >>> detail_ell(np.full((10, 10), 0.75), 25)   # dark 0.25 everywhere: the dot spacing
    2.0
    """
    d = 1.0 - np.asarray(gray, dtype=np.float64)
    total = float(d.sum())
    dmed = median_above(d.reshape(-1), 0.05)
    return detail_scale(total, n, float(d.mean()) if dmed is None else dmed)


#: Values a run of :func:`median_above` reads at a time (its temporaries' size), and
#: the values it samples for its bracket.
MEDIAN_PART, MEDIAN_SAMPLE = 1 << 20, 1 << 16


def median_above(flat, lo, *, part=MEDIAN_PART, sample=MEDIAN_SAMPLE):
    """``np.median(flat[flat > lo])``, the same value, or None where no value is above `lo`.

    No copy of the values is gathered (a whole picture's, at the detail scale
    of a large one): a bracket around the median is read off a seeded random
    sample of `sample` values, then one pass, on every core
    (:func:`~diskpack_cl._cores.on_cores`) and `part` values at a time, counts
    the values above `lo` and those below the bracket and gathers those
    inside; the median is then selected among the bracket's.  A bracket that
    misses the median's rank (about eight standard deviations of the sample's
    rank away) falls back to gathering them all.

    Examples
    --------
    >>> median_above(np.array([0.0, 0.3, 0.9, 0.2, 0.5]), 0.1)
    0.4
    """
    flat = np.asarray(flat).reshape(-1)
    # a random sample (seeded: the same bracket every run), not a stride, which a
    # picture's columns could bias
    pick = flat[np.random.default_rng(0).integers(0, flat.size, min(sample, flat.size))]
    pick = np.sort(pick[pick > lo])
    # the bracket at the sample's middle (the median's rank needs the count of the pass)
    low = high = np.inf   # no value of the sample above lo: the bracket holds none
    if pick.size:
        reach = 4 * int(np.sqrt(pick.size)) + 2
        low = pick[max((pick.size - 1) // 2 - reach, 0)]
        high = pick[min(pick.size // 2 + reach, pick.size - 1)]
    n, below, inside = _bracketed(flat, lo, low, high, part)
    if n == 0:
        return None
    ranks = sorted({(n - 1) // 2, n // 2})
    if below <= ranks[0] and ranks[-1] < below + inside.size:
        return _middle(np.partition(inside, [r - below for r in ranks]), [r - below for r in ranks])
    dark = flat[flat > lo]
    return _middle(np.partition(dark, ranks), ranks)


def _middle(part, ranks):
    """np.median's value from the values at `ranks` of a partitioned array: their mean."""
    return float(np.mean(part[ranks]))


def _bracketed(flat, lo, low, high, part):
    """``(above, below, inside)``: how many values of `flat` are above `lo`, how many of
    those are below `low`, and the values from `low` to `high` (``lo < low``)."""
    above, below, inside = [], [], []

    def run(rows):
        for i in range(rows.start, rows.stop, part):
            x = flat[i:min(i + part, rows.stop)]
            n = int(np.count_nonzero(x > lo))
            above.append(n)
            below.append(n - int(np.count_nonzero(x >= low)))
            inside.append(x[(x >= low) & (x <= high)])

    on_cores(run, flat.size, flat.size, part)
    return sum(above), sum(below), np.concatenate([flat[:0], *inside])   # (none: an empty flat)


#: :func:`detail_fields`' defaults: the factor on the relative detail, and the blur (px) of
#: the sharp darkness.
DETAIL_GAIN, DETAIL_FINE = 1.5, 0.5


def detail_fields(gray, n, field, *, gain=DETAIL_GAIN, fine=DETAIL_FINE, ell=None, blur=None):
    """The radius field and the blend weight of ``features="detail"``.

    Structure finer than the dot spacing (small bright galaxies on a dark
    ground, thin lines, sharp edges) cannot be drawn by the radii, which
    follow a blurred darkness; it can only be drawn by where the dots sit.
    With ``ell = sqrt(sum(D) / (n D_med))``, the dot spacing in pixels at the
    median darkness ``D_med`` of the pixels darker than 0.05:

    * the blend weight is ``clip(gain |D_fine - D_ell| / max(D_ell, 0.1), 0, 1)``,
      ``D_fine`` the darkness blurred by ``fine`` px and ``D_ell`` by
      ``ell / 2`` px: 0 where the image is smooth at the scale of a dot, up
      to 1 where it holds finer detail. A mix step there moves a point
      ``m + (a + (1 - a) weight) (c - m)`` instead of ``m + a (c - m)``: more
      of the way to its cell's centroid, which follows the detail.
    * the radius field is ``field`` dilated (grey-level maximum) over a disk
      of ``max(1, round(ell / 4))`` px: next to an edge the dots on the dark
      side keep the larger radius of the light side, so a light dot's nearest
      neighbour across the edge is not much closer than its light-side ones
      (this holds the spacing P01 that the stronger centroid pull would cost).

    Parameters
    ----------
    gray : (H, W) array_like
        Gray image in [0, 1], 1 = white.
    n : int
        Number of dots.
    field : (H, W) array_like
        The radius field of the run (:func:`radius_field`).
    gain : float
        Factor on the relative detail before clipping to [0, 1].
    fine : float
        Blur (pixels) of the fine darkness.
    ell : float, optional
        The scale ``ell`` (:func:`detail_scale`), when `gray` is a window
        of a larger picture whose scale it is.
    blur : callable, optional
        ``blur(image, sigma)`` with the values of :func:`gaussian_blur` (the
        default), such as a :class:`~diskpack_cl.device.blur.DeviceBlur`.

    Returns
    -------
    field : (H, W) float64
        The dilated radius field (never smaller than ``field``).
    weight : (H, W) float64
        The blend weight in [0, 1].

    Examples
    --------
    >>> g = np.ones((64, 64)) * 0.2
    >>> g[30:33, 30:33] = 1.0                    # a small bright feature on a dark ground
    >>> f, w = detail_fields(g, 400, radius_field(g, radii="density", floor=0.01, sigma=3))
    >>> bool(w[31, 31] > 0.9 and w[5, 5] < 0.01)
    True
    """
    d = 1.0 - np.asarray(gray, dtype=np.float64)
    if ell is None:
        ell = _darkness_scale(d, n)
    sigmas = detail_sigmas(ell, fine)
    weight = detail_blend(d, dict(zip(sigmas, blurs(blur or gaussian_blur, d, list(sigmas.values())))), gain)
    del d
    rad = dilation_radius(ell)
    dilated = in_bands(lambda f: disk_dilation(f, rad), np.asarray(field, dtype=np.float64), rad)
    return dilated, weight


def detail_sigmas(ell, fine=DETAIL_FINE):
    """``{"coarse": ell / 2, "sharp": fine}``: the blurs (px) of the darkness that the blend
    weight of :func:`detail_fields` is made of, at the detail scale `ell` (no ``"sharp"``
    where `fine` is 0: the darkness itself is the sharp one).

    Examples
    --------
    >>> detail_sigmas(8.0), detail_sigmas(8.0, 0)
    ({'coarse': 4.0, 'sharp': 0.5}, {'coarse': 4.0})
    """
    return {"coarse": ell / 2.0, **({"sharp": fine} if fine > 0 else {})}


def detail_blend(darkness, blurred, gain=DETAIL_GAIN):
    """The blend weight of :func:`detail_fields` from the darkness and its blurs named as in
    :func:`detail_sigmas` (`blurred`: ``{name: blur}``, which loses those two).

    Examples
    --------
    >>> d = np.array([0.5, 0.25, 0.0])
    >>> detail_blend(d, {"coarse": np.array([0.5, 0.5, 0.05])}, 1.0).tolist()
    [0.0, 0.5, 0.5]
    """
    sharp = blurred.pop("sharp") if "sharp" in blurred else darkness.copy()
    return detail_weight(sharp, blurred.pop("coarse"), gain)


def detail_weight(sharp, coarse, gain):
    """The blend weight of :func:`detail_fields`, ``clip(gain |sharp - coarse| / max(coarse,
    0.1), 0, 1)`` of two blurs of the darkness, made in place of `sharp` (returned) and
    `coarse` (lost): on a gigapixel-scale image each temporary would be another whole image.

    Examples
    --------
    >>> detail_weight(np.array([0.5, 0.25, 0.0]), np.array([0.5, 0.5, 0.05]), 1.0).tolist()
    [0.0, 0.5, 0.5]
    """
    sharp -= coarse
    np.abs(sharp, out=sharp)
    sharp *= gain
    sharp /= np.maximum(coarse, 0.1, out=coarse)
    return np.clip(sharp, 0.0, 1.0, out=sharp)


def dilation_radius(ell):
    """The radius (px) of :func:`detail_fields`' disk at the detail scale `ell`.

    Examples
    --------
    >>> dilation_radius(8.6), dilation_radius(1.0)
    (2, 1)
    """
    return max(1, int(round(ell / 4.0)))


def disk_dilation(field, rad):
    """``ndimage.grey_dilation(field, footprint=disk, mode="reflect")`` with ``disk`` the
    pixels within `rad` of the centre (``dx^2 + dy^2 <= rad^2``): the same values (a maximum
    is exact), in the field's own dtype, a few times faster.

    The disk is a stack of chords: the row ``dy`` holds the columns ``|dx| <= h(dy)``.
    Each row of the reflected field is maximised over the windows ``2 h + 1`` wide,
    a window from the next smaller one by two shifted maxima, and the result is
    the maximum of the windows of each chord at its row.

    Examples
    --------
    >>> f = np.zeros((5, 7)); f[2, 3] = 1.0
    >>> disk_dilation(f, 1).astype(int).tolist()[1:4]
    [[0, 0, 0, 1, 0, 0, 0], [0, 0, 1, 1, 1, 0, 0], [0, 0, 0, 1, 0, 0, 0]]
    """
    f = np.asarray(field)
    H, W = f.shape
    chords = [math.isqrt(rad * rad - dy * dy) for dy in range(rad + 1)]
    padded = np.pad(f, rad, mode="symmetric")   # numpy's "symmetric" is scipy's "reflect"
    # windows[h][:, c]: the maximum of the padded columns c .. c + 2 h; from h - 1's two
    # shifted by 2, which overlap from h = 2 on
    windows = [padded, np.maximum(np.maximum(padded[:, :-2], padded[:, 1:-1]), padded[:, 2:])]
    while len(windows) <= rad:
        windows.append(np.maximum(windows[-1][:, :-2], windows[-1][:, 2:]))
    out = windows[rad][rad:rad + H].copy()   # the middle row's chord: the widest
    for dy in range(1, rad + 1):
        h = chords[dy]
        for row in (rad - dy, rad + dy):
            np.maximum(out, windows[h][row:row + H, rad - h:rad - h + W], out=out)
    return out


def field_at(field, points):
    """Value of a per-pixel field at the pixel holding each point (clipped to the image),
    as float64 whatever the field's type.

    Examples
    --------
    >>> field_at(np.arange(6.0).reshape(2, 3), [[2.5, 1.5], [-1.0, 0.2]]).tolist()
    [5.0, 0.0]
    """
    return fields_at([field], points)[0]


#: Points per core from which :func:`fields_at` splits its lookups over the cores.
PARALLEL_POINTS = 1 << 17


def fields_at(fields, points, *, part=PARALLEL_POINTS):
    """:func:`field_at` of each of `fields` (one shape; None gives None) at `points`: the
    pixels are found once for all of them (a third of a lookup's time at 1M points).

    A million points take a field's value from as many cache lines: the lookups are
    bound by the memory's latency, and run on every core in runs of points (at least
    `part` each; numpy releases the GIL), each point's value the same.

    Examples
    --------
    >>> f = np.arange(6.0).reshape(2, 3)
    >>> [None if v is None else v.tolist() for v in fields_at([f, None, 2 * f], [[2.5, 1.5]])]
    [[5.0], None, [10.0]]
    """
    shapes = {f.shape for f in fields if f is not None}
    if len(shapes) != 1:
        raise ValueError(f"fields_at needs fields of one shape, got {sorted(shapes)}")
    points = np.asarray(points, dtype=np.float64)
    out = [None if f is None else np.empty(len(points)) for f in fields]

    def run(at):
        _lookups(fields, points[at], [None if o is None else o[at] for o in out])

    on_cores(run, len(points), len(points), part)
    return out


def _lookups(fields, points, out):
    """Each field's value at the pixel of each of `points`, written into `out` (float64)."""
    H, W = next(f for f in fields if f is not None).shape
    row, col = _pixel_of(points, W, H)
    for f, o in zip(fields, out):   # a field that is not C-contiguous: by the two indices
        if f is not None and not f.flags.c_contiguous:   # (a flat view would copy it whole)
            o[...] = f[row, col]
    if any(f is not None and f.flags.c_contiguous for f in fields):
        # a flat take: numpy's two-array index is about twice as slow (1M points: 30-40
        # against 80 ms); the flat index made in place, the two-index reads being done
        row *= W
        row += col
        for f, o in zip(fields, out):
            if f is not None and f.flags.c_contiguous:
                # the indices are in range (clipped): "clip" skips take's bounds check
                # (1M: 9 -> 7.5 ms); the float64 values as astype makes them
                o[...] = np.take(f.reshape(-1), row, mode="clip")


def largest_valid_k(points, r, width, height):
    """Largest ``k`` with all disks ``(points_i, k r_i)`` inside the rectangle and disjoint.

    Exact in float64 over all binding candidates: the edge constraints
    ``k r_i <= min(x_i, W - x_i, y_i, H - y_i)`` and every pair with
    ``d_ij <= k_u (r_i + r_j)``, where ``k_u`` is an upper bound from
    consecutive points and a sample's nearest neighbours; pairs are found
    with cKDTrees per radius octave, so the search stays local even when the
    radii vary by orders of magnitude. Every ratio is ``np.hypot``'s, as a
    brute force over all pairs computes it.

    Returns
    -------
    k : float
        ``min(min_i edge_i / r_i, min_ij d_ij / (r_i + r_j))``; 0 when two
        points coincide or a point lies on the border.

    Examples
    --------
    Two unit disks 2 apart in a 4 x 2 box: they touch each other and the walls at k = 1.

    >>> largest_valid_k(np.array([[1.0, 1.0], [3.0, 1.0]]), np.array([1.0, 1.0]), 4, 2)
    1.0
    """
    return _largest_valid_k(points, r, width, height)[0]


#: Points whose nearest neighbours bound :func:`largest_valid_k`'s pair search whatever
#: the points' order (:func:`_pair_bound`).
BOUND_SAMPLE = 4096


def _pair_bound(p, r, classes, trees):
    """An upper bound of the least ``d_ij / (r_i + r_j)``: the least ratio of the pairs of
    consecutive points and of a seeded sample's nearest neighbours in each octave.

    Any pair's ratio bounds the least one; the bound sets how far the octaves' search
    reaches. Consecutive points are neighbours where the points come in a spatial order
    (a stippling's, row by row from the error diffusion: there the binding pair is often
    among them), and the sample keeps the bound among the lowest ratios in any order.
    Each ratio is the exact pair search's own (``np.hypot``), so that the least is the
    same whichever pairs it comes from.
    """
    d = np.diff(p, axis=0)
    bound = float(np.min(np.hypot(d[:, 0], d[:, 1]) / (r[1:] + r[:-1])))
    sample = np.random.default_rng(0).integers(0, len(p), min(BOUND_SAMPLE, len(p)))
    for c, tree in zip(classes, trees):
        _, jj = tree.query(p[sample], k=min(2, len(c)))
        # the two nearest: one is the point itself where it is of this octave
        for near in c[np.asarray(jj).reshape(len(sample), -1).T]:
            other = near != sample
            i, j = sample[other], near[other]
            ratio = np.hypot(p[i, 0] - p[j, 0], p[i, 1] - p[j, 1]) / (r[i] + r[j])
            bound = min(bound, float(np.min(ratio, initial=np.inf)))
    return bound


def _largest_valid_k(points, r, width, height):
    """:func:`largest_valid_k` and the octaves it searched: ``(k, (classes, trees,
    searched))`` (:func:`~diskpack_cl.geometry.radius_octaves` of `r`, a cKDTree of each
    class's points, and the pairs of each pair of octaves it found, as
    :func:`~diskpack_cl.geometry.certify_disks` takes them), or ``(k, None)`` where it
    found k without them."""
    p = np.asarray(points, dtype=np.float64)
    r = np.asarray(r, dtype=np.float64)
    edge = np.minimum.reduce([p[:, 0], width - p[:, 0], p[:, 1], height - p[:, 1]])
    k = float(np.min(edge / r))
    if len(p) < 2:
        return max(k, 0.0), None
    classes = radius_octaves(r)
    rmax = [r[c].max() for c in classes]
    # the octaves' trees at once, on every core (cKDTree releases the GIL)
    with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
        trees = list(pool.map(lambda c: cKDTree(p[c]), classes))
    k = min(k, _pair_bound(p, r, classes, trees))
    if k <= 0:
        return 0.0, None

    def pair_k(ab):
        # every pair of octaves (a, b) within the bound k has: a pair it misses has a
        # larger ratio than the bound, so the least ratio is the same in any order
        a, b = ab
        reach = k * (rmax[a] + rmax[b]) * (1 + 1e-9)
        sdm = trees[a].sparse_distance_matrix(trees[b], reach, output_type="ndarray")
        i, jj = classes[a][sdm["i"]], classes[b][sdm["j"]]
        keep = i != jj
        # the certificate's own search of these octaves reaches less far (its k is at
        # most this bound): it takes these pairs (a few per thousand centres)
        searched[ab] = (reach, i[keep], jj[keep], sdm["v"][keep])
        if not np.any(keep):
            return np.inf
        i, jj = i[keep], jj[keep]
        dij = np.hypot(p[i, 0] - p[jj, 0], p[i, 1] - p[jj, 1])
        return float(np.min(dij / (r[i] + r[jj])))

    # the pairs of octaves on every core
    searched = {}
    with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
        pairs = [(a, b) for a in range(len(classes)) for b in range(a, len(classes))]
        k = min(k, *pool.map(pair_k, pairs))
    return max(k, 0.0), (classes, trees, searched)


def certified_k(points, r, width, height, domain):
    """``(k, radii, certificate)``: the largest valid k, shrunk by ulps until certified.

    :func:`largest_valid_k` is exact up to rounding; the disks ``k r_i`` are
    then checked by :func:`diskpack_cl.geometry.certify_disks`, and k shrinks
    by a few ulps while rounding makes two disks touch.

    Raises
    ------
    ValueError
        Two points coincide or one lies on the border (no positive k).
    CertificateError
        The disks still fail :func:`~diskpack_cl.geometry.certify_disks`
        after the shrinking: an invalid certificate is never returned.

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> k, radii, cert = certified_k([[1.0, 1.0], [3.0, 1.0]], np.ones(2), 4, 2, Domain.rect(4, 2))
    >>> round(float(k), 9), cert.valid
    (1.0, True)
    """
    k, octaves = _largest_valid_k(points, r, width, height)
    if not k > 0:
        raise ValueError("two stipples coincide or lie on the image border: no valid radius")
    shrink = 1.0 - 4 * np.finfo(float).eps
    for _ in range(8):
        k *= shrink
        radii = k * r
        cert = certify_disks(points, radii, domain, octaves=octaves)   # its trees and pairs
        if cert.valid:
            return k, radii, cert
        shrink = shrink * shrink * shrink * (1 - 1e-12)
    raise CertificateError("the disks of the largest valid k failed their certificate", cert)
