"""The tail of a disk-packing relaxation, done locally: only the bad pairs' neighbourhoods move.

After a few iterations of Algorithm 1 almost every pair is already farther
apart than ``d_eps = 2 eps r_max``; rho is held below eps by a few bad
pairs (at 100k points after four iterations, about 1 % of the points),
and the later iterations move a million points to shift a few thousand.
Here one local iteration moves the points within :data:`MOVE_RADIUS`
spacings of a bad point to the centres of the maximal inscribed circles
(MICs) of their Voronoi cells, solved exactly (:func:`exact_mic`) on the
sites within :data:`HALO` more spacings, and leaves every other point where
it is.  Two facts make this exact and cheap:

* **A partial move never lowers the minimum distance.**  A moved point's
  disk (radius R_i, at least half its old nearest-neighbour distance) lies
  in its old cell, so its distance to a moved point j is at least
  ``R_i + R_j`` and to a fixed point j at least ``R_i + |x_i - x_j| / 2``;
  both are at least the old minimum distance.
* **New bad pairs come from old bad points.**  By the same bounds, a pair
  of points that were both at least ``d_eps`` from every other point stays
  at least ``d_eps`` apart, whichever of them move.  So the bad pairs after
  a step are found among the partners, within ``d_eps``, of the points
  that were bad before it: no global search.

A moved point's MIC is exact when every site that could cut its disk lies
in the sub-problem: a site farther than ``|q| + 2 R`` from the centre
(``q`` the move) cannot, and the sub-problem holds every site within the
halo of the point; a cell that reaches past it is not moved this time, and
the halo grows for the next iteration.

In a box both facts need the radii the bounds use, which a wall can take
away (it cuts the disk of half the nearest-neighbour distance around a point
near it): a point moves only where its MIC radius is at least half the
set's smallest distance (a bad point) or ``d_eps / 2`` (any other).  On a
torus every point has that.
"""

from __future__ import annotations

import numpy as np

from .geometry import exact_mic
from .measures import ball_candidates, hexagonal_radius

__all__ = ["HALO", "LOCAL_SHARE", "LOCAL_SOON", "MOVE_RADIUS", "bad_points", "local_step", "relax_local"]

#: Points within this many spacings (``2 r_max``) of a bad point move.
MOVE_RADIUS = 1.2
#: Sites within this many spacings more make a local step's sub-problem.
HALO = 2.2
#: The cells that find a local step's sub-problem are this many times finer than its reach.
FINE = 4
#: A search for the points of at most this share of the cells gathers them from lists of
#: each cell's points (:class:`_CellLists`), a larger one passes over all points' cells:
#: a pass over a million took about 3.5 ms, each of a local step's last steps two.
SPARSE_CELLS = 1 / 8
#: :func:`diskpack_cl.relax_poisson` with ``local=True`` goes local when at
#: most this share of the points is bad (a local step costs about a hundred
#: times a global one per bad point, counting its neighbourhood).  Before and
#: after its two over-relaxed global moves (:data:`diskpack_cl.relax.OVER_RELAX`)
#: 67 %, 31 %, then 1.5-1.6 % of the points are bad (200k and 1M points, seeds
#: 0-5): it goes local there.
LOCAL_SHARE = 0.04
#: From at most this share of bad points the next iterate probably goes
#: local: :func:`diskpack_cl.relax_poisson` measures its nearest neighbours
#: alone first (:meth:`diskpack_cl.device.cells.CellMIC.nearest`, about a tenth of
#: the MICs' cost), and solves its MICs only if it does not.
LOCAL_SOON = 0.45


def bad_points(nn, eps, area):
    """Indices of the points whose nearest neighbour is closer than ``2 eps r_max``.

    Examples
    --------
    >>> bad_points(np.array([0.1, 0.5, 0.5]), 0.8, 1.0).tolist()   # r_max(3) = 0.31
    [0]
    """
    return np.flatnonzero(nn < 2.0 * eps * hexagonal_radius(len(nn), area))


def _pairs_near(X, C, r, domain):
    """``(i, j, q)``: a superset of the pairs of a point ``i`` of `C` and a point
    ``j`` of `X` within `r` (``i`` itself included), and ``q = X[i] - X[j]``
    (minimum image), from a grid of cells (:func:`ball_candidates`); a
    KD-tree where the grid does not serve."""
    found = ball_candidates(X, C, r, domain)
    if found is None:
        from scipy.spatial import cKDTree  # not loaded at start-up: the grid serves most sets

        tree = cKDTree(X, boxsize=domain.size if domain.periodic else None)
        lists = tree.query_ball_point(X[C], r, return_sorted=False)
        lens = np.fromiter(map(len, lists), dtype=np.int64, count=len(lists))
        found = np.repeat(C, lens), np.fromiter((k for lst in lists for k in lst),
                                                dtype=np.int64, count=int(lens.sum()))
    i, j = found
    # np.take: numpy's row gather X[i] is four to eight times slower
    return i, j, domain.shortest(np.take(X, i, axis=0) - np.take(X, j, axis=0))


class _Neighbourhoods:
    """Each point's cell in a grid of cells ``side / FINE`` wide (:data:`FINE`), kept as
    the points move: :meth:`near` finds the points around a few without a pass over
    all of them."""

    def __init__(self, X, side, domain):
        self.side, self.domain = side, domain
        self.n = len(X)
        coarse = min(int(domain.width // side), int(domain.height // side))
        self.nx, self.ny = int(domain.width // (side / FINE)), int(domain.height // (side / FINE))
        self.flat = self._cells(X) if coarse >= 4 else None
        self._lists = None   # _CellLists, made on the first search of few cells
        self._stencils = {}
        self._rows, self._cols = (_index_table(m, domain.periodic) for m in (self.ny, self.nx))

    def _cells(self, X):
        cx = np.minimum((X[:, 0] * (self.nx / self.domain.width)).astype(np.int64), self.nx - 1)
        cy = np.minimum((X[:, 1] * (self.ny / self.domain.height)).astype(np.int64), self.ny - 1)
        return cy * self.nx + cx     # a flat gather: about a third faster than grown[cy, cx] at 1M

    def _stencil(self, radius):
        """``(dy, dx)`` of the cells that hold a point within `radius` (at most `side`) of a
        point of cell (0, 0): those whose gap to it is under `radius` (a disk of cells, not
        a square, which would hold about twice the points)."""
        if radius not in self._stencils:
            cw, ch = self.domain.width / self.nx, self.domain.height / self.ny
            d = np.arange(-FINE, FINE + 1)
            gy, gx = np.meshgrid(np.maximum(np.abs(d) - 1, 0) * ch, np.maximum(np.abs(d) - 1, 0) * cw,
                                 indexing="ij")
            dy, dx = np.nonzero(gx * gx + gy * gy < radius * radius)
            self._stencils[radius] = d[dy], d[dx]
        return self._stencils[radius]

    def moved(self, idx, X):
        """The points `idx` of X moved: their cells again."""
        if self.flat is not None:
            self.flat[idx] = self._cells(np.take(X, idx, axis=0))
            if self._lists is not None:
                self._lists.left(idx)

    def near(self, B, radius=None, among=None):
        """Indices of a superset of the points within `radius` (None: `side`) of the points
        `B` (the cells of the stencil around each of B's), and whether it is all of them.

        `among`: sorted indices that hold every point within `radius` of B: what a near()
        of a larger radius around B found, where no point moved since farther than that
        radius's margin allows (:func:`local_step`).  The search then passes over them
        alone, not over all points (in a local step's last steps a thousandth of them)."""
        if self.flat is None:
            return np.arange(self.n), True
        nx = self.nx
        dy, dx = self._stencil(self.side if radius is None else radius)
        cy, cx = np.divmod(_distinct(self.flat[B], nx * self.ny), nx)
        y = self._rows[cy[:, None] + (dy + FINE)]
        x = self._cols[cx[:, None] + (dx + FINE)]
        mark = np.zeros(nx * self.ny, dtype=bool)
        mark[(y * nx + x)[(y >= 0) & (x >= 0)]] = True
        if among is None:
            return self._marked_points(mark), False
        return among[mark[self.flat[among]]], False

    def _marked_points(self, mark):
        """Sorted indices of the points in the cells that `mark` marks: gathered from the
        cells' lists where those are at most :data:`SPARSE_CELLS` of the cells, else by a
        pass over every point's cell (the same points either way)."""
        cells = np.flatnonzero(mark)
        if len(cells) > SPARSE_CELLS * len(mark):
            return np.flatnonzero(mark[self.flat])
        if self._lists is None:
            self._lists = _CellLists(self.flat, len(mark))
        return self._lists.points(cells, mark, self.flat)


class _CellLists:
    """The points of each cell of a :class:`_Neighbourhoods` grid, listed once (sorted by
    cell), and the points that left their listed cells since: the points of a few cells
    without a pass over all of them."""

    def __init__(self, flat, size):
        self.order = np.argsort(flat, kind="stable")
        self.count = np.bincount(flat, minlength=size)
        self.start = np.cumsum(self.count) - self.count
        self.moved = np.zeros(len(flat), dtype=bool)
        self.gone = np.empty(0, dtype=np.int64)   # the moved points, each once

    def left(self, idx):
        """The distinct points `idx` moved (their cells may differ from the listed ones)."""
        new = idx[~self.moved[idx]]
        self.moved[new] = True
        self.gone = np.concatenate([self.gone, new])

    def points(self, cells, mark, flat):
        """Sorted indices of the points now in `cells` (`mark`: those cells marked, `flat`:
        every point's cell now): the listed ones that never moved, and the moved ones
        whose cell now is marked (no point is both)."""
        count = self.count[cells]
        runs = np.repeat(self.start[cells] - np.cumsum(count) + count, count)
        listed = self.order[runs + np.arange(len(runs))]
        stayed = listed[~self.moved[listed]]
        return np.sort(np.concatenate([stayed, self.gone[mark[flat[self.gone]]]]))


def _index_table(m, periodic):
    """The row (or column) of each index ``-FINE .. m + FINE - 1`` of a grid m cells
    across: wrapped on a torus, -1 off a box (a lookup, where a modulo a cell would
    cost a division)."""
    k = np.arange(-FINE, m + FINE)
    return k % m if periodic else np.where((k >= 0) & (k < m), k, -1)


def _bad_pairs(X, B, d_eps, domain, cells=None, among=None):
    """``(i, j, distance)`` of the pairs closer than `d_eps` that hold a point of `B`
    (with `cells`, a :class:`_Neighbourhoods` of X: searched among the points it finds
    near B only; `among` as in :meth:`_Neighbourhoods.near`)."""
    C, B = _candidates(X, B, d_eps, cells, among)
    i, j, q = _pairs_near(np.take(X, C, axis=0), B, d_eps, domain)
    d = np.hypot(*q.T)
    keep = (i != j) & (d < d_eps)
    return C[i[keep]], C[j[keep]], d[keep]


def _within(X, B, r, domain, cells=None, among=None):
    """Sorted indices of the points within `r` of a point of `B`, the squared
    distance as a periodic KD-tree computes it (so the same points as its ball query;
    with `cells` as in :func:`_bad_pairs`, and `among` as in
    :meth:`_Neighbourhoods.near`)."""
    C, B = _candidates(X, B, r, cells, among)
    _, j, q = _pairs_near(np.take(X, C, axis=0), B, r, domain)
    dx, dy = q[:, 0], q[:, 1]   # a column at a time: the same dx^2 + dy^2 as along rows of two
    return C[_distinct(j[dx * dx + dy * dy <= r * r], len(C))]


def _distinct(idx, size):
    """The distinct values of `idx`, each in ``[0, size)``, in order (as np.unique gives
    them), from a mark a value: numpy 2's unique hashed the 92 000 indices of a 1M set's
    first local step in 22 ms, the marks take under 1 ms."""
    mark = np.zeros(size, dtype=bool)
    mark[idx] = True
    return np.flatnonzero(mark)


def _candidates(X, B, r, cells, among=None):
    """``(C, B)``: sorted indices of a superset of the points within `r` of `B` (all of
    X without `cells`; found in `among` as :meth:`_Neighbourhoods.near` says), and B's
    positions in C: the searches' grids then sort C, a small part of a step's sites."""
    if cells is None:
        return np.arange(len(X)), B
    C = cells.near(B, r, among)[0]
    return C, np.searchsorted(C, B)


def _reach(n, domain, halo):
    """How far from a bad point a local step's sub-problem reaches: the moving
    points' :data:`MOVE_RADIUS` and the `halo`, in spacings."""
    s = 2.0 * hexagonal_radius(n, domain.area)
    return MOVE_RADIUS * s + halo * s


def local_step(X, B, eps, domain, halo=HALO, solver=None, cells=None, d_min=None):
    """One local iteration on the bad points `B`: move their neighbourhoods, in place.

    Parameters
    ----------
    X : (n, 2) float64
        The points (wrapped on a torus); changed in place.
    B : (m,) int
        Every point whose nearest neighbour is closer than ``2 eps r_max``.
    eps : float
    domain : Domain
    halo : float
        Spacings of sites kept around the moving points.
    solver : CellMIC, optional
        Solves the moving cells on the device (:meth:`CellMIC.solve
        <diskpack_cl.device.cells.CellMIC.solve>` with `cells`, certified as by
        :func:`exact_mic`); None: :func:`exact_mic` on the host.
    cells : _Neighbourhoods, optional
        The points' cells from the last step (:func:`relax_local` keeps them;
        None, or another halo's: found again).
    d_min : float, optional
        The smallest distance of X (in a box: what a bad point's MIC radius
        must reach twice to move; None: found from the bad pairs).

    Returns
    -------
    B : (k,) int
        The bad points after the step.
    d_min : float
        The smallest distance of a bad pair (``inf`` when none is left).
    held : int
        Moving points whose cell reached past the halo (not moved).

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> X = np.random.default_rng(0).random((400, 2))
    >>> from diskpack_cl.measures import nearest_neighbor_distances as nnd
    >>> B = bad_points(nnd(X), 0.8, 1.0)
    >>> B2, d, held = local_step(X, B, 0.8, Domain.torus())
    >>> bool(d >= nnd(X).min() - 1e-15), len(B2) < len(B)
    (True, True)
    """
    n = len(X)
    s = 2.0 * hexagonal_radius(n, domain.area)
    move = MOVE_RADIUS * s
    reach = _reach(n, domain, halo)
    if cells is None or cells.side != reach:
        cells = _Neighbourhoods(X, reach, domain)
    S, everything = cells.near(B)
    # S is sorted and holds every point within `move` of B: found among S, not all points
    XS, BS = np.take(X, S, axis=0), np.searchsorted(S, B)
    A = np.searchsorted(S, _within(X, B, move, domain, cells, S))
    if solver is None:
        mic = exact_mic(XS, domain=domain, cells=A)
    else:   # buckets as fine as the whole set's
        mic = solver.solve(XS, cells=A, density=n / domain.area)
    q = domain.shortest(mic.centers - np.take(XS, A, axis=0))
    ok = ~mic.empty & (everything | (2.0 * (np.hypot(*q.T) + mic.radii) <= halo * s))
    held = int((~ok).sum())
    d_eps = 2.0 * eps * hexagonal_radius(n, domain.area)
    if not domain.periodic:
        ok &= _wide_enough(XS, A, BS, mic.radii, d_eps, d_min, domain)
    moving = S[A[ok]]   # only these rows change: not all of S written back
    X[moving] = mic.centers[ok]
    cells.moved(moving, X)
    # found among S still: a point moved at most half the halo (ok), from within the move
    # radius of B, so every point within d_eps of B now was within the reach of B before
    i, j, d = _bad_pairs(X, B, d_eps, domain, cells, S)
    return _distinct(np.concatenate([i, j]), n), float(d.min()) if len(d) else np.inf, held


def _wide_enough(XS, A, BS, radii, d_eps, d_min, domain):
    """Which of the moving points `A` (MIC radii `radii`) may move in a box: a bad one
    (of `BS`) where its radius is at least half the smallest distance `d_min` (None:
    that of the bad pairs), any other where it is at least ``d_eps / 2``."""
    if d_min is None:
        d_min = float(_bad_pairs(XS, BS, d_eps, domain)[2].min(initial=d_eps))
    bad = np.zeros(len(XS), dtype=bool)
    bad[BS] = True
    return radii >= 0.5 * np.where(bad[A], d_min, d_eps)


def relax_local(X, nn, eps, domain, *, max_iter=1000, patience=100, callback=None, first=1,
                stall_gain=1e-3, solver=None):
    """Local iterations (:func:`local_step`) until no pair is closer than ``2 eps r_max``.

    Parameters
    ----------
    X : (n, 2) float64
        The points (wrapped on a torus); not changed.
    nn : (n,) float64
        Each point's exact nearest-neighbour distance in `X`.
    eps : float
    domain : Domain
    max_iter, patience : int
        Iteration cap; stop as ``"stalled"`` when the smallest distance has
        not grown by `stall_gain` of rho (or of its gap to eps) in
        `patience` iterations.
    callback : callable, optional
        ``callback(iteration, rho)`` after each iteration, numbered from
        `first`.
    first : int
        Number of the first iteration (for the callback).
    solver : CellMIC, optional
        Where the moving cells are solved (see :func:`local_step`).

    Returns
    -------
    X : (n, 2) float64
    rho : list of float
        rho after each iteration while bad pairs are left (exact: the
        smallest distance of a bad pair); eps stands for "no bad pair
        left", whose exact rho the caller measures.
    reason : str
        ``"eps"``, ``"stalled"`` or ``"max_iter"``.

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> from diskpack_cl.measures import nearest_neighbor_distances as nnd, normalized_radius
    >>> X = np.random.default_rng(0).random((300, 2))
    >>> Y, rho, reason = relax_local(X, nnd(X), 0.7, Domain.torus())
    >>> reason, bool(normalized_radius(Y) >= 0.7)
    ('eps', True)
    """
    X = np.array(X, dtype=np.float64)
    r_max = hexagonal_radius(len(X), domain.area)
    B = bad_points(nn, eps, domain.area)
    d_min = float(nn.min())
    rho, best, best_at, halo, held = [], d_min / (2 * r_max), 0, HALO, 0
    cells = None
    for it in range(max_iter):
        if not len(B):
            return X, rho, "eps"
        if cells is None or held:   # a grown halo, a wider grid
            cells = _Neighbourhoods(X, _reach(len(X), domain, halo), domain)
        B, d_min, held = local_step(X, B, eps, domain, halo, solver, cells, d_min)
        halo = halo * 1.5 if held else halo
        rho.append(min(d_min / (2 * r_max), eps))
        if callback is not None:
            callback(first + it, rho[-1])
        if rho[-1] > best + max(1e-12, stall_gain * min(best, eps - best)):
            best, best_at = rho[-1], it
        elif it - best_at >= patience:
            return X, rho, "stalled"
    return X, rho, "eps" if not len(B) else "max_iter"
