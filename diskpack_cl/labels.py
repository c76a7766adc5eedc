"""Power-diagram labels of a grid and density-weighted cell centroids, on the host.

:func:`grid_power_labels` is the exact float64 counterpart of the OpenCL
``power_labels`` kernel (:class:`diskpack_cl.device.raster.PowerRaster`): the owner of
each grid-cell centre.  It is a nearest-neighbour query in lifted
coordinates: with ``C >= max w``,
``|p - x|^2 - w = |(p, 0) - (x, sqrt(C - w))|^2 - C``, so the site of least
power distance is the nearest lifted site.  :func:`cell_centroids` integrates
a density over the cells of any labelling (the raster's or this one).
"""

from __future__ import annotations

import numpy as np

__all__ = ["grid_centers", "grid_power_labels", "cell_centroids"]


def grid_centers(domain, shape):
    """Centres ``((ix + 0.5) W / nx, (iy + 0.5) H / ny)`` of a ``(ny, nx)`` grid, shape (ny * nx, 2).

    Row-major (iy slow, ix fast), like ``labels.ravel()``.

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> grid_centers(Domain.rect(4, 2), (1, 2)).tolist()
    [[1.0, 1.0], [3.0, 1.0]]
    """
    ny, nx = shape
    iy, ix = np.divmod(np.arange(nx * ny), nx)
    return np.column_stack([(ix + 0.5) * (domain.width / nx), (iy + 0.5) * (domain.height / ny)])


def grid_power_labels(points, weights, domain, shape):
    """Site of least power distance ``|p - x_i|^2 - w_i`` at every grid-cell centre (float64).

    Parameters
    ----------
    points : (n, 2) array_like
        Sites (wrapped into the torus when periodic).
    weights : (n,) array_like or None
        Power weights; None: the Voronoi diagram.
    domain : Domain
    shape : tuple of int
        ``(ny, nx)``.

    Returns
    -------
    (ny, nx) ndarray of int
        Ties (equal power distances) go to any of the tied sites.

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> grid_power_labels([[0.5, 0.5], [3.5, 0.5]], [0.0, 4.0], Domain.rect(4, 1), (1, 4)).tolist()
    [[0, 1, 1, 1]]
    """
    from scipy.spatial import cKDTree  # not loaded at start-up

    X = np.asarray(points, np.float64)
    if domain.periodic:
        X = domain.wrap(X)
    w = np.zeros(len(X)) if weights is None else np.asarray(weights, np.float64)
    lift = np.sqrt(w.max() - w) if len(w) else w
    sites = np.column_stack([X, lift])
    if domain.periodic:
        # the lift axis never wraps: its period is over twice its extent
        box = (domain.width, domain.height, 2.0 * float(lift.max(initial=0.0)) + 1.0)
        tree = cKDTree(sites, boxsize=box)
    else:
        tree = cKDTree(sites)
    q = np.column_stack([grid_centers(domain, shape), np.zeros(shape[0] * shape[1])])
    _, lab = tree.query(q, k=1)
    return lab.reshape(shape)


def cell_centroids(labels, points, density, domain):
    """Density-weighted centroids and masses of the cells of a grid labelling.

    Parameters
    ----------
    labels : (ny, nx) array_like of int
        Owning site of each grid cell.
    points : (n, 2) array_like
        The sites (wrapped into the torus when periodic).
    density : (ny, nx) array_like or None
        Non-negative density per grid cell (uniform when None).
    domain : Domain

    Returns
    -------
    centroids : (n, 2) float64
        NaN where a cell has zero mass (wrapped into the torus there).
    mass : (n,) float64
        Integral of the density over each cell (grid-cell area units).

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> c, m = cell_centroids([[0, 0, 1, 1]], [[1.0, 0.5], [3.0, 0.5]], None, Domain.rect(4, 1))
    >>> c.tolist(), m.tolist()
    ([[1.0, 0.5], [3.0, 0.5]], [2.0, 2.0])
    """
    lab = np.asarray(labels).ravel()
    ny, nx = np.shape(labels)
    pts = np.asarray(points, np.float64)
    if domain.periodic:
        pts = domain.wrap(pts)
    n = len(pts)
    hx, hy = domain.width / nx, domain.height / ny
    dens = np.ones(nx * ny) if density is None else np.asarray(density, np.float64).ravel()
    if dens.size != nx * ny:
        raise ValueError(f"density must have the raster shape {(ny, nx)}")
    iy, ix = np.divmod(np.arange(nx * ny), nx)
    # offsets from the owning site, so that a cell crossing the seam of a
    # torus averages its own contiguous piece
    dx = (ix + 0.5) * hx - pts[lab, 0]
    dy = (iy + 0.5) * hy - pts[lab, 1]
    if domain.periodic:
        dx -= domain.width * np.round(dx / domain.width)
        dy -= domain.height * np.round(dy / domain.height)
    mass = np.bincount(lab, dens, minlength=n)
    sx = np.bincount(lab, dens * dx, minlength=n)
    sy = np.bincount(lab, dens * dy, minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        c = pts + np.stack([sx / mass, sy / mass], 1)
    if domain.periodic:
        c = domain.wrap(c)
    return c, mass
