"""Measures of a stippled picture: tone, spacing, stray dots, edges, holes.

Stipplings in pixel units (origin at the top-left pixel corner, x to the right,
y down, pixel (row r, col c) covers [c, c+1) x [r, r+1)) against a darkness
image (2-D float array in [0, 1], 1 = black), as in weighted Voronoi
stippling [1]_: the tone SSIM [2]_, the density normalized spacing and
:func:`stipple_measures`, which gathers them. The measures of the point set
alone (spectra, rho, ``|psi_6|``) are :mod:`diskpack_cl.analysis`.

Everything here is numpy/scipy only and float64.

References
----------
.. [1] A. Secord, "Weighted Voronoi stippling", NPAR 2002, 37-43.
.. [2] Z. Wang, A. C. Bovik, H. R. Sheikh and E. P. Simoncelli, "Image quality
   assessment: from error visibility to structural similarity", IEEE
   Transactions on Image Processing 13(4):600-612, 2004.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from . import measures
from ._checks import check_points
from .analysis import hexatic_order
from .measures import PLANE

__all__ = [
    "HEXAGONAL_SPACING",
    "Holes",
    "Spacing",
    "StrayDots",
    "dot_spacing",
    "edge_fidelity",
    "holes",
    "render_dots",
    "spacing",
    "ssim",
    "ssim_map",
    "stipple_measures",
    "stray_dots",
    "strong_edges",
    "tone_radius",
    "tone_ssim",
]

#: Density-normalized nearest-neighbour distance of a hexagonal packing,
#: sqrt(2 / sqrt(3)) = 1.0746.
HEXAGONAL_SPACING = math.sqrt(2.0 / math.sqrt(3.0))


def _as_darkness(darkness):
    d = np.asarray(darkness, dtype=np.float64)
    if d.ndim != 2 or d.size == 0:
        raise ValueError(f"darkness must be a non-empty 2-D array, got shape {d.shape}")
    if not np.all(np.isfinite(d)) or d.min() < 0.0 or d.max() > 1.0:
        raise ValueError("darkness values must lie in [0, 1]")
    return d


def ssim_map(a, b, *, sigma=1.5, data_range=1.0):
    """Local structural similarity of two images, per pixel (Wang et al. 2004).

    The map whose mean (without a border of the window radius) is
    :func:`ssim`; see there for the window and constants.

    Examples
    --------
    >>> img = np.random.default_rng(4).random((24, 24))
    >>> m = ssim_map(img, 1.0 - img)
    >>> m.shape, bool(m.max() < 1.0)
    ((24, 24), True)
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape or a.ndim != 2:
        raise ValueError(f"images must be 2-D with equal shapes, got {a.shape} and {b.shape}")
    pad = _ssim_pad(sigma)
    if min(a.shape) < 2 * pad + 1:
        raise ValueError(f"images must be at least {2 * pad + 1} x {2 * pad + 1} pixels, got {a.shape}")

    def filt(x):
        return ndimage.gaussian_filter(x, sigma, mode="reflect", truncate=_SSIM_TRUNCATE)

    ux, uy = filt(a), filt(b)
    vx = filt(a * a) - ux * ux
    vy = filt(b * b) - uy * uy
    vxy = filt(a * b) - ux * uy
    c1 = (0.01 * data_range) ** 2
    c2 = (0.03 * data_range) ** 2
    return ((2 * ux * uy + c1) * (2 * vxy + c2)) / ((ux * ux + uy * uy + c1) * (vx + vy + c2))


_SSIM_TRUNCATE = 3.5


def _ssim_pad(sigma):
    return int(_SSIM_TRUNCATE * sigma + 0.5)


def ssim(a, b, *, sigma=1.5, data_range=1.0):
    """Mean structural similarity of two images (Wang et al. 2004).

    Gaussian-weighted local statistics (``sigma`` 1.5, truncated at 3.5 sigma:
    an 11-tap window), population covariances, ``K1 = 0.01``, ``K2 = 0.03``,
    mirror boundary; the mean is taken over the image without a border of the
    window radius. This is the choice that matches
    ``skimage.metrics.structural_similarity(a, b, gaussian_weights=True,
    sigma=1.5, use_sample_covariance=False, data_range=1)``.

    Examples
    --------
    >>> img = np.random.default_rng(4).random((32, 32))
    >>> ssim(img, img)
    1.0
    """
    pad = _ssim_pad(sigma)
    return float(ssim_map(a, b, sigma=sigma, data_range=data_range)[pad:-pad, pad:-pad].mean())


def tone_radius(n, darkness):
    """Dot radius in pixels for which n dots hold the total darkness as ink.

    ``sqrt(sum(darkness) / (n pi))`` (darkness summed in pixel area units).

    Examples
    --------
    >>> round(tone_radius(100, np.full((10, 10), 0.5 * np.pi)), 6)
    0.707107
    """
    d = np.asarray(darkness, dtype=np.float64)
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n}")
    return math.sqrt(float(d.sum()) / (n * math.pi))


def render_dots(points, radius, shape, *, samples=16):
    """Draw dots as anti-aliased disks of ink; the ink of overlapping dots adds.

    Pixel (row r, col c) covers [c, c+1) x [r, r+1). The coverage of a pixel by
    a disk is integrated exactly along x (chord lengths) and by the midpoint
    rule with ``samples`` rows per pixel along y; each dot's coverage is then
    rescaled to exactly pi r^2, so the total ink is ``sum(pi r_i^2)`` minus
    what falls outside the image. Ink is additive and not clipped at 1, so the
    drawing's local mean equals the dot density times the dot area: what a
    reader sees after blurring.

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Dot centres (x, y) in pixel units.
    radius : float or array_like, shape (n,)
        Dot radii in pixels (> 0).
    shape : (ny, nx)
        Output image shape.
    samples : int
        Sub-rows per pixel for the y integration.

    Returns
    -------
    ndarray of float64, shape (ny, nx)
        Ink per pixel (1 = a fully covered pixel).

    Examples
    --------
    >>> img = render_dots([[10.3, 9.7]], 3.0, (20, 20))
    >>> round(float(img.sum()) / np.pi, 6)
    9.0
    """
    p = check_points(points)
    n = len(p)
    ny, nx = (int(s) for s in shape)
    out = np.zeros(ny * nx)
    if n == 0:
        return out.reshape(ny, nx)
    r = np.broadcast_to(np.asarray(radius, dtype=np.float64), (n,))
    if not np.all(np.isfinite(r)) or np.any(r <= 0):
        raise ValueError("radius must be positive and finite")
    order = np.argsort(r)  # similar sizes share a window size
    p, r = p[order], r[order]
    w = int(math.ceil(2.0 * r.max())) + 1
    # block so that block * w * w * samples stays near 4M values
    block = max(1, (1 << 22) // (w * w * samples))
    sub = (np.arange(samples) + 0.5) / samples  # sub-row centres within a pixel
    offs = np.arange(w)
    for s in range(0, n, block):
        cx, cy, rr = p[s:s + block, 0], p[s:s + block, 1], r[s:s + block]
        wb = int(math.ceil(2.0 * rr.max())) + 1
        o = offs[:wb]
        x0 = np.floor(cx - rr)[:, None] + o  # (b, wb) pixel columns
        y0 = np.floor(cy - rr)[:, None] + o  # (b, wb) pixel rows
        ys = y0[:, :, None] + sub  # (b, wb, samples)
        dy = ys - cy[:, None, None]
        half = np.sqrt(np.maximum(rr[:, None, None] ** 2 - dy * dy, 0.0))
        lo = (cx[:, None, None] - half)[:, :, :, None]  # (b, wb, samples, 1)
        hi = (cx[:, None, None] + half)[:, :, :, None]
        xl = x0[:, None, None, :]  # (b, 1, 1, wb)
        cover = np.clip(np.minimum(hi, xl + 1.0) - np.maximum(lo, xl), 0.0, None)
        cover = cover.sum(axis=2) / samples  # (b, wb rows, wb cols)
        total = cover.sum(axis=(1, 2))
        area = np.pi * rr * rr
        scale = np.where(total > 0, area / np.where(total > 0, total, 1.0), 0.0)
        cover *= scale[:, None, None]
        lost = total <= 0  # dots too small for the sub-rows: all ink in their pixel
        if np.any(lost):
            cover[lost] = 0.0
            ic = (np.floor(cx[lost]) - x0[lost, 0]).astype(np.int64)
            ir = (np.floor(cy[lost]) - y0[lost, 0]).astype(np.int64)
            cover[np.nonzero(lost)[0], ir, ic] = area[lost]
        rows = np.broadcast_to(y0[:, :, None], cover.shape)
        cols = np.broadcast_to(x0[:, None, :], cover.shape)
        ok = (rows >= 0) & (rows < ny) & (cols >= 0) & (cols < nx) & (cover > 0)
        flat = rows[ok].astype(np.int64) * nx + cols[ok].astype(np.int64)
        out += np.bincount(flat, weights=cover[ok], minlength=ny * nx)
    return out.reshape(ny, nx)


def tone_ssim(points, darkness, *, sigma=3.0):
    """Tone fidelity of a stippling: SSIM of the blurred drawing and the blurred image.

    Every dot is drawn (:func:`render_dots`) as an anti-aliased disk of one
    radius, :func:`tone_radius`, chosen so that the total ink equals the total
    darkness; drawing and darkness are blurred with a Gaussian of ``sigma``
    pixels (``scipy.ndimage.gaussian_filter``, mirror boundary) and compared
    with :func:`ssim` (Wang et al. 2004; data range 1).

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Dots in pixel units (x right, y down, origin at the top-left corner).
    darkness : ndarray, shape (ny, nx)
        Darkness in [0, 1] (1 = black), not all zero.
    sigma : float
        Blur in pixels (the viewing distance).

    Returns
    -------
    float

    References
    ----------
    .. [1] Wang et al. 2004 (SSIM).
    .. [2] Secord 2002 (stippling: dot density follows darkness).

    Examples
    --------
    >>> dark = np.full((40, 40), 0.25)
    >>> iy, ix = np.mgrid[0:20, 0:20]
    >>> pts = np.column_stack([2.0 * ix.ravel() + 1.0, 2.0 * iy.ravel() + 1.0])
    >>> tone_ssim(pts, dark) > 0.99
    True
    """
    p, d = _stipple_inputs(points, darkness)
    return _tone(_equal_ink_drawing(p, d), d, sigma)


def _equal_ink_drawing(p, d):
    """The dots drawn with the one radius whose ink equals the darkness (:func:`tone_radius`)."""
    return render_dots(p, tone_radius(len(p), d), d.shape)


def _blurred_pair(drawing, d, sigma):
    return (ndimage.gaussian_filter(drawing, sigma, mode="reflect"),
            ndimage.gaussian_filter(d, sigma, mode="reflect"))


def _tone(drawing, d, sigma):
    return ssim(*_blurred_pair(drawing, d, sigma), data_range=1.0)


def _stipple_inputs(points, darkness, minimum=1):
    """The dots and the darkness of a stippling measure, checked (at least `minimum` dots)."""
    p = check_points(points)
    d = _as_darkness(darkness)
    if len(p) < minimum:
        raise ValueError("need at least one point" if minimum == 1 else f"need at least {minimum} points")
    if d.sum() <= 0:
        raise ValueError("darkness is all zero (a white image): nothing to stipple")
    return p, d


class Spacing(NamedTuple):
    """Per-point density-normalized spacing, its summary, and the expected density it used.

    Examples
    --------
    >>> p = np.random.default_rng(1).random((400, 2)) * 40
    >>> s = spacing(p, np.full((40, 40), 0.5))
    >>> s.values.shape, bool(s.p01 < s.median)
    ((400,), True)
    """

    values: np.ndarray
    p01: float
    median: float
    density: np.ndarray


def spacing(points, darkness, *, sigma=3.0, normalize="dot"):
    """Nearest-neighbour distance of each dot relative to the spacing its tone asks for.

    ``s_i = d_nn(i) * sqrt(rho_i)`` with the expected local density
    ``rho_i = n * D_sigma(x_i) / sum(D)`` (dots per pixel area), where
    ``D_sigma`` is the darkness blurred with a Gaussian of ``sigma`` pixels and
    read at the dot by bilinear interpolation between pixel centres. A
    hexagonal packing at uniform darkness gives ``sqrt(2 / sqrt(3)) = 1.0746``
    (:data:`HEXAGONAL_SPACING`); small values are clumps, so the 1st
    percentile is the number to watch. Distances are in the bounded image (no
    wrap).

    Parameters
    ----------
    points : array_like, shape (n, 2), n >= 2
        Dots in pixel units.
    darkness : ndarray, shape (ny, nx)
        Darkness in [0, 1], 1 = black.
    sigma : float
        Blur of the expected density, in pixels.
    normalize : {"dot", "pair"}
        ``"dot"`` (the measure above, the spacing P01): the distance read
        against the dot's own expected spacing ``1 / sqrt(rho_i)``.
        ``"pair"``: against the mean of the expected spacings of the dot and
        its nearest neighbour ``j``, ``s_i = d_nn(i) * 2 sqrt(rho_i rho_j) /
        (sqrt(rho_i) + sqrt(rho_j))``; the same where the density is uniform,
        but across a tone edge it asks a light-side dot to keep only the mean
        spacing, not its own, from its dark-side neighbour, which is what
        tangent disks of the two sides' sizes give. A diagnostic of where
        ``"dot"`` fails, not the target.

    Returns
    -------
    Spacing
        ``values`` (n,), ``p01`` (1st percentile), ``median`` and
        ``density`` (n,), the expected local density ``rho_i``.

    References
    ----------
    .. [1] Secord 2002 (dot density proportional to darkness).
    .. [2] Lagae and Dutre 2008 (normalized nearest-neighbour distance).

    Examples
    --------
    >>> dark = np.full((64, 64), 0.3)
    >>> pts = np.random.default_rng(5).random((400, 2)) * 64
    >>> s = spacing(pts, dark)
    >>> bool(s.p01 < s.median < 1.0746)
    True
    >>> bool(np.allclose(spacing(pts, dark, normalize="pair").values, s.values))
    True
    """
    if normalize not in ("dot", "pair"):
        raise ValueError(f"normalize must be 'dot' or 'pair', got {normalize!r}")
    p, d = _stipple_inputs(points, darkness, minimum=2)
    nn, j = measures.nearest_neighbors(p, PLANE)
    blurred = ndimage.gaussian_filter(d, sigma, mode="reflect")
    local = ndimage.map_coordinates(blurred, [p[:, 1] - 0.5, p[:, 0] - 0.5], order=1, mode="nearest")
    density = len(p) * np.maximum(local, 0.0) / d.sum()
    root = np.sqrt(density)
    if normalize == "pair":
        # 1 / mean of the two spacings 1/root: the harmonic mean of the roots
        total = root + root[j]
        root = np.divide(2.0 * root * root[j], total, out=np.zeros_like(total), where=total > 0)
    values = nn * root
    return Spacing(values, float(np.percentile(values, 1.0)), float(np.median(values)), density)


class StrayDots(NamedTuple):
    """Dots with no ink near them: a mask, their count and their rate per 10 000 dots.

    Examples
    --------
    Ink on the left half only; 100 dots there and one on the white right half:

    >>> d = np.zeros((40, 40))
    >>> d[:, :20] = 1.0
    >>> p = np.vstack([np.random.default_rng(0).random((100, 2)) * [20, 40], [[35.0, 20.0]]])
    >>> s = stray_dots(p, d)
    >>> s.count, np.flatnonzero(s.mask).tolist()
    (1, [100])
    """

    mask: np.ndarray
    count: int
    per_10k: float


def stray_dots(points, darkness, *, threshold=0.02):
    """Dots farther than half their own spacing from every inked pixel.

    A dot's spacing is the distance ``d_nn`` to its nearest neighbour, so
    the disk of radius ``d_nn / 2`` around it is the room it has to itself.
    When no pixel with darkness above `threshold` meets that disk (its
    square, not only its centre), the dot draws ink on white paper: a
    plotter inks it, the eye sees it first. Weighted Lloyd stippling leaves
    none on black-and-white drawings; a tone blur hides them, and a spacing
    percentile rewards them for being far apart, which is why they need a
    measure of their own.

    Parameters
    ----------
    points, darkness
        The dots and the darkness, as for :func:`spacing`.
    threshold : float
        Darkness above which a pixel counts as inked.

    Returns
    -------
    StrayDots
        ``mask`` (n,) bool, ``count`` and ``per_10k`` (stray dots per 10 000).

    Examples
    --------
    >>> dark = np.zeros((20, 20)); dark[:, :10] = 1.0
    >>> stray_dots([[3.0, 5.0], [5.0, 5.0], [17.0, 12.0]], dark).mask.tolist()
    [False, False, True]
    """
    p, d = _stipple_inputs(points, darkness, minimum=2)
    nn, _ = measures.nearest_neighbors(p, PLANE)
    rows, cols = np.nonzero(d > threshold)
    mask = np.ones(len(p), dtype=bool)
    if rows.size:
        centres = np.column_stack([cols + 0.5, rows + 0.5])
        mask = _far_from_squares(p, 0.5 * nn, centres)
    count = int(np.count_nonzero(mask))
    return StrayDots(mask, count, 1e4 * count / len(p))


def _far_from_squares(p, reach, centres):
    """Whether each point is farther than `reach` from every unit pixel square of `centres`."""
    tree = cKDTree(centres)
    dist, _ = tree.query(p, k=1)
    far = dist > reach   # a square is never farther than its centre
    idx = np.nonzero(far)[0]
    # only a square whose centre is within reach + sqrt(2)/2 can be within reach
    near = tree.query_ball_point(p[idx], reach[idx] + 0.5 * math.sqrt(2.0))
    for i, cand in zip(idx, near):
        if cand:
            gap = np.maximum(np.abs(centres[cand] - p[i]) - 0.5, 0.0)
            far[i] = bool(np.min(np.hypot(gap[:, 0], gap[:, 1])) > reach[i])
    return far


def dot_spacing(n, darkness, level=1.0):
    """Spacing (px) of ``n`` dots drawing `darkness` where its value is `level`.

    ``sqrt(sum(darkness) / (n level))``: the dot density follows the
    darkness, ``n level / sum(darkness)`` dots per pixel at that level.

    Examples
    --------
    >>> dot_spacing(100, np.full((20, 20), 0.25))
    1.0
    """
    d = np.asarray(darkness, dtype=np.float64)
    return math.sqrt(float(d.sum()) / (int(n) * float(level)))


def strong_edges(darkness, *, edge=0.25):
    """Pixels where the darkness changes by at least `edge` per pixel (central differences).

    A black-to-white step gives 0.5 on the two pixels beside it; the
    gradients of a photograph's soft edges stay below 0.25.

    Examples
    --------
    >>> dark = np.zeros((6, 6)); dark[:, 3:] = 1.0
    >>> strong_edges(dark)[0].astype(int).tolist()
    [0, 0, 1, 1, 0, 0]
    """
    gy, gx = np.gradient(np.asarray(darkness, dtype=np.float64))
    return np.hypot(gx, gy) >= edge


def edge_fidelity(points, darkness, *, sigma=1.0, edge=0.25, band=2.0):
    """Fine-scale tone near strong edges: SSIM of the rendering inside an edge band.

    The dots are drawn as in :func:`tone_ssim` (equal ink, blur `sigma`
    px) and compared with the darkness by :func:`ssim_map`; the mean is
    taken over the pixels within `band` dot spacings of a strong edge
    (:func:`strong_edges`), the spacing being that of the edges' dark side
    (:func:`dot_spacing` at the median of the 3x3 maximum darkness on the
    edge pixels). A ragged or blurred outline, a rounded corner, a broken
    line all lower it; a tone blur of 3 px forgives them.

    Parameters
    ----------
    points, darkness
        The dots and the darkness, as for :func:`spacing` (one dot is enough).
    sigma : float
        Blur (px) of drawing and darkness before the comparison.
    edge : float
        Gradient threshold of :func:`strong_edges`.
    band : float
        Half-width of the band, in dot spacings.

    Returns
    -------
    float
        The mean local SSIM in the band; NaN when the image has no strong edge.

    Examples
    --------
    >>> dark = np.zeros((40, 40)); dark[:, :20] = 1.0
    >>> iy, ix = np.mgrid[0:20, 0:10]
    >>> pts = np.column_stack([2.0 * ix.ravel() + 1.0, 2.0 * iy.ravel() + 1.0])
    >>> bool(edge_fidelity(pts, dark) > edge_fidelity(pts + [8.0, 0.0], dark))
    True
    """
    p, d = _stipple_inputs(points, darkness)
    return _edge(p, d, None, sigma, edge, band)


def _edge(p, d, drawing, sigma, edge, band):
    """:func:`edge_fidelity` with the equal-ink drawing given (None: drawn here)."""
    edges = strong_edges(d, edge=edge)
    if not edges.any():
        return math.nan
    level = float(np.median(ndimage.maximum_filter(d, size=3)[edges]))
    width = band * dot_spacing(len(p), d, level)
    mask = ndimage.distance_transform_edt(~edges) <= width
    pad = _ssim_pad(1.5)
    mask[:pad], mask[-pad:], mask[:, :pad], mask[:, -pad:] = False, False, False, False
    if not mask.any():
        return math.nan
    drawing = _equal_ink_drawing(p, d) if drawing is None else drawing
    return float(ssim_map(*_blurred_pair(drawing, d, sigma))[mask].mean())


class Holes(NamedTuple):
    """Solid-dark pixels far from every dot: a mask, their count and rate per 10 000.

    Examples
    --------
    Solid black, dots on the left half only: the right half is a hole.

    >>> p = np.random.default_rng(0).random((200, 2)) * [20, 40]
    >>> h = holes(p, np.ones((40, 40)))
    >>> h.mask.shape, bool(h.mask[:, 35].all()), bool(h.mask[:, 5].any())
    ((40, 40), True, False)
    """

    mask: np.ndarray
    count: int
    per_10k: float


def holes(points, darkness, *, solid=0.5, sigma=3.0):
    """Solid-dark pixels farther than one expected dot spacing from every dot.

    A pixel is solid-dark when its darkness is at least `solid`; its
    expected spacing is ``1 / sqrt(rho)`` with ``rho`` the expected dot
    density of :func:`spacing` (darkness blurred by `sigma` px) at its
    centre. In a hexagonal packing no point is farther than 0.58 spacings
    from a dot, so a pixel farther than one spacing sits in a hole: a thin
    line broken up, a dark shape with a gap.

    Parameters
    ----------
    points, darkness
        The dots and the darkness, as for :func:`spacing` (one dot is enough).
    solid : float
        Darkness from which a pixel is solid-dark.
    sigma : float
        Blur (px) of the expected density.

    Returns
    -------
    Holes
        ``mask`` (ny, nx) bool, ``count`` and ``per_10k`` (hole pixels per
        10 000 solid-dark pixels; 0 when there are none).

    Examples
    --------
    >>> dark = np.ones((20, 20))
    >>> iy, ix = np.mgrid[0:10, 0:10]
    >>> pts = np.column_stack([2.0 * ix.ravel() + 1.0, 2.0 * iy.ravel() + 1.0])
    >>> holes(pts, dark).count, holes(pts[pts[:, 0] > 8], dark).count > 0
    (0, True)
    """
    p, d = _stipple_inputs(points, darkness)
    rows, cols = np.nonzero(d >= solid)
    mask = np.zeros(d.shape, dtype=bool)
    if rows.size == 0:
        return Holes(mask, 0, 0.0)
    blurred = ndimage.gaussian_filter(d, sigma, mode="reflect")[rows, cols]
    rho = len(p) * np.maximum(blurred, 1e-12) / d.sum()
    dist, _ = cKDTree(p).query(np.column_stack([cols + 0.5, rows + 0.5]), k=1)
    far = dist > 1.0 / np.sqrt(rho)
    mask[rows[far], cols[far]] = True
    count = int(np.count_nonzero(far))
    return Holes(mask, count, 1e4 * count / rows.size)


def stipple_measures(points, darkness, *, sigma=3.0):
    """The stippling measures, in one dict: tone, spacing, order, and what the eye sees first.

    Parameters
    ----------
    points, darkness
        The dots and the darkness, as for :func:`spacing` (one dot is enough).
    sigma : float
        Blur in pixels for tone and spacing.

    Returns
    -------
    dict
        ``n``; ``tone_ssim`` (:func:`tone_ssim` at `sigma`) and
        ``tone_ssim_fine`` (at half of it); ``spacing_p01`` and
        ``spacing_median`` (:func:`spacing`), ``spacing_p01_pair`` (read with
        the pair's spacing); ``psi6_mean`` (:func:`hexatic_order` in the
        bounded image, no periodic wrap); ``stray_per_10k``
        (:func:`stray_dots`), ``edge_ssim`` (:func:`edge_fidelity`, NaN
        without strong edges) and ``holes_per_10k`` (:func:`holes`).

    Examples
    --------
    >>> dark = np.full((48, 48), 0.3)
    >>> pts = np.random.default_rng(6).random((300, 2)) * 48
    >>> sorted(stipple_measures(pts, dark))  # doctest: +NORMALIZE_WHITESPACE
    ['edge_ssim', 'holes_per_10k', 'n', 'psi6_mean', 'spacing_median', 'spacing_p01',
     'spacing_p01_pair', 'stray_per_10k', 'tone_ssim', 'tone_ssim_fine']
    """
    p, d = _stipple_inputs(points, darkness)
    sp = spacing(p, d, sigma=sigma)
    drawing = _equal_ink_drawing(p, d)   # drawn once for the three tone measures
    return {
        "n": int(len(p)),
        "tone_ssim": _tone(drawing, d, sigma),
        "tone_ssim_fine": _tone(drawing, d, sigma / 2),
        "spacing_p01": sp.p01,
        "spacing_median": sp.median,
        "spacing_p01_pair": spacing(p, d, sigma=sigma, normalize="pair").p01,
        "psi6_mean": hexatic_order(p, periodic=False).mean,
        "stray_per_10k": stray_dots(p, d).per_10k,
        "edge_ssim": _edge(p, d, drawing, 1.0, 0.25, 2.0),
        "holes_per_10k": holes(p, d, sigma=sigma).per_10k,
    }
