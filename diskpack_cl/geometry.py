"""Exact float64 geometry: certified maximal inscribed circles of power cells, disk certificates."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from itertools import combinations

import numpy as np

from ._checks import check_sites
from .domain import Domain
from .measures import kdtree

__all__ = ["MIC", "exact_mic", "chebyshev_center_linprog", "Certificate", "certify_disks", "radius_octaves"]


def _sites_tree(points, domain, margin, lift=None):
    """KD-tree over the points and, on a torus, their images within `margin`.

    Returns (tree, positions, original index); the first n entries are the
    points themselves, so entry i is "site i, unshifted".  With `lift` (one
    height per point) the tree is over (x, y, lift): see :func:`_cutter_radius`.
    """
    from scipy.spatial import cKDTree  # not loaded at start-up

    pos, gid = domain.images(points, margin)
    pts = pos if lift is None else np.column_stack([pos, lift[gid]])
    return cKDTree(pts), pos, gid


def _triples(m):
    return np.array(list(combinations(range(m), 3)), dtype=np.intp).reshape(-1, 3)


def cramer_inverse(a, b, beta):
    """Dual side of the vertices of constraint triples ``(a_k, b_k) . q + R <= beta_k``.

    The last axis holds the three constraints.  Cofactors of the last column
    of the rows ``(a_k, b_k, 1)`` give both ``R = M^{-1} beta`` (third row)
    and the multipliers ``l = M^{-T} e3``.  Returns ``(R, 1/det, good)``;
    good: the triple is regular and dual feasible (l >= 0), so R bounds the
    optimum from above.
    """
    e0 = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    e1 = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    e2 = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    det = e0 + e1 + e2
    good = np.abs(det) > 1e-14
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / np.where(good, det, 1.0)
        good &= (e0 * inv >= -1e-9) & (e1 * inv >= -1e-9) & (e2 * inv >= -1e-9)
        R = (e0 * beta[..., 0] + e1 * beta[..., 1] + e2 * beta[..., 2]) * inv
    return R, inv, good


def power_vertex(a, b, beta, inv):
    """Centre ``(qx, qy)`` of the vertex of constraint triples (see :func:`cramer_inverse`)."""
    qx = ((b[..., 1] - b[..., 2]) * beta[..., 0] + (b[..., 2] - b[..., 0]) * beta[..., 1]
          + (b[..., 0] - b[..., 1]) * beta[..., 2]) * inv
    qy = ((a[..., 2] - a[..., 1]) * beta[..., 0] + (a[..., 0] - a[..., 2]) * beta[..., 1]
          + (a[..., 1] - a[..., 0]) * beta[..., 2]) * inv
    return qx, qy


def _solve_subsets(N, B, tol, lead=None):
    """Chebyshev centres of the half-plane sets ``q . N[c,k] <= B[c,k]``.

    The LP ``max R s.t. q.N_k + R <= B_k`` has an optimal vertex where three
    constraints are tight.  Every triple of the first `lead` constraints
    (all by default) gives a vertex and its multipliers, solving
    ``sum l_k (N_k, 1) = (0, 0, 1)``.  A triple with l >= 0 is dual
    feasible, so its R bounds the optimum from above (weak duality); the
    least such R is the optimum exactly when that vertex also satisfies all
    constraints, which is checked.  Cells where it does not (degenerate
    ties) fall back to checking every dual-feasible triple.

    Returns (q, R, ok): ok is False where no triple certifies (the subset
    is unbounded or degenerate and needs more constraints).
    """
    nc, m = B.shape
    if m < 3 or nc == 0:
        return np.zeros((nc, 2)), np.full(nc, -np.inf), np.zeros(nc, bool)
    T = _triples(m if lead is None else min(lead, m))
    a = N[:, T, 0]                                         # (nc, t, 3)
    b = N[:, T, 1]
    beta = B[:, T]
    R, inv, good = cramer_inverse(a, b, beta)
    rows = np.arange(nc)

    def vertex(pick):
        return np.stack(power_vertex(a[rows, pick], b[rows, pick], beta[rows, pick], inv[rows, pick]), 1)

    best = np.argmin(np.where(good, R, np.inf), axis=1)
    q = vertex(best)
    Rb = R[rows, best]
    slack = B - np.einsum("ckj,cj->ck", N, q) - Rb[:, None]
    ok = good[rows, best] & np.all(slack >= -tol, axis=1)
    tie = np.nonzero(~ok & np.any(good, axis=1))[0]
    if len(tie):
        # degenerate ties among dual-feasible vertices: check them all
        qx, qy = power_vertex(a[tie], b[tie], beta[tie], inv[tie])
        Nt, Bt = N[tie], B[tie]
        sl = (Bt[:, None, :] - qx[..., None] * Nt[:, None, :, 0] - qy[..., None] * Nt[:, None, :, 1]
              - R[tie][..., None])
        fit = good[tie] & np.all(sl >= -tol, axis=-1)
        pick = np.argmin(np.where(fit, R[tie], np.inf), axis=1)
        r_ = np.arange(len(tie))
        found = fit[r_, pick]
        q[tie[found]] = np.stack([qx[r_, pick], qy[r_, pick]], 1)[found]
        Rb[tie[found]] = R[tie][r_, pick][found]
        ok[tie[found]] = True
    return q, Rb, ok


def _constraints(X, w, i, gpos, gidx, gid, domain):
    """Half-planes ``q . n <= beta`` (q relative to X[i]) from sites gidx of the tree.

    Entry gidx == i (the site itself, unshifted) and coincident images give
    an inactive constraint (beta = +inf).
    """
    xi = X[i][:, None, :]
    a = gpos[gidx] - xi
    L = np.hypot(a[..., 0], a[..., 1])
    dead = (gidx == i[:, None]) | (L == 0)
    Ls = np.where(dead, 1.0, L)
    nrm = a / Ls[..., None]
    beta = (L * L - w[gid[gidx]] + w[i][:, None]) / (2 * Ls)
    beta[dead] = np.inf
    return nrm, beta


def _edge_constraints(X, i, domain):
    xi = X[i]
    nrm = np.broadcast_to(np.array([[-1.0, 0], [1, 0], [0, -1], [0, 1]]), (len(i), 4, 2))
    beta = np.stack([xi[:, 0], domain.width - xi[:, 0], xi[:, 1], domain.height - xi[:, 1]], 1)
    return nrm, beta


def _fill_dead(N, B):
    """Replace inactive (infinite) constraints by copies of the first one.

    A copy makes every triple it joins singular, so it never forms a vertex,
    and it adds nothing to feasibility.
    """
    dead = ~np.isfinite(B)
    N[dead] = np.broadcast_to(N[:, :1], N.shape)[dead]
    B[dead] = np.broadcast_to(B[:, :1], B.shape)[dead]
    return N, B


def _widen(N, B, width):
    """Pad constraint arrays to `width` columns with unused (1e300) slots."""
    extra = width - B.shape[1]
    if extra <= 0:
        return N, B
    N = np.concatenate([N, np.broadcast_to(N[:, :1], (len(N), extra, 2))], 1)
    B = np.concatenate([B, np.full((len(B), extra), 1e300)], 1)
    return N, B


#: Vertex search widths: every triple of the first ``_LEADS[0]`` least-slack
#: constraints, then, for the cells none of those certify, of the first
#: ``_LEADS[1]``, then ``_LEADS[2]`` (fewer cells each time).
_LEADS = (6, 9, 12)
#: Constraint-generation rounds; cells still open after them go to linprog.
_MAX_ROUNDS = 12
#: Most sites in a regrown constraint set (a cell with no certified vertex
#: starts again from twice as many nearest sites, up to this many).
_MAX_POOL = 256
#: Relative slack on "the cutter ball lies inside the ball the set came from".
_COVER_RTOL = 1e-12


@dataclass
class MIC:
    """Certified maximal inscribed circles of power cells: the one answer of every engine.

    :func:`exact_mic`, :meth:`diskpack_cl.device.cells.CellMIC.solve` and every
    engine's ``mic`` (:mod:`diskpack_cl.engine`) return it.

    Attributes
    ----------
    centers : (n, 2) float64
        MIC centres (wrapped into the torus when periodic; the site itself
        where the cell is empty).
    radii : (n,) float64
        MIC radii; negative where the power cell is empty.
    empty : (n,) bool
        The power cell is empty (or its radius is not finite).
    stats : dict
        Counts of the solver (see the function that made it).
    nn : (n,) float64 or None
        Distance from each site to its nearest other site, exact (periodic
        on a torus), when the solver found it on the way (the per-cell
        kernel does).

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> mic = exact_mic(np.array([[0.25, 0.5], [0.75, 0.5]]), domain=Domain.torus())
    >>> mic.radii.tolist(), mic.empty.tolist()
    ([0.25, 0.25], [False, False])
    """

    centers: np.ndarray
    radii: np.ndarray
    empty: np.ndarray
    stats: dict = field(default_factory=dict)
    nn: np.ndarray | None = None


def exact_mic(points, weights=None, domain=Domain.torus(), *, estimate=None, k=12, cells=None):
    """Exact (float64) maximal inscribed circle of every power cell.

    The MIC of cell i is the Chebyshev centre of the convex polygon
    ``{p : |p-x_i|^2 - w_i <= |p-x_j|^2 - w_j for all j}`` (intersected with the
    rectangle on a bounded domain): the linear program
    ``max R s.t. n_k . c + R <= b_k`` over its bounding half-planes.

    Each cell's LP is first solved on its K nearest sites around the start
    estimate (plus the rectangle's edges), by enumerating the vertices formed
    by the least-slack constraints and keeping the one that is feasible for
    all of them and passes the optimality (KKT) test.  The solution is then
    certified against *every* site that could cut its disk: the power
    distance bounds how far such a site can be, and when that ball lies
    inside the ball the K sites came from, they are all already checked;
    otherwise a KD-tree query finds them.  A violated constraint joins the
    cell's set and the cell is solved again (constraint generation); this
    ends because each round adds a constraint.  Feasible for all and optimal
    for a subset means optimal: the result does not depend on the estimate.

    Parameters
    ----------
    points : (n, 2) array_like
        Sites (wrapped into the torus when periodic).
    weights : (n,) array_like, optional
        Power weights (squared radii); None for the Voronoi diagram.
    domain : Domain
    estimate : tuple of arrays, optional
        ``(centers, radii)`` from the raster, one row per site (also with
        `cells`); radius < 0: no estimate.
    k : int
        Sites in each cell's first constraint set.
    cells : (m,) array_like of int, optional
        Solve only these cells (every site still constrains them).  The
        result then has one row per entry of `cells`, in their order; a
        cell's result is its certified optimum, equal to the full solve's
        up to rounding (degenerate cells may pick another optimal centre).

    Returns
    -------
    MIC
        ``centers`` (n, 2), ``radii`` (n,) (negative: the power cell is
        empty; ``centers`` is then the site itself), ``empty`` mask, and
        ``stats``: rounds, cells widened, linprog fallbacks, and the largest
        estimate errors.  With `cells`: m rows instead of n.

    Raises
    ------
    ValueError
        Points not (n, 2) finite, weights not n finite numbers, cells not
        integer indices of sites.

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.random.default_rng(1).random((100, 2))
    >>> mic = exact_mic(pts)
    >>> bool(np.all(mic.radii > 0))
    True

    Three cells only, as a fallback for the cells a raster could not settle:

    >>> part = exact_mic(pts, cells=[4, 0, 7])
    >>> bool(np.allclose(part.radii, mic.radii[[4, 0, 7]], rtol=0, atol=1e-12))
    True
    """
    X, w = _checked_sites(points, weights, domain)
    n = len(X)
    todo = checked_cells(cells, n)
    c_est, r_est = _start_estimate(X, estimate)
    q0 = domain.shortest(c_est - X)
    q, R, stats = _solve_with_margin(X, w, q0, r_est, domain, todo, k)
    R, c_est, r_est = R[todo], c_est[todo], r_est[todo]
    centers, empty = mic_centres(X[todo], q[todo], R, domain)
    if estimate is not None:
        stats.update(_estimate_errors(centers, R, c_est, r_est, domain))
    stats["empty"] = int(empty.sum())
    return MIC(centers, R, empty, stats)


def mic_centres(X, q, R, domain):
    """MIC centres ``X + q`` (the site itself for an empty cell, ``R < 0``), wrapped."""
    empty = R < 0
    centers = X + q
    centers[empty] = X[empty]
    if domain.periodic:
        centers = domain.wrap(centers)
    return centers, empty


def _solve_with_margin(X, w, q0, r_est, domain, todo, k):
    """Solve the cells `todo`, widening the periodic margin until every cell fits in it."""
    n = len(X)
    scale = max(domain.width, domain.height)
    wmax = w.max() if n else 0.0
    spacing = np.sqrt(domain.area / max(n, 1))
    full = _full_margin(domain, wmax)
    margin = min(8 * spacing + np.sqrt(wmax), full) if domain.periodic else 0.0
    while True:
        try:
            problem = _CellProblem.build(X, w, q0, r_est, domain, margin, tol=1e-11 * scale)
            q, R, stats = _solve_cells(problem, todo, k)
            break
        except _MarginTooSmall as exc:
            # a cell reaches past the periodic images in the tree: add more
            margin = min(max(1.25 * exc.needed, 2 * margin), full)
    stats["margin"] = margin
    return q, R, stats


def _checked_sites(points, weights, domain):
    """Points (wrapped on a torus) and weights shifted to min 0, as float64 copies."""
    X, w = check_sites(points, weights, domain, minimum=0)
    if len(X):
        w -= w.min()   # the diagram ignores a common shift; bounds below want w >= 0
    return X, w


def checked_cells(cells, n):
    """The cell indices to solve: all n, or `cells` checked to be indices of sites."""
    if cells is None:
        return np.arange(n)
    c = np.asarray(cells)
    if c.ndim != 1 or not (c.size == 0 or np.issubdtype(c.dtype, np.integer)):
        raise ValueError(f"cells must be a 1-D array of site indices, got shape {c.shape} "
                         f"and dtype {c.dtype}")
    if c.size and (c.min() < 0 or c.max() >= n):
        raise ValueError(f"cells must be site indices in [0, {n}), got {c.min()} .. {c.max()}")
    return c.astype(np.intp)


def _start_estimate(X, estimate):
    """Start centres and radii per site: the estimate where it has one, else the site, 0."""
    c_est = X.copy()
    r_est = np.zeros(len(X))
    if estimate is not None:
        ec, er = (np.asarray(a, np.float64) for a in estimate)
        has = er >= 0
        c_est[has] = ec[has]
        r_est[has] = er[has]
    return c_est, r_est


def _estimate_errors(centers, R, c_est, r_est, domain):
    """Largest radius and centre errors of the estimate, over cells that had one."""
    has = r_est > 0
    d = centers[has] - c_est[has]
    if domain.periodic:
        d -= np.round(d)
    return {"estimate_radius_error_max": float(np.max(np.abs(R[has] - r_est[has]), initial=0.0)),
            "estimate_center_error_max": float(np.max(np.hypot(d[:, 0], d[:, 1]), initial=0.0))}


class _MarginTooSmall(Exception):
    """A cell reaches past the periodic images in the tree; `needed` is the margin it wants."""

    def __init__(self, needed):
        self.needed = float(needed)


def _full_margin(domain, wmax):
    """Margin of periodic images beyond which no image can bound any power cell.

    A site's own images bound its cell to the period box around it, whose
    points lie within ``rb = hypot(W, H) / 2`` of the site; an image at
    distance ``D`` has its power bisector at least ``D/2 - wmax/(2D)`` away,
    outside the box once ``D >= 2 rb + sqrt(wmax)``.  With every image
    within that margin in the tree, the LP over the tree is the LP over all
    images, so no cell needs more (a cell's intermediate disk may reach
    further; far images cannot cut the optimum).
    """
    return float(np.hypot(domain.width, domain.height) + np.sqrt(wmax))


def _overhang(centers, radius, domain, margin):
    """How far each ball pokes out of the region whose periodic images are in the tree."""
    if not domain.periodic:
        return np.zeros(len(centers))
    size = np.array([domain.width, domain.height])
    lo = -(centers - radius[:, None]) - margin
    hi = centers + radius[:, None] - size - margin
    return np.maximum(np.max(np.maximum(lo, hi), axis=1), 0.0)


@dataclass
class _CellProblem:
    """Everything the cells are solved against: sites, weights, tree, starts.

    ``tree`` holds the sites and, on a torus, their images within `margin`
    (``gpos`` positions, ``gid`` site of each entry).  With unequal weights
    the tree is over ``(x, y, lift)``, ``lift = sqrt(2 (wmax - w))``: one
    radius per cell then finds every site that can cut a disk, whatever its
    weight (see :func:`_cutter_radius`).  ``q0`` (start centre relative to
    the site) and ``r_est`` (start radius) are per site.
    """

    X: np.ndarray
    w: np.ndarray
    wmax: float
    q0: np.ndarray
    r_est: np.ndarray
    domain: Domain
    margin: float
    tol: float
    tree: object
    gpos: np.ndarray
    gid: np.ndarray
    lift: np.ndarray | None

    @classmethod
    def build(cls, X, w, q0, r_est, domain, margin, tol):
        wmax = w.max() if len(w) else 0.0
        lift = np.sqrt(2.0 * (wmax - w)) if wmax > 0 else None
        tree, gpos, gid = _sites_tree(X, domain, margin, lift)
        return cls(X, w, wmax, q0, r_est, domain, margin, tol, tree, gpos, gid, lift)

    @property
    def lifted(self):
        return self.lift is not None

    def at(self, c):
        """Tree coordinates of plane points (height 0 when lifted)."""
        return c if self.lift is None else np.column_stack([c, np.zeros(len(c))])

    def constraints(self, cells, idx):
        """Half-planes of `cells` from tree entries `idx` (one row per cell), with the edges."""
        N, B = _constraints(self.X, self.w, cells, self.gpos, idx, self.gid, self.domain)
        if not self.domain.periodic:
            En, Eb = _edge_constraints(self.X, cells, self.domain)
            N, B = np.concatenate([N, En], 1), np.concatenate([B, Eb], 1)
        return N, B

    def cutter_radius(self, cells, q, R):
        return _cutter_radius(q, R, self.w[cells], self.wmax, self.lifted)


@dataclass
class _ConstraintSet:
    """Constraint sets of some cells: row r holds cell ``cells[r]``'s half-planes.

    ``q . N[r, j] <= B[r, j]`` with q relative to the site; unused slots are
    copies of the first constraint (:func:`_fill_dead`) or ``B = 1e300``
    padding (:func:`_widen`).  ``reach[r]``: every site within this distance
    of the cell's start is in its set (-inf: unknown, always query).
    """

    cells: np.ndarray
    N: np.ndarray
    B: np.ndarray
    reach: np.ndarray

    @property
    def width(self):
        return self.B.shape[1]

    def padded(self, width):
        """The same sets with `width` columns (more unused slots)."""
        N, B = _widen(self.N, self.B, width)
        return _ConstraintSet(self.cells, N, B, self.reach)

    def concat(self, other):
        """Rows of both sets, padded to a common width."""
        width = max(self.width, other.width)
        a, b = self.padded(width), other.padded(width)
        return _ConstraintSet(np.concatenate([a.cells, b.cells]), np.concatenate([a.N, b.N]),
                              np.concatenate([a.B, b.B]), np.concatenate([a.reach, b.reach]))


def _solve_cells(P, cells, k):
    """Constraint generation for `cells` (see :func:`exact_mic`).

    Returns ``(q, R, stats)`` with one row per site (rows outside `cells`:
    q = 0, R = -inf): the MIC centre relative to the site and its radius.
    """
    n = len(P.X)
    stats = {"rounds": 0, "widened": 0, "grown": 0, "linprog": 0, "queried": 0}
    S = _nearest_sets(P, cells, int(min(len(P.gpos), k)))
    q = np.zeros((n, 2))
    R = np.full(n, -np.inf)
    widened = np.zeros(n, bool)
    while len(S.cells):
        stats["rounds"] += 1
        q[S.cells], R[S.cells], ok = _vertex_search(S, P.tol, stats)
        vr, vN, vB = _violations(P, S, q, R, ok, stats)
        widened[S.cells[vr]] = True
        bad = np.nonzero(~ok)[0]
        stats["grown"] += len(bad)
        if stats["rounds"] >= _MAX_ROUNDS:
            rows = np.union1d(vr, bad)
            stats["linprog"] += len(rows)
            for r in rows:
                c = S.cells[r]
                q[c], R[c] = _cutting_plane_cell(P, c, S.N[r], S.B[r])
            break
        if not len(vr) and not len(bad):
            break
        S = _with_violations(S, vr, vN, vB, q, R).concat(_regrown_sets(P, S, bad))
    stats["widened"] = int(widened.sum())
    return q, R, stats


def _nearest_sets(P, cells, size):
    """Constraints from the `size` sites nearest each cell's start, least slack first."""
    start = P.X[cells] + P.q0[cells]
    dk, nb = P.tree.query(P.at(start), k=size)
    nb = nb.reshape(len(cells), size)
    N, B = P.constraints(cells, nb)
    sl = B - np.einsum("ckj,cj->ck", N, P.q0[cells]) - P.r_est[cells, None]
    o = np.argsort(sl, axis=1, kind="stable")
    N, B = _fill_dead(np.take_along_axis(N, o[..., None], 1), np.take_along_axis(B, o, 1))
    if size < P.tree.n:
        reach = dk.reshape(len(cells), size)[:, -1]
    else:
        reach = np.full(len(cells), np.inf)
    # a ball poking out of the imaged region may miss images: not a cover
    reach[_overhang(start, reach, P.domain, P.margin) > 0] = -np.inf
    return _ConstraintSet(cells, N, B, reach)


def _vertex_search(S, tol, stats):
    """Each row's optimum on its set: vertex search over widening leads, then linprog.

    Returns (q, R, ok) per row; ok is False where the set does not bound a
    certified vertex (unbounded or long thin cell among its sites).
    """
    qs, Rs, ok = _solve_subsets(S.N, S.B, tol, lead=_LEADS[0])
    for prev, lead in zip(_LEADS, _LEADS[1:]):
        # fewer cells each time: more of their constraints lead
        sub = np.nonzero(~ok)[0]
        if len(sub) and prev < S.width:
            qs[sub], Rs[sub], ok[sub] = _solve_subsets(S.N[sub], S.B[sub], tol, lead=lead)
    for c in np.nonzero(~ok)[0]:
        # the active constraints are not among the least slack at the
        # start (a poor estimate): solve this cell's set by LP instead
        stats["linprog"] += 1
        qs[c], Rs[c], ok[c] = _lp_subset(S.N[c], S.B[c], tol)
    return qs, Rs, ok


def _violations(P, S, q, R, ok, stats):
    """Violated constraints of the solved rows, as (row, normal, beta), sorted by row.

    The set's sites came from a ball around the start; a cutter of the disk
    lies within the cutter radius of its centre, hence within that plus the
    shift from the start: inside the ball, it has been checked already.
    Only rows whose cutter ball leaves it are queried.
    """
    rows = np.nonzero(ok)[0]
    fine = S.cells[rows]
    rad = P.cutter_radius(fine, q[fine], R[fine])
    shift = np.hypot(*(q[fine] - P.q0[fine]).T)
    unsure = rows[rad + shift > S.reach[rows] * (1 - _COVER_RTOL)]
    stats["queried"] += len(unsure)
    cu = S.cells[unsure]
    if len(unsure):
        _check_margin(P, cu, q[cu], R[cu])
    return _verify(P, unsure, q[cu], R[cu], cu)


def _check_margin(P, cells, q, R):
    """Raise _MarginTooSmall when a cell's cutter ball reaches past the
    periodic images in the tree (never once the tree holds the full margin)."""
    if not P.domain.periodic or not P.margin < _full_margin(P.domain, P.wmax):
        return
    over = _overhang(P.X[cells] + q, P.cutter_radius(cells, q, R), P.domain, P.margin)
    if over.max() > 0:
        raise _MarginTooSmall(P.margin + over.max())


def _with_violations(S, vr, vN, vB, q, R):
    """The rows with violations, their new constraints added, least slack at (q, R) first.

    The new constraints then take part in the next vertex search; these
    rows are never "covered" again (reach -inf: always query).
    """
    vrows = np.unique(vr)
    N, B = S.N[vrows], S.B[vrows]
    if len(vr):
        rank = np.arange(len(vr)) - np.searchsorted(vr, vr)
        slot = np.searchsorted(vrows, vr)
        width = B.shape[1]
        N, B = _widen(N, B, width + int(rank.max()) + 1)
        N[slot, width + rank], B[slot, width + rank] = vN, vB
        cells = S.cells[vrows]
        sl = B - np.einsum("ckj,cj->ck", N, q[cells]) - R[cells][:, None]
        o = np.argsort(sl, axis=1, kind="stable")
        N, B = np.take_along_axis(N, o[..., None], 1), np.take_along_axis(B, o, 1)
    return _ConstraintSet(S.cells[vrows], N, B, np.full(len(vrows), -np.inf))


def _regrown_sets(P, S, bad):
    """Rows with no certified vertex start again from twice as many nearest
    sites; on a torus also from the site's own images, which bound the cell
    (a cell at the rim of a cluster is not bounded by its nearest sites)."""
    size = int(min(P.tree.n, 2 * S.width, _MAX_POOL))
    G = _nearest_sets(P, S.cells[bad], size)
    if not P.domain.periodic or not len(bad):
        return G
    En, Eb = _own_images(P.domain)
    k = len(bad)
    N = np.concatenate([G.N, np.broadcast_to(En, (k, 4, 2))], 1)
    B = np.concatenate([G.B, np.broadcast_to(Eb, (k, 4))], 1)
    return _ConstraintSet(G.cells, N, B, G.reach)


def _own_images(domain):
    """The half-planes ``q . n <= beta`` from a torus site's four nearest own
    images: the period box around the site."""
    W, H = domain.width, domain.height
    return (np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]),
            np.array([W / 2, W / 2, H / 2, H / 2]))


def _cutter_radius(q, R, wi, wmax, lifted=False):
    """Radius around the centre beyond which no site can violate (q, R).

    Site j cuts the disk (c, R) of cell i only if, for some p in the disk,
    pow_j(p) <= pow_i(p); with |c - x_i| = |q| that needs
    ``(|c - x_j| - R)^2 <= (|q| + R)^2 - w_i + w_j``.  In the plane, bounding
    w_j by wmax gives a distance.  Lifted, each site sits at height
    ``sqrt(2 (wmax - w_j))`` and, since ``|c-x_j|^2 <= 2 (|c-x_j| - R)^2 + 2 R^2``,
    every cutter lies within ``sqrt(2 ((|q| + R)^2 - w_i + R^2 + wmax))`` of
    (c, 0): light sites near, heavy ones far, one radius per cell.
    """
    Rp = np.maximum(R, 0.0)
    qn = np.hypot(q[:, 0], q[:, 1])
    if lifted:
        return np.sqrt(np.maximum(2.0 * ((qn + Rp) ** 2 - wi + Rp ** 2 + wmax), 0.0))
    return Rp + np.sqrt(np.maximum((qn + Rp) ** 2 - wi + wmax, 0.0))


def _query_pairs(tree, centers, radius, k=16):
    """All (row, tree index) pairs with the tree point within radius[row] of centers[row].

    A k-nearest query per centre; rows whose k-th neighbour is still inside
    the radius are asked again with 4k, so nothing inside is missed.  The
    search stops at the largest radius asked (scipy takes one bound for all
    rows): where most rows have fewer than k points inside, that prunes
    most of the tree (certifying 50 000 disks: 0.7 s to 0.23 s).
    """
    rows_out, idx_out = [], []
    rows = np.arange(len(centers))
    while len(rows):
        k = min(k, tree.n)
        # scipy keeps only neighbours strictly below the bound
        bound = np.nextafter(float(radius[rows].max()) * (1 + 1e-12), np.inf)
        d, idx = tree.query(centers[rows], k=k, distance_upper_bound=bound, workers=-1)
        d, idx = d.reshape(len(rows), k), idx.reshape(len(rows), k)
        within = (d <= radius[rows, None] * (1 + 1e-12)) & (idx < tree.n)
        full = within[:, -1] if k < tree.n else np.zeros(len(rows), bool)
        r, c = np.nonzero(within & ~full[:, None])
        rows_out.append(rows[r])
        idx_out.append(idx[r, c])
        rows = rows[full]
        k *= 4
    return np.concatenate(rows_out), np.concatenate(idx_out)


#: Violated constraints a cell gets per round (the worst ones).
_VIOLATIONS_PER_ROUND = 3
_CUTTING_ROUNDS = 20     # linprog rounds of one left-open cell before the LP over every site


def _verify(P, tags, q, R, cells, per_cell=_VIOLATIONS_PER_ROUND):
    """Violated constraints of each cell's (q, R): the worst `per_cell` per
    cell (None: all).

    Returns flat arrays (tag, normal, beta), one row per violated
    constraint, sorted by tag; `tags` label the cells in the output.
    """
    if not len(cells):
        return np.zeros(0, np.intp), np.zeros((0, 2)), np.zeros(0)
    rad = P.cutter_radius(cells, q, R)
    rows, idx = _query_pairs(P.tree, P.at(P.X[cells] + q), rad)
    Nn, Bb = _constraints(P.X, P.w, cells[rows], P.gpos, idx[:, None], P.gid, P.domain)
    Nn, Bb = Nn[:, 0], Bb[:, 0]
    if not P.domain.periodic:
        En, Eb = _edge_constraints(P.X, cells, P.domain)
        rows = np.concatenate([rows, np.repeat(np.arange(len(cells)), 4)])
        Nn = np.concatenate([Nn, En.reshape(-1, 2)])
        Bb = np.concatenate([Bb, Eb.ravel()])
    slack = Bb - np.einsum("kj,kj->k", Nn, q[rows]) - R[rows]
    v = slack < -P.tol
    rows, Nn, Bb, slack = rows[v], Nn[v], Bb[v], slack[v]
    order = np.lexsort((slack, rows))
    rows, Nn, Bb = rows[order], Nn[order], Bb[order]
    rank = np.arange(len(rows)) - np.searchsorted(rows, rows)
    keep = rank < (len(rank) if per_cell is None else per_cell)
    return np.asarray(tags)[rows[keep]], Nn[keep], Bb[keep]


def _lp_subset(N, B, tol):
    """One cell's LP on its constraint set by linprog, polished to an exact vertex.

    Returns (q, R, ok); ok is False when the set is unbounded.  The vertex
    polish re-solves the three tightest constraints and keeps the result only
    if it passes the same feasibility and KKT test as the vertex search.
    """
    keep = B < 1e299
    try:
        c, R = chebyshev_center_linprog(N[keep], B[keep])
    except RuntimeError:
        return np.zeros(2), -np.inf, False
    sl = B[keep] - N[keep] @ c - R
    o = np.argsort(sl)
    cand = o[: min(8, len(o))]
    Nc, Bc = N[keep][cand][None], B[keep][cand][None]
    qv, Rv, okv = _solve_subsets(Nc, Bc, tol)
    if okv[0] and np.all(B[keep] - N[keep] @ qv[0] - Rv[0] >= -tol):
        return qv[0], Rv[0], True
    return np.asarray(c), float(R), True


def _cutting_plane_cell(P, c, N, B):
    """One cell that constraint generation left open: linprog on its set,
    every violated site added, until none is (then the optimum is the LP's
    over all sites, by the same check as the vectorized rounds); linprog
    over every site in the tree when the set stays unbounded."""
    tol = P.tol
    if P.domain.periodic:
        En, Eb = _own_images(P.domain)
        N, B = np.concatenate([N, En]), np.concatenate([B, Eb])
    for _ in range(_CUTTING_ROUNDS):
        qc, Rc, ok = _lp_subset(N, B, tol)
        if not ok:
            break
        cells, qv, Rv = np.array([c]), qc[None], np.array([Rc])
        _check_margin(P, cells, qv, Rv)
        _, vN, vB = _verify(P, [0], qv, Rv, cells, per_cell=None)
        if not len(vB):
            return qc, Rc
        N, B = np.concatenate([N, vN]), np.concatenate([B, vB])
    return _linprog_cell(P, c)


def _linprog_cell(P, c):
    """Fallback: one cell's Chebyshev centre by scipy's LP over every site in the tree."""
    N, B = P.constraints(np.array([c]), np.arange(P.tree.n)[None, :])
    N, B = N[0], B[0]
    keep = np.isfinite(B)
    try:
        return chebyshev_center_linprog(N[keep], B[keep])
    except RuntimeError:
        if P.domain.periodic and P.margin < _full_margin(P.domain, P.wmax):
            # unbounded: the cell needs images from further away (its own)
            raise _MarginTooSmall(max(2 * P.margin, max(P.domain.width, P.domain.height)))
        raise


def chebyshev_center_linprog(normals, beta):
    """Chebyshev centre of ``{q : q . normals_k <= beta_k}`` by ``scipy.optimize.linprog``.

    `normals` must be unit vectors.  Returns ``(center (2,), radius)``; the
    radius is negative when the set is empty.  The independent reference for
    :func:`exact_mic`.

    Examples
    --------
    The unit square as ``x <= 1, -x <= 0, y <= 1, -y <= 0``:

    >>> centre, radius = chebyshev_center_linprog(np.array([[1.0, 0], [-1, 0], [0, 1], [0, -1]]),
    ...                                           np.array([1.0, 0, 1, 0]))
    >>> centre.tolist(), float(radius)
    ([0.5, 0.5], 0.5)
    """
    from scipy.optimize import linprog  # not loaded at start-up

    A = np.column_stack([normals, np.ones(len(beta))])
    res = linprog([0, 0, -1], A_ub=A, b_ub=beta, bounds=[(None, None)] * 3, method="highs")
    if res.status != 0:
        raise RuntimeError(f"linprog failed: {res.message}")
    return res.x[:2], res.x[2]


class CertificateError(ValueError):
    """Disks that failed their certificate: no result is returned (or written) for them.

    Attributes
    ----------
    certificate : Certificate

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> touching = certify_disks(np.array([[1.0, 1.0], [2.0, 1.0]]), np.array([0.5, 0.5]), Domain.rect(4, 2))
    >>> exc = CertificateError("disks overlap", touching)
    >>> isinstance(exc, ValueError), exc.certificate.disjoint
    (True, False)
    """

    def __init__(self, message, certificate):
        super().__init__(f"{message} ({certificate})")
        self.certificate = certificate


@dataclass
class Certificate:
    """Exact float64 check that disks lie in the domain and are pairwise disjoint.

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> c = certify_disks(np.array([[1.0, 1.0], [3.0, 1.0]]), np.array([0.9, 0.9]), Domain.rect(4, 2))
    >>> c.valid, c.inside, c.disjoint, round(c.min_gap, 6)
    (True, True, True, 0.1)
    """

    valid: bool
    min_gap: float          # smallest d_ij - r_i - r_j over checked pairs (and edge clearances)
    pairs_checked: int
    inside: bool
    disjoint: bool

    def as_dict(self):
        return {"valid": bool(self.valid), "min_gap": float(self.min_gap),
                "pairs_checked": int(self.pairs_checked), "inside": bool(self.inside),
                "disjoint": bool(self.disjoint)}


def radius_octaves(r):
    """Indices of the disks grouped by radius octave (zero radii in one group).

    Examples
    --------
    >>> [c.tolist() for c in radius_octaves(np.array([1.0, 3.0, 1.5, 0.0]))]
    [[3], [0, 2], [1]]
    """
    r = np.asarray(r, np.float64)
    pos = r > 0
    lr = np.full(len(r), -1, np.int64)
    if pos.any():
        # a difference of logarithms: the ratio overflows where the smallest radius is subnormal
        lr[pos] = np.floor(np.log2(r[pos]) - np.log2(r[pos].min())).astype(np.int64)
    return [np.flatnonzero(lr == c) for c in np.unique(lr)]


def _octave_trees(classes, octaves, domain):
    """The trees and searches of `octaves` (``(classes, trees[, searched])``) where its
    classes are those of `classes`, else a None for each class (made anew) and no search:
    ``(trees, searched)``."""
    if octaves is None or domain.periodic or len(octaves[0]) != len(classes) \
            or not all(np.array_equal(a, b) for a, b in zip(octaves[0], classes)):
        return [None] * len(classes), {}
    return list(octaves[1]), (octaves[2] if len(octaves) > 2 else {})


def _searched_pairs(found, reach, trees, classes, a, b):
    """``(i, j, distance)``: the pairs of octaves a and b within `reach`, the caller's
    search `found` (``(its reach, i, j, distance)`` or None) where it reached as far,
    else a dual-tree search of their trees. A wider search holds the pairs of this one
    and more, whose distances (the same arithmetic on the same trees) the caller's
    filter below `reach` drops."""
    if found is not None and found[0] >= reach:
        return found[1:]
    sdm = trees[a].sparse_distance_matrix(trees[b], reach, output_type="ndarray")
    return classes[a][sdm["i"]], classes[b][sdm["j"]], sdm["v"]


def _octave_pairs(C, r, domain, octaves):
    """``(i, j)``: every pair of disks that could overlap, each once.

    One tree per radius octave: disk i meets the disks of octave c only
    within ``r_i`` plus the largest radius of c, a short reach even when the
    radii vary by orders of magnitude.  The pairs of two octaves a <= b come
    from one dual-tree search of their trees (the disks of a within reach
    of those of b; within one octave each pair once, from its lower index),
    all pairs of octaves at once on every core (cKDTree releases the GIL):
    the pairs that a query of each disk of a against the tree of b within
    ``r_i`` plus the largest radius of b finds, without querying every disk
    of the lower octaves again for each higher one.
    """
    from concurrent.futures import ThreadPoolExecutor   # (this module is read at start-up)

    classes = radius_octaves(r)   # ascending
    rmax = [r[c].max() for c in classes]
    err = np.geterr()   # the caller's handling of overflow (a reader's: none), in the pool too

    def tree(ct):
        with np.errstate(**err):
            return kdtree(C[ct[0]], domain)[1] if ct[1] is None else ct[1]

    def pairs(ab):
        a, b = ab
        with np.errstate(**err):
            ii, jj, v = _searched_pairs(searched.get(ab), (rmax[a] + rmax[b]) * (1 + 1e-9), trees,
                                        classes, a, b)
            keep = v <= (r[ii] + rmax[b]) * (1 + 1e-12)
        if a == b:
            keep &= ii < jj
        return ii[keep], jj[keep]

    known, searched = _octave_trees(classes, octaves, domain)
    with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
        trees = list(pool.map(tree, zip(classes, known)))
        found = list(pool.map(pairs, [(a, b) for b in range(len(classes)) for a in range(b + 1)]))
    return (np.concatenate([f[0] for f in found]).astype(np.intp),
            np.concatenate([f[1] for f in found]).astype(np.intp))


def certify_disks(centers, radii, domain, *, octaves=None):
    """Certify closed disks: inside the domain and pairwise disjoint (exact float64).

    Every pair that could overlap is examined: for each radius octave, the
    centres of that octave within ``r_i`` plus the octave's largest radius of
    each disk i of that octave or a lower one (:func:`_octave_pairs`), so no
    overlapping pair escapes.

    Parameters
    ----------
    centers : (n, 2) array_like
        The disks' centres.
    radii : (n,) array_like
        Their radii.
    domain : Domain
        Where they must lie.
    octaves : tuple, optional
        ``(classes, trees)`` or ``(classes, trees, searched)``: the centres'
        indices grouped by :func:`radius_octaves`, a ``cKDTree`` of each
        group's centres and, in `searched`, the pairs of octaves ``(a, b)``
        (``a <= b``) already searched, each ``(reach, i, j, distance)``: every
        pair of distinct centres of a and b (indices of `centers`) within
        ``reach`` as ``trees[a].sparse_distance_matrix(trees[b], reach)``
        finds them, as :func:`~diskpack_cl.radii.certified_k` has them from
        its search for the largest k.  They serve where the groups are those
        of `radii` (scaled radii can round across an octave's border) in a
        rectangle, a search where it reached as far as this one; otherwise
        the trees are made and searched here.  The certificate is the same.

    Returns
    -------
    Certificate

    Examples
    --------
    >>> cert = certify_disks([[1, 1], [3, 1]], [0.9, 0.9], Domain.rect(4, 2))
    >>> cert.valid
    True
    """
    C = np.asarray(centers, np.float64)
    r = np.asarray(radii, np.float64)
    if len(C) == 0:
        return Certificate(True, np.inf, 0, True, True)
    if not (np.all(np.isfinite(C)) and np.all(np.isfinite(r)) and np.all(r >= 0)):
        return Certificate(False, -np.inf, 0, False, False)
    if domain.periodic:
        C = domain.wrap(C)
        edge_gap = np.inf
        inside = True
    else:
        edge = np.minimum.reduce([C[:, 0], domain.width - C[:, 0], C[:, 1], domain.height - C[:, 1]])
        edge_gap = float(np.min(edge - r))
        inside = edge_gap >= 0
    i, j = _octave_pairs(C, r, domain, octaves)
    d = domain.shortest(C[j] - C[i])
    gaps = np.hypot(d[:, 0], d[:, 1]) - r[i] - r[j]
    pair_gap = float(gaps.min()) if len(gaps) else np.inf
    disjoint = pair_gap > 0 if len(gaps) else True
    return Certificate(bool(inside and disjoint), min(pair_gap, edge_gap), int(len(gaps)), bool(inside), bool(disjoint))
