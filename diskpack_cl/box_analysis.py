"""Spectra and measures of point sets in a box ``[0, W] x [0, H]`` (no periodic wrap).

A box set is not periodic, so the torus periodogram of
:func:`diskpack_cl.analysis.periodogram` would see the walls as a seam.
Here the box is mapped onto the unit square (``u = x / W``, ``v = y / H``)
and every point is weighted by the separable Hann window
``w = sin^2(pi u) sin^2(pi v)``, which vanishes, with its slope, on the
walls::

    P(k) = |sum_j w_j exp(-2 pi i k . u_j)|^2 / sum_j w_j^2

at integer k.  The window's Fourier series has terms at 0 and +-1 only,
so the mean of the weighted sum leaks into the 3 x 3 frequencies
``max(|kx|, |ky|) <= 1`` and nowhere else: for uniform random points the
expected power is exactly 1 at every other k, as on the torus.  That block
is set to 0 and left out of the radial means.  The window costs
resolution (a spectral line is three frequencies wide) and gives the
points near the walls little weight: the spectrum is that of the box's
interior.  Radial means take annuli of width 1 in ``|f| sqrt(W H)`` (``f``
the physical frequency ``(kx / W, ky / H)``), so the blue-noise peak sits
near ``sqrt(n)`` whatever the aspect ratio, as on the unit torus.

Nearest neighbours, rho and the hexatic order are taken without wrap
(rho normalized by the box's area).
"""

from __future__ import annotations

import math

import numpy as np

from . import analysis
from .domain import Domain
from .measures import hexagonal_radius, nearest_neighbor_distances

__all__ = ["box_periodogram", "box_radial", "box_measures"]


def _scaled(sets, box):
    W, H = box
    out = []
    for s in sets:
        if np.any(s < 0) or np.any(s > (W, H)):
            raise ValueError(f"points must lie in the box [0, {W:g}] x [0, {H:g}]")
        out.append(s / (W, H))
    return out


def box_periodogram(points_or_list, box, *, kmax=None):
    """Mean Hann-windowed periodogram of point sets in the box ``(W, H)``.

    Parameters
    ----------
    points_or_list : array_like
        One (n, 2) set, a (K, n, 2) stack or a sequence of sets, in the box.
    box : (float, float)
        ``(W, H)``.
    kmax : int, optional
        Largest integer frequency per axis (of the box mapped onto the unit
        square); default: enough for annuli up to ``2 sqrt(n)`` in
        ``|f| sqrt(W H)``.

    Returns
    -------
    freqs : (2 kmax + 1,) int
    P : (2 kmax + 1, 2 kmax + 1) float64
        ``P[iy, ix]`` at ``k = (freqs[ix], freqs[iy])``; 0 where
        ``max(|kx|, |ky|) <= 1`` (the window's own transform).

    Examples
    --------
    >>> pts = np.random.default_rng(0).random((400, 2)) * (2, 1)
    >>> freqs, P = box_periodogram(pts, (2, 1), kmax=10)
    >>> P.shape, float(P[10, 11]), 0.3 < float(P[P > 0].mean()) < 3
    ((21, 21), 0.0, True)
    """
    W, H = map(float, box)
    sets = _scaled(analysis._as_realizations(points_or_list), (W, H))
    if kmax is None:
        aspect = math.sqrt(max(W / H, H / W))
        kmax = max(2, int(math.ceil(2.0 * math.sqrt(np.mean([len(s) for s in sets])) * aspect)))
    kmax = int(kmax)
    P = np.zeros((2 * kmax + 1, 2 * kmax + 1))
    for u in sets:
        w = (np.sin(np.pi * u[:, 0]) * np.sin(np.pi * u[:, 1])) ** 2
        fast = len(u) * P.size > analysis._NUFFT_WORK
        P += (analysis._nufft_power(u, kmax, weights=w) if fast
              else analysis._direct_power(u, kmax, weights=w))
    P /= len(sets)
    P[kmax - 1:kmax + 2, kmax - 1:kmax + 2] = 0.0
    return np.arange(-kmax, kmax + 1), P


def box_radial(P, freqs, box):
    """Radial mean power and anisotropy (dB) in annuli of width 1 of ``|f| sqrt(W H)``.

    Annuli ``1 .. R`` with R the largest fully inside the computed
    frequencies; the window's 3 x 3 block is left out (an annulus that
    lies wholly in it, as annulus 1 of a square box, is nan).

    Returns
    -------
    centres, power, anisotropy_db : (R,) float64

    Examples
    --------
    >>> pts = np.random.default_rng(1).random((400, 2)) * (2, 1)
    >>> freqs, P = box_periodogram(pts, (2, 1), kmax=12)
    >>> c, p, a = box_radial(P, freqs, (2, 1))
    >>> c[:3].tolist(), len(c) == len(p) == len(a)
    ([1.0, 2.0, 3.0], True)
    """
    W, H = map(float, box)
    kx, ky = np.meshgrid(freqs, freqs)
    sx, sy = math.sqrt(H / W), math.sqrt(W / H)
    fr = np.hypot(kx * sx, ky * sy)
    R = int(math.floor(freqs[-1] * min(sx, sy) - 0.5))
    ring = np.rint(fr).astype(np.int64)
    use = (np.maximum(np.abs(kx), np.abs(ky)) > 1) & (ring >= 1) & (ring <= R)
    counts = np.bincount(ring[use], minlength=R + 1)[1:]
    sums = np.bincount(ring[use], P[use], minlength=R + 1)[1:]
    squares = np.bincount(ring[use], P[use] ** 2, minlength=R + 1)[1:]
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = sums / counts
        var = (squares - counts * mean ** 2) / (counts - 1)
        aniso = 10 * np.log10(var / mean ** 2)
    return np.arange(1.0, R + 1), mean, aniso


def box_measures(sets, box, *, kmax=None):
    """The numbers of ``diskpack analyze`` for point sets in a box (see the module docstring).

    Returns
    -------
    numbers : dict
        As :func:`diskpack_cl.plots.point_set_numbers`, plus ``box`` and
        ``window``.
    curves : tuple
        ``(freqs, P, centres, power, anisotropy_db)``.

    Examples
    --------
    >>> pts = np.random.default_rng(2).random((300, 2)) * (2, 1)
    >>> numbers, _ = box_measures([pts], (2, 1), kmax=12)
    >>> numbers["box"], numbers["window"], numbers["n"]
    ([2.0, 1.0], 'hann', 300)
    """
    W, H = map(float, box)
    dom = Domain.rect(W, H)
    freqs, P = box_periodogram(sets, (W, H), kmax=kmax)
    centres, power, aniso = box_radial(P, freqs, (W, H))
    rhos, mean_rhos = [], []
    for s in sets:
        nn = nearest_neighbor_distances(s, dom)
        r_max = hexagonal_radius(len(s), dom.area)
        rhos.append(0.5 * nn.min() / r_max)
        mean_rhos.append(0.5 * nn.mean() / r_max)
    psi6 = (analysis.hexatic_order(sets[0], periodic=False, width=W, height=H).mean
            if len(sets[0]) >= 3 else float("nan"))
    finite = np.isfinite(aniso)
    peak = int(np.nanargmax(power))
    numbers = {"n": int(len(sets[0])), "realizations": len(sets), "kmax": int(freqs[-1]),
               "box": [W, H], "window": "hann", "rho": rhos[0], "rho_min": min(rhos),
               "rho_mean": float(np.mean(rhos)), "mean_rho": float(np.mean(mean_rhos)),
               "psi6_mean": psi6, "peak_frequency": float(centres[peak]),
               "peak_power": float(power[peak]),
               "anisotropy_mean_db": float(aniso[finite].mean()) if finite.any() else None,
               "anisotropy_reference_db": -10.0 * math.log10(len(sets)),
               "radial_frequency": centres.tolist(), "radial_power": power.tolist(),
               "anisotropy_db": aniso.tolist()}
    return numbers, (freqs, P, centres, power, aniso)
