"""Brute-force float64 oracles for the raster and exact-geometry stages.

Every function here is deliberately simple: it loops (or broadcasts) over
*all* sites and, on a torus, all 9 periodic images, with no buckets, trees or
pruning.  They share no code with the modules they check beyond
:class:`~diskpack_cl.Domain`, and are meant for small inputs (the tests).

On a unit-period torus the 3 x 3 images suffice: a power cell lies inside the
Voronoi cell of its own site's lattice of images (the square of side W x H
centred on the site), and for a point of that square the nearest image of
any other site is within one period in each direction; images of one site
share its weight, so only the nearest one can win.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np


__all__ = ["grid_centers", "images", "power_labels_ref", "boundary_distance_ref",
           "mic_estimate_ref", "chebyshev_ref", "lloyd_centroids_ref",
           "min_distance_ref", "certify_ref", "cells_within_ref", "ChebyshevRef"]

ChebyshevRef = namedtuple("ChebyshevRef", "center radius unique")


def _prep(points, weights, domain):
    X = np.array(points, dtype=np.float64).reshape(-1, 2)
    if domain.periodic:
        X = np.mod(X, (domain.width, domain.height))
        X[X >= (domain.width, domain.height)] = 0.0
    w = np.zeros(len(X)) if weights is None else np.array(weights, dtype=np.float64).reshape(-1)
    return X, w


def grid_centers(domain, shape):
    """Grid-cell centres ``((ix+0.5) W/nx, (iy+0.5) H/ny)``, shape (ny, nx, 2)."""
    ny, nx = shape
    x = (np.arange(nx) + 0.5) * (domain.width / nx)
    y = (np.arange(ny) + 0.5) * (domain.height / ny)
    gx, gy = np.meshgrid(x, y)
    return np.stack([gx, gy], -1)


def images(points, domain):
    """All 9 periodic images (torus) or the points themselves (rectangle).

    Returns
    -------
    pos : (m, 2) float64
    site : (m,) int
        Index of the original point of each image.
    """
    X = np.asarray(points, np.float64)
    n = len(X)
    if not domain.periodic:
        return X.copy(), np.arange(n)
    pos, site = [], []
    for sx in (-1, 0, 1):
        for sy in (-1, 0, 1):
            pos.append(X + (sx * domain.width, sy * domain.height))
            site.append(np.arange(n))
    return np.concatenate(pos), np.concatenate(site)


def _power_table(points, weights, domain, shape):
    """Power distances of every grid-cell centre to every image: (npix, m)."""
    X, w = _prep(points, weights, domain)
    P = grid_centers(domain, shape).reshape(-1, 2)
    pos, site = images(X, domain)
    d2 = ((P[:, None, :] - pos[None, :, :]) ** 2).sum(-1)
    return P, pos, site, d2 - w[site][None, :]


def power_labels_ref(points, weights, domain, shape):
    """Owning site of every grid-cell centre by brute force.

    Parameters
    ----------
    points : (n, 2) array_like
    weights : (n,) array_like or None
        Power weights; None means zeros (Voronoi).
    domain : Domain
    shape : tuple
        ``(ny, nx)``.

    Returns
    -------
    labels : (ny, nx) int
        Site of least power distance (ties to the lowest index).
    gap : (ny, nx) float64
        Second-best power distance over *other* sites minus the best one
        (inf with a single site): where it is tiny the label is a tie.
    """
    _, _, site, pw = _power_table(points, weights, domain, shape)
    n = int(site.max()) + 1
    per_site = np.full((pw.shape[0], n), np.inf)
    for k in range(n):
        per_site[:, k] = pw[:, site == k].min(axis=1)
    lab = np.argmin(per_site, axis=1)
    best = per_site[np.arange(len(lab)), lab]
    other = per_site.copy()
    other[np.arange(len(lab)), lab] = np.inf
    gap = other.min(axis=1) - best
    return lab.reshape(shape), gap.reshape(shape)


def boundary_distance_ref(points, weights, domain, shape):
    """Distance from each grid-cell centre to the boundary of its power cell.

    The minimum over every other site image j of the distance to the
    bisector line, ``((|p-x_j|^2-w_j)-(|p-x_i|^2-w_i)) / (2|x_j-x_i|)`` with
    x_i the owning image, and, in a rectangle, the distance to its edges.

    Returns
    -------
    dist : (ny, nx) float64
    labels : (ny, nx) int
        The owners used (as :func:`power_labels_ref`).
    """
    P, pos, site, pw = _power_table(points, weights, domain, shape)
    lab, _ = power_labels_ref(points, weights, domain, shape)
    lab = lab.ravel()
    # owning image: the best image of the owning site
    masked = np.where(site[None, :] == lab[:, None], pw, np.inf)
    own = np.argmin(masked, axis=1)
    rows = np.arange(len(P))
    xi = pos[own]
    sep = np.hypot(pos[None, :, 0] - xi[:, None, 0], pos[None, :, 1] - xi[:, None, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        dj = (pw - pw[rows, own][:, None]) / (2 * sep)
    dj[sep == 0] = np.inf
    D = dj.min(axis=1)
    if not domain.periodic:
        edge = np.minimum.reduce([P[:, 0], domain.width - P[:, 0], P[:, 1], domain.height - P[:, 1]])
        D = np.minimum(D, edge)
    return D.reshape(shape), lab.reshape(shape)


def mic_estimate_ref(labels, dist, n, domain):
    """Per-cell argmax of a distance map (ties to the lowest flat index).

    Returns
    -------
    centers : (n, 2) float64
        Grid-cell centre of the argmax (NaN where the cell has no grid cell).
    radii : (n,) float64
        The maximum (-1 where the cell has no grid cell).
    argpix : (n,) int
        Flat index of the argmax (-1 where none).
    """
    lab = np.asarray(labels).ravel()
    d = np.asarray(dist, np.float64).ravel()
    shape = np.asarray(labels).shape
    radii = np.full(n, -1.0)
    argpix = np.full(n, -1)
    for p in range(len(lab)):           # first strict maximum wins: lowest index on ties
        k = lab[p]
        if d[p] > radii[k]:
            radii[k] = d[p]
            argpix[k] = p
    C = grid_centers(domain, shape).reshape(-1, 2)
    centers = np.full((n, 2), np.nan)
    has = argpix >= 0
    centers[has] = C[argpix[has]]
    return centers, radii, argpix


def _halfplanes(points, weights, domain, i):
    """Constraints ``q . a_k <= b_k`` (unit a_k) of cell i, q relative to site i."""
    X, w = _prep(points, weights, domain)
    pos, site = images(X, domain)
    a = pos - X[i]
    L = np.hypot(a[:, 0], a[:, 1])
    keep = L > 0
    a, L, site = a[keep], L[keep], site[keep]
    A = a / L[:, None]
    b = (L * L - w[site] + w[i]) / (2 * L)
    if not domain.periodic:
        A = np.concatenate([A, [[-1.0, 0.0], [1.0, 0.0], [0.0, -1.0], [0.0, 1.0]]])
        b = np.concatenate([b, [X[i, 0], domain.width - X[i, 0], X[i, 1], domain.height - X[i, 1]]])
    return X, A, b


def chebyshev_ref(points, weights, domain, i, *, unique_tol=1e-6):
    """Chebyshev centre of power cell i by ``scipy.optimize.linprog`` on all constraints.

    Solves ``max R s.t. a_k . q + R <= b_k`` over every other site and image
    (and the rectangle edges), then checks uniqueness: with R fixed just
    below its optimum, the feasible centres must span less than
    `unique_tol` in x and y.

    Returns
    -------
    ChebyshevRef
        ``center`` (2,) absolute (wrapped on a torus), ``radius`` (negative:
        the cell is empty), ``unique`` bool.
    """
    from scipy.optimize import linprog

    X, A, b = _halfplanes(points, weights, domain, i)
    M = np.column_stack([A, np.ones(len(b))])
    res = linprog([0.0, 0.0, -1.0], A_ub=M, b_ub=b, bounds=[(None, None)] * 3, method="highs")
    if res.status != 0:
        raise RuntimeError(f"linprog failed: {res.message}")
    q, R = res.x[:2], res.x[2]
    scale = max(domain.width, domain.height)
    Rlow = R - 1e-9 * scale
    span = []
    for c in ([1, 0], [-1, 0], [0, 1], [0, -1]):
        r2 = linprog(c, A_ub=A, b_ub=b - Rlow, bounds=[(None, None)] * 2, method="highs")
        span.append(r2.fun if r2.status == 0 else -np.inf)
    unique = (-(span[0] + span[1]) < unique_tol * scale) and (-(span[2] + span[3]) < unique_tol * scale)
    c = X[i] + q
    if domain.periodic:
        c = np.mod(c, (domain.width, domain.height))
    return ChebyshevRef(c, float(R), bool(unique))


def lloyd_centroids_ref(points, weights, domain, shape, density=None):
    """Density-weighted centroids of the brute-force raster cells.

    Each grid-cell centre counts at its offset from the *owning image* of
    its site, so cells crossing the seam of a torus average one contiguous
    piece.

    Returns
    -------
    centroids : (n, 2) float64
        NaN where a cell has zero mass; wrapped on a torus.
    mass : (n,) float64
        Sum of the density over the cell's grid cells.
    """
    P, pos, site, pw = _power_table(points, weights, domain, shape)
    X, _ = _prep(points, weights, domain)
    n = len(X)
    lab, _ = power_labels_ref(points, weights, domain, shape)
    lab = lab.ravel()
    masked = np.where(site[None, :] == lab[:, None], pw, np.inf)
    own = np.argmin(masked, axis=1)
    off = P - pos[own]
    dens = np.ones(len(P)) if density is None else np.asarray(density, np.float64).ravel()
    mass = np.zeros(n)
    sx = np.zeros(n)
    sy = np.zeros(n)
    for p in range(len(P)):
        mass[lab[p]] += dens[p]
        sx[lab[p]] += dens[p] * off[p, 0]
        sy[lab[p]] += dens[p] * off[p, 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        c = X + np.stack([sx / mass, sy / mass], 1)
    if domain.periodic:
        c = np.mod(c, (domain.width, domain.height))
    return c, mass


def min_distance_ref(points, domain):
    """Smallest pairwise distance over all pairs (and images on a torus)."""
    X, _ = _prep(points, None, domain)
    n = len(X)
    best = np.inf
    for i in range(n):
        for j in range(i + 1, n):
            d = X[j] - X[i]
            if domain.periodic:
                for sx in (-1, 0, 1):
                    for sy in (-1, 0, 1):
                        best = min(best, np.hypot(d[0] + sx * domain.width, d[1] + sy * domain.height))
            else:
                best = min(best, np.hypot(d[0], d[1]))
    return best


def certify_ref(centers, radii, domain):
    """True when closed disks are inside the domain and pairwise disjoint (all pairs)."""
    C, _ = _prep(centers, None, domain)
    r = np.asarray(radii, np.float64)
    if not domain.periodic:
        if np.any(C[:, 0] - r < 0) or np.any(C[:, 0] + r > domain.width):
            return False
        if np.any(C[:, 1] - r < 0) or np.any(C[:, 1] + r > domain.height):
            return False
    for i in range(len(C)):
        for j in range(i + 1, len(C)):
            d = min_distance_ref(C[[i, j]], domain)
            if not d - r[i] - r[j] > 0:
                return False
    return True


def cells_within_ref(points, weights, domain, i, j, h):
    """True when power cells i and j (any periodic image of j) come within `h`.

    Feasibility LP for ``y`` in cell i and ``y'`` in an image of cell j with
    ``|y - y'|_inf <= h``: a necessary condition for two grid cells of
    spacing h, one in each cell, to be neighbours.
    """
    from scipy.optimize import linprog

    Xi, Ai, bi = _halfplanes(points, weights, domain, i)
    _, Aj, bj = _halfplanes(points, weights, domain, j)
    shifts = [(0.0, 0.0)]
    if domain.periodic:
        shifts = [(sx * domain.width, sy * domain.height) for sx in (-1, 0, 1) for sy in (-1, 0, 1)]
    for s in shifts:
        # variables (y, y'); y - x_i in cell i, y' - x_j - s in cell j
        A = np.zeros((len(bi) + len(bj) + 4, 4))
        b = np.zeros(len(A))
        A[:len(bi), :2] = Ai
        b[:len(bi)] = bi + Ai @ Xi[i]
        A[len(bi):len(bi) + len(bj), 2:] = Aj
        b[len(bi):len(bi) + len(bj)] = bj + Aj @ (Xi[j] + s)
        k = len(bi) + len(bj)
        A[k, [0, 2]] = 1, -1
        A[k + 1, [0, 2]] = -1, 1
        A[k + 2, [1, 3]] = 1, -1
        A[k + 3, [1, 3]] = -1, 1
        b[k:] = h
        res = linprog(np.zeros(4), A_ub=A, b_ub=b, bounds=[(None, None)] * 4, method="highs")
        if res.status == 0:
            return True
    return False
