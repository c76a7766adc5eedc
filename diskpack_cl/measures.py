"""Point-set measures, written once: packing radius, distances, rho, coincident pairs.

Sampling (rho of a start set), relaxation (rho per iteration, the duplicate
check), analysis (nearest-neighbour spacing) and geometry all use these.
Distances are periodic (minimum image) on a torus and plain on a rectangle.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ._cores import on_cores
from .domain import Domain

__all__ = ["HEXAGONAL_CELL", "PLANE", "as_domain", "ball_candidates", "bucket_order", "close_pairs",
           "hexagonal_radius", "nearest_neighbors", "nearest_neighbor_distances", "min_distance",
           "min_distance_at_most", "min_distance_since", "normalized_radius", "coincident_pairs", "kdtree"]

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
    from scipy.spatial import cKDTree  # not loaded at start-up

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

    The pairs within ``bound (1 + 1e-9)`` are found by a grid of cells of
    side at least that (:func:`_grid_min_distance`): at a million points a
    few times faster than a KD-tree.  With ``grow=True`` the smallest
    distance is always returned: the grid's cells are at least the mean
    spacing wide, so its neighbour cells hold the closest pair of any set
    that is not clustered; one that is goes to the KD-tree, whose bound
    grows by 5 % until a pair is found.

    Examples
    --------
    >>> p = [[0.05, 0.5], [0.95, 0.5], [0.5, 0.5]]
    >>> round(min_distance_at_most(p, 0.2), 12), min_distance_at_most(p, 0.05)
    (0.1, inf)
    >>> round(min_distance_at_most(p, 0.05, grow=True), 12)
    0.1
    """
    X = np.asarray(points, np.float64)
    if len(X) < 2:
        raise ValueError("need at least 2 points")
    reach = bound * (1 + 1e-9)
    found = _grid_min_distance(X, reach, domain)
    if found is not None:
        dmin, side = found
        if dmin <= reach or (grow and dmin < side):
            return dmin
        if not grow:
            return float("inf")
    return _kdtree_min_distance_at_most(X, bound, domain, grow)


def _kdtree_min_distance_at_most(points, bound, domain, grow):
    """:func:`min_distance_at_most` by one KD-tree query (the grid's fallback)."""
    X, tree = kdtree(points, domain)
    while not len(pairs := tree.query_pairs(bound * (1 + 1e-9), output_type="ndarray")):
        if not grow:
            return float("inf")
        bound *= 1.05
    dmin = float(_pair_distances(X, pairs[:, 0], pairs[:, 1], domain).min())
    return dmin if grow or dmin <= bound * (1 + 1e-9) else float("inf")


def _pair_distances(X, i, j, domain):
    """Distances of the pairs ``(i[k], j[k])`` of X (minimum image on a torus)."""
    # np.take and a column at a time: numpy's row gather X[i] and its reduction along rows
    # of two run their inner loops two values long (the same sums: dx^2 + dy^2)
    d = domain.shortest(np.take(X, i, axis=0) - np.take(X, j, axis=0))
    dx, dy = d[:, 0], d[:, 1]
    return np.sqrt(dx * dx + dy * dy)


#: A grid's cells are this much wider than the distance asked for, so that
#: rounding in ``floor(x / side)`` cannot put a pair within it two cells apart.
_GRID_MARGIN = 1 + 1e-6

#: Candidate pairs per point beyond which a (clustered) set goes to the KD-tree,
#: which bounds the grid's memory (a relaxed or uniform set has about 4).
_GRID_PAIRS_PER_POINT = 16

#: Half of the 3 x 3 neighbourhood: each pair of adjacent cells is compared once.
_HALF_NEIGHBOURS = ((1, 0), (-1, 1), (0, 1), (1, 1))


def _grid_min_distance(X, reach, domain):
    """``(dmin, side)``: the smallest distance of the pairs in the same or adjacent
    cells of a grid of cells of side ``side >= reach``, or None where the grid
    does not serve (see :func:`_grid_cells`, and a clustered set).

    Every pair closer than ``side`` lies in adjacent cells (``side`` is the
    cells' width less the margin), so ``dmin`` is the exact smallest distance
    when it is below ``side`` (``inf`` if no pair is adjacent).  Distances are computed as the KD-tree path computes them.
    """
    found = _grid_candidates(X, reach, domain)
    if found is None:
        return None
    xy, ranges, grid = found
    d2 = min(_range_pairs(xy, first, count, domain)[2].min(initial=np.inf) for first, count in ranges)
    return float(np.sqrt(d2)), grid.side


def _grid_candidates(X, reach, domain):
    """``(xy, ranges, grid)``: :func:`_grid_min_distance`'s coordinates in cell order,
    the partners' ranges (:func:`_candidate_ranges`) and the :class:`_SortedGrid`;
    None where the grid does not serve."""
    cells = _grid_cells(X, reach, domain)
    if cells is None:
        return None
    X, cell, shape, extent, lo = cells
    (order, start, count), ranges, total = _candidate_ranges(cell[:, 0] * shape[1] + cell[:, 1],
                                                             shape, domain.periodic)
    if total > _GRID_PAIRS_PER_POINT * len(X):
        return None
    # along an axis of one cell (a box's) every point shares it: no limit there
    width = np.where(shape > 1, extent / shape, np.inf).min()
    grid = _SortedGrid(order, start, count, shape, lo, _per_length(shape, extent),
                       float(width) / _GRID_MARGIN)
    return list(np.take(X, order, axis=0).T.copy()), ranges, grid


class _SortedGrid(NamedTuple):
    """Points sorted by the cells of a grid: ``order``, and per flat cell the
    ``start`` and ``count`` of its run in that order; the cells' geometry
    (:func:`_grid_cells`); pairs closer than ``side`` lie in adjacent cells."""
    order: np.ndarray
    start: np.ndarray
    count: np.ndarray
    shape: np.ndarray
    lo: np.ndarray
    per_length: np.ndarray
    side: float

    def cells(self, X):
        """``(column, row)`` of each of the points X (clamped into the grid)."""
        return _cells_of(X, self.lo, self.per_length, self.shape)


class ClosePairs(NamedTuple):
    """:func:`close_pairs`' answer: the pairs ``(i[k], j[k])``, ``i < j``, their
    distances ``d``, the `reach` asked, and the grid that found them."""
    i: np.ndarray
    j: np.ndarray
    d: np.ndarray
    reach: float
    grid: _SortedGrid


def close_pairs(points, reach, domain=Domain.torus()):
    """Every pair of points at most `reach` apart, with its exact distance (as
    :func:`min_distance` measures it), or None for a clustered set (the grid of
    cells this searches would hold too many pairs; a KD-tree serves there).

    Returns
    -------
    ClosePairs or None

    Examples
    --------
    >>> p = [[0.05, 0.5], [0.95, 0.5], [0.5, 0.5], [0.5, 0.1]]
    >>> found = close_pairs(p, 0.2)
    >>> found.i.tolist(), found.j.tolist(), np.round(found.d, 12).tolist()
    ([0], [1], [0.1])
    """
    X = np.asarray(points, np.float64)
    found = _grid_candidates(X, reach, domain)
    if found is None:
        return None
    xy, ranges, grid = found
    parts = []
    for first, count in ranges:
        i, j, d2 = _range_pairs(xy, first, count, domain)
        d = np.sqrt(d2)
        keep = d <= reach
        i, j = grid.order[i[keep]], grid.order[j[keep]]
        parts.append((np.minimum(i, j), np.maximum(i, j), d[keep]))
    i, j, d = (np.concatenate(a) for a in zip(*parts))
    return ClosePairs(i, j, d, float(reach), grid)


#: Fewest moved points a thread of :func:`min_distance_since` searches from.
_MOVED_PART = 20_000


def min_distance_since(points, before, pairs, domain=Domain.torus()):
    """Smallest pairwise distance of `points` if it is at most ``pairs.reach``
    (else ``inf``), exact, from the :func:`close_pairs` of an earlier state of them.

    The pairs of points that did not move since `before` keep their
    distances; the points that moved are searched again, among themselves
    and in the cells of the earlier grid: after a few local moves, a small
    part of a full search.

    Parameters
    ----------
    points, before : (n, 2) array_like
        The points now, and when `pairs` was found.
    pairs : ClosePairs
        ``close_pairs(before, reach, domain)``.
    domain : Domain

    Examples
    --------
    >>> p = np.array([[0.05, 0.5], [0.95, 0.5], [0.5, 0.5], [0.5, 0.1]])
    >>> q = p.copy(); q[2] = [0.5, 0.25]
    >>> round(min_distance_since(q, p, close_pairs(p, 0.2)), 12)
    0.1
    >>> q[0] = [0.5, 0.35]
    >>> round(min_distance_since(q, p, close_pairs(p, 0.2)), 12)
    0.1
    """
    X, old = (np.ascontiguousarray(a, np.float64) for a in (points, before))
    if domain.periodic:   # as close_pairs saw them, and the cells take them
        X, old = domain.wrap(X), domain.wrap(old)
    # a row as one complex number: np.any over rows of two runs two values a loop
    moved = X.view(np.complex128).ravel() != old.view(np.complex128).ravel()
    still = ~(moved[pairs.i] | moved[pairs.j])
    best = float(pairs.d[still].min(initial=np.inf))
    M = np.flatnonzero(moved)
    if len(M) >= 2:
        best = min(best, min_distance_at_most(X[M], pairs.reach, domain))
    if len(M):   # on the cores: the end of a local relaxation waits for this search
        found = []
        on_cores(lambda rows: found.append(_to_unmoved(X, M[rows], moved, pairs, domain)),
                 len(M), len(M), _MOVED_PART)
        best = min(best, *found)
    return best


def _to_unmoved(X, M, moved, pairs, domain):
    """Smallest distance at most ``pairs.reach`` from a point of `M` to a point that
    did not move (``inf`` if none): those sit in the earlier grid's cells, and a
    partner within its side lies in the 3 x 3 cells around a point's own."""
    grid = pairs.grid
    near = _neighbour_cells(grid.cells(X[M]), grid.shape, domain.periodic).ravel()
    i, j = _partners(M, near, grid.start, grid.count, grid.order)
    keep = ~moved[j]
    d = _pair_distances(X, i[keep], j[keep], domain)
    return float(d[d <= pairs.reach].min(initial=np.inf))


def _grid_cells(X, reach, domain):
    """``(X, cell, shape, extent, lo)``: the points (wrapped on a torus), each one's
    ``(column, row)`` in a grid of ``shape`` cells of side at least ``reach``
    over ``extent`` from ``lo``, or None where a grid does not serve (non-finite points,
    fewer than 3 cells across a torus, where neighbour cells would repeat)."""
    if not np.all(np.isfinite(X)):
        return None
    if domain.periodic:
        X = domain.wrap(X)
        lo, extent = np.zeros(2), domain.size
    else:   # a column at a time: along rows of two, numpy's reduction runs its loop two long
        lo = np.array([X[:, 0].min(), X[:, 1].min()])
        extent = np.array([X[:, 0].max(), X[:, 1].max()]) - lo
    # at most 4n cells, and 4n along a line of points (a box's extent can be 0)
    spacing = max(0.5 * np.sqrt(np.prod(extent) / len(X)), 0.25 * extent.max() / len(X))
    side = max(reach, spacing) * _GRID_MARGIN
    shape = np.maximum(np.floor(extent / side), 1).astype(np.int64)
    if domain.periodic and shape.min() < 3:
        return None
    per_length = _per_length(shape, extent)
    return X, _cells_of(X, lo, per_length, shape), shape, extent, lo


def _cells_of(X, lo, per_length, shape):
    """``(column, row)`` of each of the points X in a grid of ``shape`` cells from `lo`,
    `per_length` cells per unit length (clamped into the grid), a column at a time: an
    ``(n, 2)`` broadcast runs numpy's inner loop two values at a time."""
    cell = np.empty(X.shape, np.int64)
    for k in range(2):
        cell[:, k] = np.clip((X[:, k] - lo[k]) * per_length[k], 0, shape[k] - 1)
    return cell


def _per_length(shape, extent):
    """Cells per unit length along each axis (0 along an axis of no extent)."""
    return np.divide(shape, extent, out=np.zeros(2), where=extent > 0)


def ball_candidates(points, centres, reach, domain=Domain.torus()):
    """``(i, j)``: a superset of the pairs of a point ``i`` of `centres` and a
    point ``j`` of `points` (``i`` itself included) within `reach`, or None
    where a grid does not serve.

    The pairs are those in the same or adjacent cells of a grid of cells of
    side at least `reach`; only the points of the cells around a centre are
    sorted, so a few centres among many points cost little more than one
    pass over the points.  The caller measures the distances (as
    :func:`_pair_distances` does) and keeps the pairs it wants; where this
    returns None (see :func:`_grid_cells`), a KD-tree's ball query serves.

    Examples
    --------
    >>> p = np.array([[0.05, 0.5], [0.95, 0.5], [0.5, 0.5], [0.5, 0.1]])
    >>> i, j = ball_candidates(p, np.array([0]), 0.2)
    >>> sorted(j[_pair_distances(p, i, j, Domain.torus()) <= 0.2].tolist())
    [0, 1]
    """
    grid = _grid_cells(np.asarray(points, np.float64), reach, domain)
    if grid is None:
        return None
    _, cell, shape, _, _ = grid
    flat = cell[:, 0] * shape[1] + cell[:, 1]
    near = _neighbour_cells(cell[centres], shape, domain.periodic).ravel()
    inside = near >= 0
    mark = np.zeros(int(shape.prod()), dtype=bool)
    mark[near[inside]] = True
    order = np.flatnonzero(mark[flat])
    order = order[np.argsort(flat[order], kind="stable")]
    count = np.bincount(flat[order], minlength=len(mark))
    return _partners(centres, near, np.cumsum(count) - count, count, order)


def _partners(centres, near, start, count, order):
    """``(i, j)``: each of `centres` paired with every point of the 3 x 3 cells `near`
    around it (flat indices, the centres' nine in a row, -1 for none), from points
    sorted by cell: `order`, and per cell the `start` and `count` of its run."""
    count = np.where(near >= 0, count[near], 0)
    i = np.repeat(np.repeat(centres, len(_NEIGHBOURS)), count)
    return i, order[_range_indices(start[near], count)]


#: The 3 x 3 neighbourhood of a cell, itself included.
_NEIGHBOURS = np.array([(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)])


def _neighbour_cells(cell, shape, periodic):
    """``(m, 9)`` flat indices of the 3 x 3 cells around each of `cell` (in the grid):
    wrapped on a torus, -1 past a box's edge.  A column of the answer at a time, from
    the three shifted columns and rows: an ``(m, 9, 2)`` broadcast runs numpy's inner
    loops two values long."""
    shifted = []
    for axis in (0, 1):
        c = [cell[:, axis] - 1, cell[:, axis], cell[:, axis] + 1]
        if periodic:   # one cell past an edge at most
            c[0] = np.where(c[0] < 0, c[0] + shape[axis], c[0])
            c[2] = np.where(c[2] >= shape[axis], c[2] - shape[axis], c[2])
        shifted.append([(v, (v >= 0) & (v < shape[axis])) for v in c])
    out = np.empty((len(cell), len(_NEIGHBOURS)), np.int64)
    for k, (dx, dy) in enumerate(_NEIGHBOURS):
        (a, a_in), (b, b_in) = shifted[0][dx + 1], shifted[1][dy + 1]
        out[:, k] = a * shape[1] + b
        if not periodic:
            out[~(a_in & b_in), k] = -1
    return out


def _candidate_ranges(flat, shape, periodic):
    """``((order, start, count), ranges, total)``: the points' order by cell with each
    flat cell's ``start`` and ``count`` in it; an iterator, per neighbour offset, of
    ``(first, count)`` of each sorted point's partners (contiguous in that order): the
    later points of its own cell, then all points of each of half its neighbour
    cells; and the number of partners in all.  The iterator makes each offset's two
    arrays when it is reached: held all at once, they were most of a million-point
    search's memory, and each first touch of a fresh page costs a page fault."""
    order = bucket_order(flat)
    own = flat[order]
    count = np.bincount(own, minlength=int(shape.prod()))
    start = np.cumsum(count) - count
    cells = count.reshape(tuple(shape))
    # own cell: each pair once; a neighbour cell: every point of it
    total = int((count * (count - 1)).sum()) // 2 + sum(
        int(np.vdot(cells, _shifted(cells, offset, periodic))) for offset in _HALF_NEIGHBOURS)
    return (order, start, count), _ranges(own, start, count, shape, periodic), total


def _ranges(own, start, count, shape, periodic):
    """The ``(first, count)`` pairs of :func:`_candidate_ranges`, one offset at a time."""
    i = np.arange(len(own))
    yield i + 1, start[own] + count[own] - i - 1
    del i
    count, start = count.reshape(tuple(shape)), start.reshape(tuple(shape))
    for offset in _HALF_NEIGHBOURS:
        yield (_shifted(start, offset, periodic).ravel()[own],
               _shifted(count, offset, periodic).ravel()[own])


def bucket_order(bid, hint=None):
    """``np.argsort(bid, kind="stable")`` for non-negative integer bucket ids.

    Below 2^16, one stable radix pass of 16-bit keys; below 2^32, two
    (least significant first), which numpy sorts stably by radix, several
    times faster than its merge sort of 64-bit keys. With `hint` (a
    permutation of the ids' indices, such as the order of the same sites a
    step before) and ids of 2^16 or more, the unique keys ``(id, index)``
    are sorted in the hint's order instead: numpy's timsort merges the long
    sorted runs of a set that moved little in about half the two passes'
    time (1M sites). The keys being unique, any hint gives the same answer.

    Examples
    --------
    >>> bucket_order(np.array([70000, 3, 70000, 0, 3])).tolist()
    [3, 1, 4, 0, 2]
    >>> bucket_order(np.array([70000, 3, 70000, 0, 3]), hint=np.array([4, 3, 2, 1, 0])).tolist()
    [3, 1, 4, 0, 2]
    """
    bid = np.asarray(bid)
    n = len(bid)
    if not n:
        return np.argsort(bid, kind="stable")
    top = int(bid.max())
    if top < 2 ** 16:
        return np.argsort(bid.astype(np.uint16), kind="stable")
    if hint is not None and len(hint) == n and top < 2 ** 62 // n:
        key = bid.astype(np.int64) * n
        key += np.arange(n)
        hint = np.asarray(hint)
        return hint[np.argsort(key[hint], kind="stable")]
    if top >= 2 ** 32:
        return np.argsort(bid, kind="stable")
    low = np.argsort((bid & 0xFFFF).astype(np.uint16), kind="stable")
    return low[np.argsort((bid[low] >> 16).astype(np.uint16), kind="stable")]


def _shifted(grid, offset, periodic):
    """``grid[c + offset]`` at each cell c: wrapped on a torus, 0 past a box's edge."""
    if periodic:
        return np.roll(grid, (-offset[0], -offset[1]), axis=(0, 1))
    out = np.zeros_like(grid)
    src = tuple(slice(max(o, 0), grid.shape[k] + min(o, 0)) for k, o in enumerate(offset))
    dst = tuple(slice(max(-o, 0), grid.shape[k] + min(-o, 0)) for k, o in enumerate(offset))
    out[dst] = grid[src]
    return out


def _range_indices(first, count):
    """``first[k], ..., first[k] + count[k] - 1`` for every k, one after the other."""
    return np.repeat(first - np.cumsum(count) + count, count) + np.arange(int(count.sum()))


def _range_pairs(xy, first, count, domain):
    """``(i, j, d2)``: each point i paired with the points ``first[i] .. first[i] +
    count[i] - 1``, and their squared distance as :func:`_pair_distances` computes it
    (its square root is that distance, bit for bit)."""
    i = np.repeat(np.arange(len(first)), count)
    j = _range_indices(first, count)
    d2 = np.zeros(len(i))
    for coord, size in zip(xy, domain.size):
        d = coord[i] - coord[j]
        if domain.periodic:
            d -= np.round(d / size) * size
        d2 += d * d
    return i, j, d2


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


def _crowded(X, domain):
    """Which points of X share their cell of a grid of about 4 cells a point with
    another: coincident points share every cell, so the sorts of :func:`_any_identical`
    need only these.  A set of rho above about 0.66 (a spacing over the cells'
    diagonal; the dart sets of :func:`diskpack_cl.poisson_disk` have 0.72) has none,
    and the count of the points per cell costs a quarter of the sort of a million x.
    Coordinates outside the domain go to its edge cells, NaN to the first (fmax, fmin:
    a NaN cast to an integer would be no index): equal values still share a cell."""
    side = 0.5 * np.sqrt(domain.area / max(len(X), 1))
    nx, ny = (max(1, min(int(s / side), 1 << 15)) for s in domain.size)
    # row * nx + col in two float arrays, in place (exact: under 2**30 cells), not eight
    # fresh ones: a process's first call pays each array's pages
    cells = _clamped_floor(X[:, 1], ny / domain.height, ny - 1)
    col = _clamped_floor(X[:, 0], nx / domain.width, nx - 1)
    cells *= nx
    cells += col
    cells = cells.astype(np.intp)
    # first whether every point has a cell of its own: a mark a cell (a byte; no count,
    # and no read back at every point): 7.5 against 17 ms at 1M, 10 against 107 ms in a
    # process's first call (the counts' 32 MB of fresh pages)
    taken = np.zeros(nx * ny, np.bool_)
    taken[cells] = True
    if np.count_nonzero(taken) == len(cells):
        return np.zeros(len(cells), np.bool_)
    return np.bincount(cells, minlength=nx * ny)[cells] > 1


def _clamped_floor(x, scale, top):
    """``floor(x * scale)`` clamped to ``[0, top]`` as float64, NaN to 0 (``fmax``), in one
    fresh array: the cast to an integer of :func:`_crowded`'s values, bit for bit."""
    v = np.multiply(x, scale)
    np.fmax(v, 0, out=v)
    np.fmin(v, top, out=v)
    return np.trunc(v, out=v)


def _any_identical(points, domain):
    """Whether two points coincide (wrapped into the torus on one), by one sort or two.

    The usual answer is no, and one sort of the points as complex numbers
    says so several times faster than a KD-tree (at a million points, about
    0.1 s against 0.6 s), a sort of their x alone faster still (0.02 s) where
    no two x are equal; a set that has duplicates then pays the tree too.
    Equal keys are contiguous after the sort (``-0.0 == 0.0`` too), so equal
    neighbours find every duplicate.  Non-2D input answers True (the tree decides).
    """
    X = np.asarray(points, np.float64)
    if X.ndim != 2 or X.shape[1] != 2:
        return True
    # wrap() maps into [0, W) x [0, H): coincident means equal there; a set inside already
    # (-0.0 equals 0.0 in the sorts) needs no wrapped copy
    if domain.periodic and not domain.holds(X):
        X = domain.wrap(X)
    X = X[_crowded(X, domain)]
    # coincident points share their x: a sort of the x alone (float64, about 7 times
    # faster than the complex sort) clears every set whose x all differ
    x = np.sort(X[:, 0])
    if not np.any(x[1:] == x[:-1]):
        return False
    z = np.sort(np.ascontiguousarray(X).view(np.complex128).ravel())
    return bool(np.any(z[1:] == z[:-1]))
