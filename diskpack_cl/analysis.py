"""Numbers users judge blue noise by: spectra, rho and local order of point sets.

Point sets on the unit torus [0,1)^2: the mean periodogram, its radial mean
power and anisotropy (Lagae and Dutre 2008 [1]_; Schlomer and Deussen 2011
[2]_; Heck, Schlomer and Deussen 2013 [3]_), the normalized Poisson disk
radius rho and its mean-nearest-neighbour variant, and the local hexatic
order ``|psi_6|``. The measures of a stippled picture are
:mod:`diskpack_cl.picture_measures`.

Everything here is numpy/scipy only and float64.

References
----------
.. [1] A. Lagae and P. Dutre, "A comparison of methods for generating Poisson
   disk distributions", Computer Graphics Forum 27(1):114-129, 2008.
.. [2] C. Schlomer and O. Deussen, "Accurate spectral analysis of
   two-dimensional point sets", Journal of Graphics, GPU, and Game Tools
   15(3):152-160, 2011.
.. [3] D. Heck, T. Schlomer and O. Deussen, "Blue noise sampling with
   controlled aliasing", ACM Transactions on Graphics 32(3):25, 2013.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy.spatial import Delaunay, QhullError
from scipy import fft, sparse

from . import measures
from ._checks import check_points
from .domain import Domain
from .measures import hexagonal_radius, normalized_radius

__all__ = [
    "HexaticOrder",
    "anisotropy",
    "hexatic_order",
    "mean_normalized_radius",
    "nearest_neighbor_distances",
    "normalized_radius",
    "periodogram",
    "radial_power",
]

_CHUNK = 1 << 15  # points per block in the Fourier sums (bounds memory)


# ---------------------------------------------------------------------------
# input checks


def _as_realizations(points_or_list):
    """One (n, 2) array, a (K, n, 2) array or a sequence of (n_k, 2) arrays."""
    if isinstance(points_or_list, np.ndarray) and points_or_list.ndim == 2:
        sets = [points_or_list]
    elif isinstance(points_or_list, np.ndarray) and points_or_list.ndim == 3:
        sets = list(points_or_list)
    elif isinstance(points_or_list, (list, tuple)):
        if len(points_or_list) == 0:
            raise ValueError("need at least one point set")
        first = np.asarray(points_or_list[0])
        sets = [points_or_list] if first.ndim == 1 else list(points_or_list)
    else:
        sets = [points_or_list]
    sets = [check_points(s) for s in sets]
    if any(len(s) == 0 for s in sets):
        raise ValueError("every point set needs at least one point")
    return sets


# ---------------------------------------------------------------------------
# spectra


def periodogram(points_or_list, *, kmax=None, method="auto"):
    """Mean periodogram of point sets on the unit torus, by exact Fourier sums.

    For each realization with points x_j in [0,1)^2,
    ``P(k) = |sum_j exp(-2 pi i k . x_j)|^2 / n`` at the integer frequency
    vectors k = (kx, ky) with ``-kmax <= kx, ky <= kmax``; the result is the
    mean over realizations. Integer frequencies are exactly the ones the torus
    supports, so no windowing is involved and points need not be wrapped.
    With this normalization a uniform random set has expected power 1 at every
    k != 0.

    The DC term k = (0, 0) equals n by definition and carries no information
    on the arrangement; it is **set to 0** in the output (so plots and radial
    means are not dominated by it). :func:`radial_power` and
    :func:`anisotropy` skip it.

    Parameters
    ----------
    points_or_list : array_like
        One point set (n, 2), a stack (K, n, 2) or a sequence of (n_k, 2)
        arrays (realizations may differ in n; each is normalized by its own n).
    kmax : int, optional
        Largest frequency along each axis. Default ``ceil(2 sqrt(n))`` with n
        the mean number of points: about twice the frequency of the blue-noise
        peak, which sits near ``sqrt(n)``.
    method : {"auto", "direct", "nufft"}
        ``direct``: exact sums, O(n kmax^2); ``nufft``: :func:`_nufft_power`,
        O(n + kmax^2 log kmax), within about 1e-8 of them; ``auto``: nufft
        where ``n (2 kmax + 1)^2`` exceeds 2e8.

    Returns
    -------
    freqs : ndarray of int, shape (2 kmax + 1,)
        The frequency axis ``-kmax .. kmax`` (same for x and y).
    P : ndarray of float64, shape (2 kmax + 1, 2 kmax + 1)
        Mean periodogram indexed ``P[iy, ix]`` at ``k = (freqs[ix], freqs[iy])``;
        the centre ``P[kmax, kmax]`` is the DC term, set to 0.

    Notes
    -----
    The sum is separable: with ``Ex[j, a] = exp(-2 pi i fa x_j)`` and
    ``Ey[j, b] = exp(-2 pi i fb y_j)`` the whole spectrum is the matrix product
    ``Ey.T @ Ex``: O(n kmax^2) work in BLAS, no Python loop over frequencies.
    Only the half plane ky >= 0 is computed (``P(-k) = P(k)`` for real
    points). Phases are reduced modulo 1 before the exponential, so the sums
    are accurate to float64 round-off.  The non-uniform FFT spreads the
    points with a Gaussian onto a grid twice as fine as the spectrum, takes
    one real FFT and divides by the Gaussian's transform.

    References
    ----------
    .. [1] Lagae and Dutre 2008, section 3 (mean periodogram).
    .. [2] Schlomer and Deussen 2011 (exact Fourier sums of point sets).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> freqs, P = periodogram(rng.random((256, 2)), kmax=8)
    >>> P.shape, int(freqs[0]), float(P[8, 8])
    ((17, 17), -8, 0.0)
    """
    sets = _as_realizations(points_or_list)
    if kmax is None:
        n_mean = np.mean([len(s) for s in sets])
        kmax = max(1, int(math.ceil(2.0 * math.sqrt(n_mean))))
    if isinstance(kmax, bool) or not isinstance(kmax, (int, np.integer)) or kmax < 1:
        raise ValueError(f"kmax must be a positive integer, got {kmax!r}")
    kmax = int(kmax)
    if method not in ("auto", "direct", "nufft"):
        raise ValueError(f"method must be 'auto', 'direct' or 'nufft', got {method!r}")
    freqs = np.arange(-kmax, kmax + 1)
    P = np.zeros((freqs.size, freqs.size))
    for pts in sets:
        fast = method == "nufft" or (method == "auto" and len(pts) * freqs.size ** 2 > _NUFFT_WORK)
        P += _nufft_power(pts, kmax) if fast else _direct_power(pts, kmax)
    P /= len(sets)
    P[kmax, kmax] = 0.0
    return freqs, P


#: Work ``n (2 kmax + 1)^2`` above which ``periodogram(method="auto")`` takes the NUFFT.
_NUFFT_WORK = 2e8

#: Half-width of the NUFFT's Gaussian in grid cells (12 gives power within about 1e-9).
_NUFFT_SPREAD = 12


def _direct_power(pts, kmax, weights=None):
    """|sum_j exp(-2 pi i k . x_j)|^2 / n at -kmax <= kx, ky <= kmax, by exact sums
    (with `weights`: ``|sum_j w_j exp(..)|^2 / sum_j w_j^2``)."""
    size = 2 * kmax + 1
    # P(-k) = P(k): compute the half plane ky >= 0 and mirror it
    F = np.zeros((kmax + 1, size), dtype=np.complex128)
    for start in range(0, len(pts), _CHUNK):
        block = pts[start:start + _CHUNK]
        ex = _phase_table(block[:, 0], kmax)  # f = 0 .. kmax
        ex = np.concatenate([ex[:, :0:-1].conj(), ex], axis=1)  # f = -kmax .. kmax
        if weights is not None:
            ex *= weights[start:start + _CHUNK, None]
        ey = _phase_table(block[:, 1], kmax)
        F += ey.T @ ex
    half = (F.real ** 2 + F.imag ** 2) / _norm(pts, weights)
    P = np.empty((size, size))
    P[kmax:] = half
    P[:kmax] = half[:0:-1, ::-1]  # P[-ky, -kx] = P[ky, kx]
    return P


def _norm(pts, weights):
    return len(pts) if weights is None else float(np.dot(weights, weights))


def _nufft_power(pts, kmax, spread=None, weights=None):
    """The power of :func:`_direct_power` by a type-1 non-uniform FFT (Gaussian gridding).

    The points are spread with the periodic Gaussian ``exp(-x^2 / (4 tau))``
    (x in radians) onto an M x M grid, M >= 2 (2 kmax + 1); the grid's FFT
    over M is the Fourier series of the spread points, and dividing it by
    the Gaussian's coefficients ``sqrt(tau / pi) exp(-k^2 tau)`` per axis
    leaves the point sums (L. Greengard and J.-Y. Lee, "Accelerating the
    nonuniform fast Fourier transform", SIAM Review 46(3), 2004; tau as
    there for oversampling R = M / (2 kmax + 1)).
    """
    msp = _NUFFT_SPREAD if spread is None else spread
    modes = 2 * kmax + 1
    M = fft.next_fast_len(2 * modes, real=True)
    R = M / modes
    tau = math.pi * msp / (modes * modes * R * (R - 0.5))
    G = _spread(np.mod(pts, 1.0), M, msp, tau, weights)
    k = np.arange(-kmax, kmax + 1)
    corr = math.sqrt(math.pi / tau) * np.exp(k * k * tau) / M
    F = fft.rfft2(G)[k % M, :kmax + 1] * corr[:, None] * corr[None, kmax:]   # kx >= 0
    half = (F.real ** 2 + F.imag ** 2) / _norm(pts, weights)
    P = np.empty((modes, modes))
    P[:, kmax:] = half
    P[:, :kmax] = half[::-1, kmax:0:-1]   # P[-ky, -kx] = P[ky, kx]
    return P


def _spread(pts, M, msp, tau, weights=None):
    """Sum over the points (times `weights`) of the periodic Gaussian on the M x M grid ``[iy, ix]``.

    Separable: the grid is ``Wy^T Wx`` with the sparse (n, M) tables of each
    point's 2 msp weights per axis, multiplied by scipy.sparse in row bands.
    """
    n, width = len(pts), 2 * msp
    ptr = np.arange(0, n * width + 1, width)
    off = np.arange(width) - msp + 1
    tables = []
    for u in (pts[:, 0] * M, pts[:, 1] * M):
        i = np.floor(u).astype(np.int64)[:, None] + off
        d = (i - u[:, None]) * (2.0 * math.pi / M)
        g = np.exp(d * d / (-4.0 * tau))
        if weights is not None and not tables:
            g *= weights[:, None]
        tables.append(sparse.csr_matrix((g.ravel(), (i % M).ravel(), ptr), shape=(n, M)))
    wx, wyt = tables[0], tables[1].T.tocsr()
    G = np.empty((M, M))
    band = max(1, (1 << 22) // M)
    for r in range(0, M, band):
        G[r:r + band] = (wyt[r:r + band] @ wx).toarray()
    return G


def _phase_table(x, kmax):
    """exp(-2 pi i f x) for every x (rows) and f = 0 .. kmax (columns).

    f = a B + b with B ~ sqrt(kmax): the table is the product of two small
    tables of exponentials of phases reduced mod 1, so every entry is within
    a few ulps of the direct value at a fraction of the cost.
    """
    B = int(math.ceil(math.sqrt(kmax + 1)))
    small = np.exp(-2j * np.pi * np.mod(np.outer(x, np.arange(B)), 1.0))
    big = np.exp(-2j * np.pi * np.mod(np.outer(x, np.arange(0, kmax + 1, B)), 1.0))
    table = (big[:, :, None] * small[:, None, :]).reshape(len(x), -1)
    return np.ascontiguousarray(table[:, : kmax + 1])  # contiguous: BLAS, not a slow path


def _annuli(P, freqs):
    P = np.asarray(P, dtype=np.float64)
    freqs = np.asarray(freqs)
    if P.ndim != 2 or P.shape != (freqs.size, freqs.size):
        raise ValueError(f"P must have shape ({freqs.size}, {freqs.size}) to match freqs, got {P.shape}")
    kx, ky = np.meshgrid(freqs, freqs)
    radius = np.hypot(kx, ky)
    kmax = int(np.max(np.abs(freqs)))
    idx = np.floor(radius + 0.5).astype(np.int64)  # annulus i: [i - 1/2, i + 1/2)
    keep = (idx >= 1) & (idx <= kmax)  # skip DC; only annuli fully inside the square
    return P[keep], idx[keep], kmax


def radial_power(P, freqs):
    """Radial mean power: the mean of ``P`` over annuli of width 1.

    Annulus ``i`` holds the frequencies with ``i - 1/2 <= |k| < i + 1/2`` and
    its centre is ``i``; annuli ``1 .. kmax`` are returned (those fully inside
    the computed square; annulus 0 is only the DC term).

    Parameters
    ----------
    P : ndarray, shape (m, m)
        A periodogram from :func:`periodogram`.
    freqs : ndarray, shape (m,)
        Its frequency axis.

    Returns
    -------
    centres : ndarray of float64, shape (kmax,)
        ``1, 2, .., kmax``.
    power : ndarray of float64, shape (kmax,)
        Mean power in each annulus (about 1 for uniform random points).

    References
    ----------
    .. [1] Lagae and Dutre 2008 (radially averaged power spectrum).
    .. [2] Heck, Schlomer and Deussen 2013 (radial power of blue noise).

    Examples
    --------
    >>> freqs, P = periodogram(np.random.default_rng(1).random((512, 2)), kmax=16)
    >>> centres, power = radial_power(P, freqs)
    >>> centres[:3]
    array([1., 2., 3.])
    """
    values, idx, kmax = _annuli(P, freqs)
    counts = np.bincount(idx, minlength=kmax + 1)[1:]
    sums = np.bincount(idx, weights=values, minlength=kmax + 1)[1:]
    return np.arange(1, kmax + 1, dtype=np.float64), sums / counts


def anisotropy(P, freqs):
    """Anisotropy in dB: variance of the power in each annulus over its squared mean.

    ``10 log10(var / mean^2)`` per annulus of :func:`radial_power` (sample
    variance, ``ddof=1``, over all frequencies of the annulus). Because the
    periodogram of a realization is roughly exponentially distributed, an
    isotropic set gives about 0 dB for one realization and about
    ``-10 log10(K)`` dB for the mean of K realizations; peaks and dips above
    that floor show directions. An annulus of zero mean power gives ``-inf``
    (a constant, isotropic annulus) or ``nan`` (all zero).

    Parameters
    ----------
    P : ndarray, shape (m, m)
        A (mean) periodogram from :func:`periodogram`.
    freqs : ndarray, shape (m,)
        Its frequency axis.

    Returns
    -------
    centres : ndarray of float64, shape (kmax,)
    anisotropy_db : ndarray of float64, shape (kmax,)

    References
    ----------
    .. [1] Lagae and Dutre 2008 (anisotropy of the mean periodogram).
    .. [2] Heck, Schlomer and Deussen 2013.

    Examples
    --------
    >>> rng = np.random.default_rng(2)
    >>> freqs, P = periodogram(rng.random((1024, 2)), kmax=32)
    >>> centres, a = anisotropy(P, freqs)
    >>> bool(abs(np.mean(a[8:])) < 1.0)
    True
    """
    values, idx, kmax = _annuli(P, freqs)
    counts = np.bincount(idx, minlength=kmax + 1)[1:].astype(np.float64)
    sums = np.bincount(idx, weights=values, minlength=kmax + 1)[1:]
    mean = sums / counts
    dev = values - mean[idx - 1]
    ss = np.bincount(idx, weights=dev * dev, minlength=kmax + 1)[1:]
    var = ss / (counts - 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        db = 10.0 * np.log10(var / (mean * mean))
    return np.arange(1, kmax + 1, dtype=np.float64), db


# ---------------------------------------------------------------------------
# distances


#: The plane (no wrap); nearest-neighbour distances do not use its size.
_PLANE = measures.PLANE
_domain = measures.as_domain
nearest_neighbor_distances = measures.nearest_neighbor_distances


def mean_normalized_radius(points):
    """Mean nearest-neighbour distance on the unit torus, normalized like rho.

    ``mean(d_nn) / 2 / r_max`` with ``r_max = sqrt(1 / (2 sqrt(3) n))``: 1 for
    a hexagonal packing that tiles the torus, and ``sqrt(2 sqrt(3)) / 4 = 0.465``
    on average for uniform random points (whose expected nearest-neighbour
    distance is ``1 / (2 sqrt(n))``). Less sensitive to one close pair than
    rho.

    References
    ----------
    .. [1] Lagae and Dutre 2008 (normalized Poisson disk radius).

    Examples
    --------
    >>> pts = np.random.default_rng(3).random((4096, 2))
    >>> 0.4 < mean_normalized_radius(pts) < 0.55
    True
    """
    p = check_points(points)
    return float(nearest_neighbor_distances(p, True).mean() / 2.0 / hexagonal_radius(len(p)))


# ---------------------------------------------------------------------------
# hexatic order


class HexaticOrder(NamedTuple):
    """Per-point ``|psi_6|`` and their mean.

    Examples
    --------
    >>> order = hexatic_order(np.random.default_rng(0).random((200, 2)))
    >>> order.psi6.shape, bool(0 < order.mean < 1)
    ((200,), True)
    """

    psi6: np.ndarray
    mean: float


def _torus_delaunay(p, domain):
    """Delaunay of p plus ghost copies near the edges, grown until certified.

    Returns (all_points, tri); vertices ``0 .. n-1`` are the original points.
    Every triangle with an original vertex must have its
    circumcircle inside the padded box: then it is empty of every periodic
    copy, i.e. it is a triangle of the periodic Delaunay triangulation.
    """
    n = len(p)
    box = domain.size
    margin = 3.0 * math.sqrt(box[0] * box[1] / n)  # about three spacings
    while True:
        m = np.minimum(margin, box)
        allp, _ = domain.images(p, m)
        tri = Delaunay(allp)
        simp = tri.simplices[(tri.simplices < n).any(axis=1)]
        centre, r = _circumcircles(allp[simp[:, 0]], allp[simp[:, 1]], allp[simp[:, 2]])
        inside = np.all((centre - r[:, None] >= -m) & (centre + r[:, None] <= box + m), axis=1)
        if np.all(inside) or np.all(m >= box):
            return allp, tri
        margin *= 2.0


def _circumcircles(a, b, c):
    bx, by = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    cx, cy = c[:, 0] - a[:, 0], c[:, 1] - a[:, 1]
    d = 2.0 * (bx * cy - by * cx)
    b2, c2 = bx * bx + by * by, cx * cx + cy * cy
    with np.errstate(divide="ignore", invalid="ignore"):
        ux = (cy * b2 - by * c2) / d
        uy = (bx * c2 - cx * b2) / d
    ux = np.where(np.isfinite(ux), ux, np.inf)
    uy = np.where(np.isfinite(uy), uy, np.inf)
    return a + np.stack([ux, uy], axis=1), np.hypot(ux, uy)


def hexatic_order(points, *, periodic=True, width=1.0, height=1.0):
    """Local hexatic order ``|psi_6|`` of every point, and its mean.

    ``psi_6(j) = (1 / N_j) sum_k exp(6 i theta_jk)`` over the N_j Voronoi
    neighbours k of point j (the points sharing a Delaunay edge with it),
    theta_jk the direction from j to k. ``|psi_6|`` is 1 for a point with six
    neighbours at multiples of 60 degrees (a hexagonal lattice) and about 0.3
    to 0.4 for uniform random points. Neighbours are counted with equal
    weights (not weighted by Voronoi edge length).

    Parameters
    ----------
    points : array_like, shape (n, 2), n >= 3
    periodic : bool
        ``True``: the torus [0,width) x [0,height); the Delaunay triangulation
        is computed with ghost copies of the points near the edges, and the
        copies are added until every triangle that touches an original point
        has its circumcircle inside the padded region (so the neighbours are
        exactly those of the periodic triangulation). ``False``: the bounded
        domain; the triangulation of the points alone, so points on the convex
        hull also count hull neighbours (a boundary effect worth remembering
        for small n).
    width, height : float
        Torus size (ignored when not periodic).

    Returns
    -------
    HexaticOrder
        ``psi6`` (n,) per-point ``|psi_6|`` and ``mean``. A point that coincides
        with another has no neighbours of its own and gets 0.

    Raises
    ------
    ValueError
        Fewer than 3 points, or no triangulation (all points coincide or
        lie on one line).

    References
    ----------
    .. [1] D. R. Nelson and B. I. Halperin, "Dislocation-mediated melting in
       two dimensions", Phys. Rev. B 19:2457, 1979 (bond orientational order).

    Examples
    --------
    >>> m, r = 26, 30    # rows of 26 points, 30 rows: nearly hexagonal on the torus
    >>> iy, ix = np.mgrid[0:r, 0:m]
    >>> pts = np.column_stack([((ix + 0.5 * (iy % 2)) / m).ravel(), (iy / r).ravel()])
    >>> round(hexatic_order(pts).mean, 4)
    1.0
    """
    p = check_points(points)
    n = len(p)
    if n < 3:
        raise ValueError("need at least 3 points")
    if periodic:
        if not (width > 0 and height > 0):
            raise ValueError(f"width and height must be positive, got {width} x {height}")
        dom = Domain(float(width), float(height), True)
        p = dom.wrap(p)
        try:
            allp, tri = _torus_delaunay(p, dom)
        except QhullError as exc:
            raise ValueError("the points are degenerate (fewer than 3 distinct points, or "
                             "all on one line): no Delaunay triangulation") from exc
    else:
        allp = p
        try:
            tri = Delaunay(p)
        except QhullError as exc:
            raise ValueError("points are collinear: no Delaunay triangulation") from exc
    indptr, indices = tri.vertex_neighbor_vertices
    counts = np.diff(indptr[: n + 1])
    src = np.repeat(np.arange(n), counts)
    dst = indices[: indptr[n]]
    d = allp[dst] - allp[src]
    z = np.exp(6j * np.arctan2(d[:, 1], d[:, 0]))
    s = np.bincount(src, weights=z.real, minlength=n) + 1j * np.bincount(src, weights=z.imag, minlength=n)
    psi = np.abs(s) / np.maximum(counts, 1)
    return HexaticOrder(psi, float(psi.mean()))
