"""Point-set measures, written once: packing radius, distances, rho, coincident pairs.

Sampling (rho of a start set), relaxation (rho per iteration, the duplicate
check), analysis (nearest-neighbour spacing) and geometry all use these.
Distances are periodic (minimum image) on a torus and plain on a rectangle.
"""

from __future__ import annotations

import numpy as np

from .domain import Domain

__all__ = ["HEXAGONAL_CELL", "PLANE", "as_domain", "hexagonal_radius", "nearest_neighbors",
           "nearest_neighbor_distances",
           "min_distance", "min_distance_at_most", "normalized_radius", "coincident_pairs", "kdtree"]

#: Area per point of the densest (hexagonal) packing of unit disks, ``2 sqrt(3)``:
#: n disks of radius r pack at best into area ``2 sqrt(3) n r^2``.
HEXAGONAL_CELL = 2.0 * np.sqrt(3.0)


def hexagonal_radius(n, area=1.0):
    """Disk radius of the densest (hexagonal) packing of `n` disks in `area`.

    ``r_max = sqrt(area / (2 sqrt(3) n))`` (Lagae and Dutre 2008), the unit
    of the normalized Poisson disk radius.

    Examples
    --------
    >>> round(hexagonal_radius(1024), 6)
    0.01679
    """
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n}")
    return float(np.sqrt(area / (HEXAGONAL_CELL * n)))


def kdtree(points, domain):
    """``(X, tree)``: the points as float64 (wrapped on a torus) and a cKDTree over them.

    On a torus the tree is periodic (``boxsize``), so its distances are
    minimum-image distances.

    Examples
    --------
    >>> X, tree = kdtree([[1.05, 0.5], [0.95, 0.5]], Domain.torus())
    >>> round(float(tree.query(X[0], k=2)[0][1]), 12)
    0.1
    """
    from scipy.spatial import cKDTree

    X = np.asarray(points, np.float64)
    if domain.periodic:
        X = domain.wrap(X)
        return X, cKDTree(X, boxsize=(domain.width, domain.height))
    return X, cKDTree(X)


def nearest_neighbors(points, domain=Domain.torus()):
    """``(distance, index)`` of each point's nearest other point (n >= 2).

    Examples
    --------
    >>> d, j = nearest_neighbors([[0.05, 0.5], [0.95, 0.5], [0.4, 0.5]])
    >>> d.round(12).tolist(), j.tolist()
    ([0.1, 0.1, 0.35], [1, 0, 0])
    """
    X, tree = kdtree(points, domain)
    if len(X) < 2:
        raise ValueError("need at least 2 points")
    d, j = tree.query(X, k=2)
    return d[:, 1], j[:, 1]


#: The unbounded plane (no edges, no wrap).
PLANE = Domain(float("inf"), float("inf"), False)


def as_domain(domain):
    """The domain ``domain`` names: a Domain, True (unit torus), (W, H) (torus) or False (plane).

    Examples
    --------
    >>> as_domain(True)
    Domain(width=1.0, height=1.0, periodic=True)
    >>> as_domain((2, 1)).area
    2.0
    >>> as_domain(False).periodic
    False
    """
    if isinstance(domain, Domain):
        return domain
    if domain is True:
        return Domain.torus()
    if domain is False or domain is None:
        return PLANE
    box = np.asarray(domain, dtype=np.float64)
    if box.shape != (2,) or not np.all(box > 0):
        raise ValueError(f"periodic must be True, False or a domain size (W, H) > 0, "
                         f"got {domain!r}")
    return Domain(float(box[0]), float(box[1]), True)


def nearest_neighbor_distances(points, domain=Domain.torus()):
    """Distance from each point to its nearest other point (n >= 2): the one API.

    ``domain`` is a :class:`~diskpack_cl.Domain` (its torus, points wrapped
    into it, or its rectangle), ``True`` (the unit torus), ``(W, H)`` (the
    torus [0,W) x [0,H)) or ``False`` (the plane).

    Examples
    --------
    >>> nearest_neighbor_distances([[0.05, 0.5], [0.95, 0.5]]).round(12).tolist()
    [0.1, 0.1]
    >>> nearest_neighbor_distances([[0.05, 0.5], [0.95, 0.5]], False).round(12).tolist()
    [0.9, 0.9]
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"points must have shape (n, 2), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("points must be finite")
    return nearest_neighbors(p, as_domain(domain))[0]


def min_distance(points, domain=Domain.torus()):
    """Smallest pairwise distance (periodic on a torus), exact.

    Examples
    --------
    >>> round(min_distance([[0.05, 0.5], [0.95, 0.5]]), 12)
    0.1
    """
    return float(nearest_neighbor_distances(points, domain).min())


def min_distance_at_most(points, bound, domain=Domain.torus(), *, grow=False):
    """Smallest pairwise distance if it is at most `bound` (1e-9 relative; else ``inf``), exact.

    One KD-tree query for the pairs within ``bound (1 + 1e-9)``: at a million
    points, a few times faster than every point's nearest neighbour when few
    pairs are that close.  With ``grow=True`` the bound grows by 5 % until a
    pair is found (one tree), so the smallest distance is always returned.

    Examples
    --------
    >>> p = [[0.05, 0.5], [0.95, 0.5], [0.5, 0.5]]
    >>> round(min_distance_at_most(p, 0.2), 12), min_distance_at_most(p, 0.05)
    (0.1, inf)
    >>> round(min_distance_at_most(p, 0.05, grow=True), 12)
    0.1
    """
    X, tree = kdtree(points, domain)
    if len(X) < 2:
        raise ValueError("need at least 2 points")
    while not len(pairs := tree.query_pairs(bound * (1 + 1e-9), output_type="ndarray")):
        if not grow:
            return float("inf")
        bound *= 1.05
    d = X[pairs[:, 0]] - X[pairs[:, 1]]
    if domain.periodic:
        d -= np.round(d / domain.size) * domain.size
    dmin = float(np.sqrt((d * d).sum(axis=1)).min())
    return dmin if grow or dmin <= bound * (1 + 1e-9) else float("inf")


def normalized_radius(points, domain=Domain.torus()):
    """Normalized Poisson disk radius ``rho = (d_min / 2) / r_max``.

    ``r_max`` is :func:`hexagonal_radius` of n points in the domain's area
    (Lagae and Dutre 2008): 1 for a hexagonal packing.

    Examples
    --------
    >>> pts = np.random.default_rng(0).random((256, 2))
    >>> bool(0 < normalized_radius(pts) < 1)
    True
    """
    return 0.5 * min_distance(points, domain) / hexagonal_radius(len(points), domain.area)


def coincident_pairs(points, domain=Domain.torus(), tol=0.0):
    """Index pairs (i, j), i < j, of points closer than `tol` (identical when tol = 0).

    Examples
    --------
    >>> coincident_pairs([[0.0, 0.2], [1.0, 0.2], [0.5, 0.5]]).tolist()
    [[0, 1]]
    """
    if tol <= 0.0 and not _any_identical(points, domain):
        return np.empty((0, 2), dtype=np.intp)
    _, tree = kdtree(points, domain)
    pairs = tree.query_pairs(max(tol, 0.0), output_type="set")
    return np.array(sorted(pairs), dtype=np.intp).reshape(-1, 2)


def _any_identical(points, domain):
    """Whether two points coincide (wrapped into the torus on one), by one sort.

    The usual answer is no, and one sort of the points as complex numbers
    says so several times faster than a KD-tree (at a million points, about
    0.1 s against 0.6 s); a set that has duplicates then pays the tree too.
    Equal keys are contiguous after the sort (``-0.0 == 0.0`` too), so equal
    neighbours find every duplicate.  Non-2D input answers True (the tree decides).
    """
    X = np.asarray(points, np.float64)
    if X.ndim != 2 or X.shape[1] != 2:
        return True
    if domain.periodic:   # wrap() maps into [0, W) x [0, H): coincident means equal there
        X = domain.wrap(X)
    z = np.sort(np.ascontiguousarray(X).view(np.complex128).ravel())
    return bool(np.any(z[1:] == z[:-1]))
