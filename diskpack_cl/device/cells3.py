"""3D per-cell stage: the maximal inscribed sphere of every Voronoi cell, on the device.

``kernels/cells3.cl`` gives each site one work item that solves its
cell's Chebyshev-centre linear program in float64 by the dual simplex
method (four active constraints at the optimum, against three in 2D) and
proves the answer by scanning every bucket the cutter ball touches.  The
host then re-solves every cell from its four active constraints in float64,
checks dual feasibility, and certifies primal feasibility against the
nearest sites of each centre (a site farther than ``|q| + 2 R`` from the
centre cannot cut the sphere); cells that fail any check are solved again
by ``scipy.optimize.linprog`` (:func:`exact_mis`) and certified the same way.
Iterates whose caller measures the set it returns may skip the host's
re-solve and certificate (``certify=False``).

The domain is the 3-torus ``[0, W) x [0, H) x [0, D)`` or the box
``[0, W] x [0, H] x [0, D]`` (:class:`Domain3`), whose walls clip the cells.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linprog
from scipy.spatial import cKDTree
import pyopencl as cl

from .context import group_size, padded
from .stage import DeviceStage

__all__ = ["Domain3", "CellMIC3", "MIS", "exact_mis", "certify_mis", "inscribed_sphere_linprog",
           "refine_basis"]

CHUNK = 1 << 16  # work items per enqueue
_FIRST_K = 24    # sites per cell in the certificate's first pass
GROUP = 16
#: Flag bits of the kernel, mirrored from ``kernels/cells3.cl``.
FLAGS = {"pivots": 1, "unbounded": 2, "scan_wide": 4, "singular": 8, "shift": 16}
_WALLS = np.array([[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1]], float)


@dataclass(frozen=True)
class Domain3:
    """The 3-torus (``periodic``) or the closed box of size ``width x height x depth``.

    Examples
    --------
    >>> Domain3.box(2, 1, 1).volume
    2.0
    >>> Domain3.torus().periodic
    True
    """

    width: float = 1.0
    height: float = 1.0
    depth: float = 1.0
    periodic: bool = True

    @classmethod
    def torus(cls):
        """The unit 3-torus."""
        return cls(1.0, 1.0, 1.0, True)

    @classmethod
    def box(cls, width, height, depth):
        """The box ``[0, width] x [0, height] x [0, depth]``; sizes must be positive."""
        if not all(np.isfinite(v) and v > 0 for v in (width, height, depth)):
            raise ValueError(f"box size must be positive, got {width} x {height} x {depth}")
        return cls(float(width), float(height), float(depth), False)

    @property
    def size(self):
        return np.array([self.width, self.height, self.depth])

    @property
    def volume(self):
        return self.width * self.height * self.depth

    def shortest(self, offsets):
        """The offsets `offsets` (``(n, 3)`` float64) made shortest over the periods, in
        place (a box's stay as they are); returns them, as :meth:`Domain.shortest
        <diskpack_cl.domain.Domain.shortest>` does in 2D.

        Examples
        --------
        >>> Domain3.torus().shortest(np.array([[0.75, -0.5, 0.25]])).tolist()
        [[-0.25, -0.5, 0.25]]
        """
        if self.periodic:
            offsets -= np.round(offsets / self.size) * self.size
        return offsets

    def check(self, points, minimum=2):
        """`points` as a float64 (n, 3) copy: wrapped on the torus, checked inside a box."""
        X = np.array(points, dtype=np.float64)
        if X.ndim != 2 or X.shape[1] != 3:
            raise ValueError(f"points must have shape (n, 3), got {X.shape}")
        if len(X) < minimum:
            raise ValueError(f"need at least {minimum} points, got {len(X)}")
        if not np.all(np.isfinite(X)):
            raise ValueError("points contain NaN or infinite coordinates")
        if self.periodic:
            X = np.mod(X, self.size)
            X[X >= self.size] = 0.0
        elif np.any(X < 0) or np.any(X > self.size):
            raise ValueError("points lie outside the box")
        return X

    def images(self, points, margin):
        """``(positions, index)``: the points (first n rows) and, on a torus, their images
        within `margin` of the domain."""
        if not self.periodic:
            return points, np.arange(len(points))
        size = self.size
        r = np.arange(-int(np.ceil(margin / size.min())), int(np.ceil(margin / size.min())) + 1)
        shifts = np.array(np.meshgrid(r, r, r, indexing="ij")).reshape(3, -1).T
        shifts = shifts[np.argsort(np.abs(shifts).sum(1), kind="stable")]   # (0, 0, 0) first
        pos, idx = [], []
        for s in shifts:
            q = points + s * size
            keep = np.all((q >= -margin) & (q <= size + margin), axis=1)
            pos.append(q[keep])
            idx.append(np.nonzero(keep)[0])
        return np.concatenate(pos), np.concatenate(idx)


@dataclass
class MIS:
    """Maximal inscribed spheres: ``centers (n, 3)``, ``radii (n,)``, ``stats``, ``timings``.

    Examples
    --------
    >>> X = np.random.default_rng(0).random((50, 3))
    >>> mis = exact_mis(X, Domain3.torus())
    >>> mis.centers.shape, bool(np.all(mis.radii > 0))
    ((50, 3), True)
    """

    centers: np.ndarray
    radii: np.ndarray
    stats: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)


def inscribed_sphere_linprog(normals, beta):
    """Chebyshev centre of ``{q : q . normals_k <= beta_k}`` (3D) by ``scipy.optimize.linprog``.

    Returns ``(q (3,), R)``; the independent reference of the kernel.

    Examples
    --------
    >>> q, R = inscribed_sphere_linprog(np.vstack([np.eye(3), -np.eye(3)]), np.ones(6))
    >>> bool(np.allclose(q, 0)), float(round(R, 12))
    (True, 1.0)
    """
    A = np.column_stack([normals, np.ones(len(beta))])
    res = linprog([0, 0, 0, -1], A_ub=A, b_ub=beta, bounds=[(None, None)] * 4, method="highs")
    if res.status != 0:
        raise RuntimeError(f"linprog failed: {res.message}")
    return res.x[:3], res.x[3]


def _polished(normals, beta):
    """linprog's Chebyshev centre, moved to the exact vertex of its four tightest
    constraints when that vertex is feasible (HiGHS stops within 1e-7)."""
    q, R = inscribed_sphere_linprog(normals, beta)
    slack = beta - normals @ q - R
    tight = np.argsort(slack)[:4]
    A = np.column_stack([normals[tight], np.ones(4)])
    if len(beta) < 4 or abs(np.linalg.det(A)) < 1e-12:
        return q, R
    x = np.linalg.solve(A, beta[tight])
    if np.all(beta - normals @ x[:3] - x[3] >= -1e-12) and x[3] >= R - 1e-6:
        return x[:3], x[3]
    return q, R


def _planes(X, i, pos, domain):
    """Normals and betas of cell i from the image sites `pos` (and the walls of a box)."""
    a = pos - X[i]
    L = np.linalg.norm(a, axis=1)
    keep = L > 0
    normals, beta = a[keep] / L[keep, None], 0.5 * L[keep]
    if not domain.periodic:
        lim = np.column_stack([X[i], domain.size - X[i]]).ravel()
        normals, beta = np.vstack([normals, _WALLS]), np.concatenate([beta, lim])
    return normals, beta


def _margin(domain, n):
    """Image margin: a few mean spacings, or the whole period for very few sites."""
    return min(4.0 * (domain.volume / n) ** (1 / 3), float(domain.size.min()))


def certify_mis(points, centers, radii, domain, *, cells=None, k=48, tol=1e-10):
    """Which spheres ``(centers, radii)`` of the cells `cells` (all by default) are certified
    to lie in their Voronoi cells.

    Sphere i is feasible when it lies in the box and no site cuts it: only
    sites within ``|c - x_i| + 2 R`` of its centre c can, so the ``k``
    nearest image sites of c settle it when the k-th lies beyond that.
    Returns a bool array (False also where k sites did not reach far enough).

    Examples
    --------
    >>> X = np.array([[0.25, 0.5, 0.5], [0.75, 0.5, 0.5]])
    >>> certify_mis(X, X, np.array([0.25, 0.25]), Domain3.torus()).tolist()
    [True, True]
    """
    S = domain.check(points)
    X = S if cells is None else S[cells]
    q = domain.shortest(np.asarray(centers) - X)
    reach = np.linalg.norm(q, axis=1) + 2.0 * radii
    # every image that can cut a sphere is in the tree (few sites: wide cells)
    margin = max(_margin(domain, len(S)), 1.01 * float(reach.max(initial=0.0)))
    pos, _ = domain.images(S, margin)
    k = min(k, len(pos))
    tree, ok, todo = cKDTree(pos), np.zeros(len(X), bool), np.arange(len(X))
    for kk in sorted({min(_FIRST_K, k), k}):   # most cells are settled by their nearest few
        d, j = tree.query(X[todo] + q[todo], k=kk)
        a = pos[j.reshape(len(todo), kk)] - X[todo, None, :]
        L = np.linalg.norm(a, axis=2)
        with np.errstate(invalid="ignore", divide="ignore"):
            slack = 0.5 * L - np.einsum("nkc,nc->nk", a, q[todo]) / L - radii[todo, None]
        settled = (d.reshape(len(todo), kk)[:, -1] > reach[todo]) | (kk == len(pos))
        ok[todo] = settled & np.all((slack >= -tol) | (L == 0), axis=1)
        todo = todo[~settled]
    if not domain.periodic:
        ok &= np.all(X + q - radii[:, None] >= -tol, axis=1)
        ok &= np.all(X + q + radii[:, None] <= domain.size + tol, axis=1)
    return ok


def exact_mis(points, domain, cells=None, *, k=64):
    """Maximal inscribed spheres of Voronoi cells by ``linprog``, each certified.

    Cell i's LP holds its ``k`` nearest image sites (and the walls); a cell
    whose answer :func:`certify_mis` does not certify is solved again with
    twice as many (and more periodic images).  linprog's answer is moved to
    the exact vertex of its four tightest constraints where that vertex is
    feasible; ``stats["uncertified"]`` counts cells left at linprog's
    tolerance (ill-conditioned ones, such as a tight cluster's).  Slow (one
    linprog per cell): the fallback and reference.

    Examples
    --------
    >>> X = np.random.default_rng(0).random((30, 3))
    >>> m = exact_mis(X, Domain3.torus())
    >>> m.radii.shape, bool(np.all(m.radii > 0))
    ((30,), True)
    """
    X = domain.check(points)
    cells = np.arange(len(X)) if cells is None else np.asarray(cells, dtype=np.intp)
    if len(cells) * _FEW <= len(X):
        found = _exact_mis_near(X, domain, cells, k)
        if found is not None:
            return found
    return _exact_mis(X, domain, cells, k)


#: :func:`exact_mis` of at most one cell in this many first solves them among the
#: sites around them (:func:`_exact_mis_near`): the images and trees of all sites
#: cost 0.3-0.45 s a call at 100 000 sites, for the one cell the kernel left.
_FEW = 50
#: How far around its cells' sites :func:`_exact_mis_near` keeps sites, in mean spacings,
#: and how many it needs there (about 2000 in a set of even density).
_NEAR_SPACINGS = 8.0
_NEAR_SITES = 100


def _exact_mis_near(X, domain, cells, k):
    """:func:`exact_mis` of `cells` among the sites within :data:`_NEAR_SPACINGS` mean
    spacings ``rho`` of theirs, or None where a sphere reaches too far for that.

    A site farther than ``|q| + 2 R`` from a sphere's centre cannot cut it, so
    one farther than ``rho >= 2 (|q| + R)`` from the cell's site cannot: the
    sphere of the fewer sites is then feasible among all, and as its cell
    holds the true one, it is the true one."""
    rho = _NEAR_SPACINGS * (domain.volume / len(X)) ** (1 / 3)
    if domain.periodic and 2.0 * rho >= domain.size.min():
        return None
    tree = cKDTree(X, boxsize=domain.size if domain.periodic else None)
    lists = tree.query_ball_point(X[cells], rho)
    if min(map(len, lists)) < _NEAR_SITES:   # a lone site: its cell reaches far
        return None
    near = np.unique(np.concatenate(lists).astype(np.intp))
    mis = _exact_mis(X[near], domain, np.searchsorted(near, cells), k)
    q = domain.shortest(mis.centers - X[cells])
    return mis if np.all(2.0 * (np.linalg.norm(q, axis=1) + mis.radii) <= rho) else None


def _exact_mis(X, domain, cells, k):
    """:func:`exact_mis` of `cells` among all the sites X."""
    margin = _margin(domain, len(X))
    pos, _ = domain.images(X, margin)
    tree = cKDTree(pos)
    centers, radii = X[cells].copy(), np.zeros(len(cells))
    todo = np.arange(len(cells))
    while len(todo):
        if k >= len(pos) and domain.periodic and margin < domain.size.max():
            margin *= 2   # the cells reach past the images: more of them
            pos, _ = domain.images(X, margin)
            tree = cKDTree(pos)
        kk = min(k, len(pos))
        for t in todo:
            i = cells[t]
            _, j = tree.query(X[i], k=kk)
            q, radii[t] = _polished(*_planes(X, i, pos[np.atleast_1d(j)], domain))
            centers[t] = X[i] + q
        good = certify_mis(X, centers[todo], radii[todo], domain, cells=cells[todo])
        if kk == len(pos) and not (domain.periodic and margin < domain.size.max()):
            break
        todo, k = todo[~good], 2 * k
    # ill-conditioned cells (a tight cluster's nearly parallel planes) may keep
    # linprog's answer, within its tolerance (1e-7): counted, not hidden
    left = len(todo) and int(np.count_nonzero(~certify_mis(
        X, centers[todo], radii[todo], domain, cells=cells[todo], k=min(27 * len(X), 2048))))
    return MIS(centers, radii, {"linprog": int(len(cells)), "uncertified": int(left)})


def _basis_rows(X, domain, codes):
    """Rows ``(n_k, 1)`` and betas of the constraints `codes` (n, 4) of each cell (float64).

    Site codes ``125 j + 25 (sx + 2) + 5 (sy + 2) + (sz + 2)``; -1..-6 the
    walls; anything else (artificial) gives a zero row, which no check passes.
    """
    n = len(X)
    A = np.zeros(codes.shape + (4,))
    b = np.zeros(codes.shape)
    site = codes >= 0
    j, r = np.divmod(np.where(site, codes, 0), 125)
    shift = np.stack([r // 25 - 2, (r // 5) % 5 - 2, r % 5 - 2], -1) * domain.size
    a = X[j] + shift - X[np.arange(n)][:, None, :]
    L = np.linalg.norm(a, axis=2)
    L[~site | (L == 0)] = np.inf
    A[..., :3] = np.where(site[..., None], a / L[..., None], 0.0)
    b[:] = np.where(site, 0.5 * L, 0.0)
    wall = (codes <= -1) & (codes >= -6)
    rows, cols = np.nonzero(wall)
    w = -codes[rows, cols] - 1
    A[rows, cols, :3] = _WALLS[w]
    lim = np.column_stack([X, domain.size - X])[:, [0, 3, 1, 4, 2, 5]]
    b[rows, cols] = lim[rows, w]
    A[..., 3] = np.where(site | wall, 1.0, 0.0)
    return A, b


def refine_basis(X, domain, codes, tol=1e-9):
    """Re-solve each cell from its four active constraints in float64.

    Returns ``(q (n, 3), R (n,), ok (n,))``: ok where the basis is regular
    and dual feasible (multipliers >= -tol), so R bounds the optimum from
    above; with the primal certificate (:func:`certify_mis`) it is optimal.

    Examples
    --------
    >>> X = np.array([[0.5, 0.5, 0.5]])    # one site in the unit box: four walls
    >>> q, R, ok = refine_basis(X, Domain3.box(1, 1, 1), np.array([[-1, -2, -3, -5]]))
    >>> float(R[0]), bool(ok[0])
    (0.5, True)
    """
    A, b = _basis_rows(X, domain, codes)
    ok = np.abs(np.linalg.det(A)) > 1e-12
    A[~ok] = np.eye(4)
    x = np.linalg.solve(A, b[..., None])[..., 0]
    e4 = np.broadcast_to([0.0, 0.0, 0.0, 1.0], (len(X), 4))[..., None]
    lam = np.linalg.solve(np.swapaxes(A, 1, 2), e4)[..., 0]
    ok &= np.all(lam >= -tol, axis=1)
    return x[:, :3], x[:, 3], ok


class CellMIC3(DeviceStage):
    """OpenCL processing object for the maximal inscribed spheres of 3D Voronoi cells.

    Parameters
    ----------
    domain : Domain3
    device : str or pyopencl.Context, optional
    sites_per_bucket : float, optional

    Examples
    --------
    >>> X = np.random.default_rng(0).random((300, 3))
    >>> res = CellMIC3(Domain3.torus()).solve(X)
    >>> bool(np.allclose(res.radii, exact_mis(X, Domain3.torus()).radii, atol=1e-9))
    True
    """

    def __init__(self, domain, device=None, *, sites_per_bucket=1.0):
        self.domain = domain
        super().__init__(device, fp64=True)
        self.sites_per_bucket = float(sites_per_bucket)
        self._kernel = self.program("cells3", {"PERIODIC": int(domain.periodic)})["cell_mic3"]
        self.group = group_size(self._kernel, self.ctx.devices[0], GROUP)

    def _buckets(self, X):
        dom = self.domain
        side = (dom.volume * self.sites_per_bucket / len(X)) ** (1 / 3)
        nb = np.maximum(1, np.ceil(dom.size / side)).astype(np.int64)
        b = np.minimum((X / (dom.size / nb)).astype(np.int64), nb - 1)
        bid = (b[:, 2] * nb[1] + b[:, 1]) * nb[0] + b[:, 0]
        order = np.argsort(bid, kind="stable")
        start = np.zeros(int(nb.prod()) + 1, np.int32)
        np.cumsum(np.bincount(bid, minlength=int(nb.prod())), out=start[1:])
        return order, start, nb

    def solve(self, points, certify=True):
        """Maximal inscribed sphere of every cell, certified (see the module docstring).

        Parameters
        ----------
        points : (n, 3) array_like
        certify : bool, optional
            False: take the device's answer for every cell it proved, without
            the host's re-solve and certificate (about half a call's time);
            cells it could not prove still go to :func:`exact_mis`.  For
            iterates whose caller measures the set it returns.

        Returns
        -------
        MIS
            ``stats``: ``flagged`` (cells the device could not prove),
            ``rejected`` (cells the host checks refused), ``fallback``
            (cells solved by :func:`exact_mis`).

        Examples
        --------
        >>> X = np.random.default_rng(0).random((300, 3))
        >>> eng, mis = CellMIC3(Domain3.torus()), exact_mis(X, Domain3.torus())
        >>> bool(np.allclose(eng.solve(X, certify=False).radii, mis.radii, rtol=0, atol=1e-9))
        True
        """
        X = self.domain.check(points)
        t0 = time.perf_counter()
        order, start, nb = self._buckets(X)
        Xs = np.ascontiguousarray(X[order])
        mic, codes = self._run(Xs, start, nb)
        t1 = time.perf_counter()
        flagged = codes[:, 4] != 0
        if certify:
            q, R, ok = refine_basis(Xs, self.domain, codes[:, :4])
            ok &= ~flagged & (np.abs(R - mic[:, 3]) <= 1e-9 * self.domain.size.max())
            ok[ok] = certify_mis(Xs, Xs[ok] + q[ok], R[ok], self.domain, cells=np.nonzero(ok)[0])
        else:
            q, R, ok = mic[:, :3], mic[:, 3].copy(), ~flagged
        t2 = time.perf_counter()
        centers = Xs + q
        bad = np.nonzero(~ok)[0]
        if len(bad):
            fb = exact_mis(Xs, self.domain, cells=bad)
            centers[bad], R[bad] = fb.centers, fb.radii
        if self.domain.periodic:
            centers = self.domain.check(centers)
        out_c, out_r = np.empty_like(centers), np.empty_like(R)
        out_c[order], out_r[order] = centers, R
        stats = {"flagged": int(flagged.sum()), "rejected": int((~ok & ~flagged).sum()),
                 "fallback": int(len(bad)), "uncertified": fb.stats["uncertified"] if len(bad) else 0}
        stats.update({k: int(np.count_nonzero(codes[:, 4] & bit)) for k, bit in FLAGS.items()})
        timings = {"device": t1 - t0, "refine": t2 - t1, "fallback": time.perf_counter() - t2}
        return MIS(out_c, out_r, stats, timings)

    def _run(self, Xs, start, nb):
        n = len(Xs)
        mf = cl.mem_flags
        b_site = cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=Xs)
        b_start = cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=start)
        mic, codes = np.empty((n, 4)), np.empty((n, 5), np.int32)
        b_mic = cl.Buffer(self.ctx, mf.WRITE_ONLY, mic.nbytes)
        b_codes = cl.Buffer(self.ctx, mf.WRITE_ONLY, codes.nbytes)
        dom = self.domain
        tol = 1e-12 * dom.size.max()
        for off in range(0, n, CHUNK):
            self._kernel(self.queue, (padded(min(CHUNK, n - off), self.group),), (self.group,),
                         b_site, b_start, np.int32(n), *(np.int32(v) for v in nb),
                         *(np.float64(v) for v in dom.size), np.float64(tol), np.int32(off),
                         b_mic, b_codes).wait()
        cl.enqueue_copy(self.queue, mic, b_mic)
        cl.enqueue_copy(self.queue, codes, b_codes)
        return mic, codes
