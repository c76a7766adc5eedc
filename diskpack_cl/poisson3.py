"""Poisson disk sets in 3D: relaxation to the centres of the maximal inscribed spheres.

The 3D form of Algorithm 1: every iteration moves each point to the centre
of the largest sphere inside its Voronoi cell (on the 3-torus, or in a box
whose walls clip the cells), from :class:`diskpack_cl.device.cells3.CellMIC3` on
the device or :func:`diskpack_cl.device.cells3.exact_mis` without one.  On the
torus the new spheres lie in the old cells, so the minimum distance never
drops, as in 2D.

rho is normalized by the densest sphere packing (FCC, density
``pi / (3 sqrt 2)``): ``r_max(n) = (V / (4 sqrt(2) n))^(1/3)`` for n
spheres in volume V, and ``rho = (d_min / 2) / r_max``.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.spatial import cKDTree

from .device.cells3 import CellMIC3, Domain3, exact_mis
from .domain import box_sizes
from .memory import freed_memory_kept
from .engine import HOST_DEVICE
from .relax import STALL_GAIN, RelaxResult
from .device.context import NoOpenCLError
from .sampling import first_come, make_rng

__all__ = ["FCC_DENSITY", "fcc_radius", "normalized_radius3", "relax_poisson3", "as_box3",
           "dart_throwing3"]

#: Density of the face-centred cubic packing, the densest sphere packing.
FCC_DENSITY = np.pi / (3.0 * np.sqrt(2.0))


def fcc_radius(n, volume=1.0):
    """Sphere radius of the FCC packing of `n` spheres in `volume`: ``(V / (4 sqrt 2 n))^(1/3)``.

    Examples
    --------
    >>> r = fcc_radius(1000)
    >>> round(float(1000 * 4 / 3 * np.pi * r ** 3), 6), round(float(FCC_DENSITY), 6)
    (0.74048, 0.74048)
    """
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n}")
    return float((volume / (4.0 * np.sqrt(2.0) * n)) ** (1.0 / 3.0))


def normalized_radius3(points, domain=Domain3.torus()):
    """rho of a 3D point set: half its minimum distance over :func:`fcc_radius` (KD-tree).

    Examples
    --------
    >>> g = (np.indices((4, 4, 4)).reshape(3, -1).T + 0.5) / 4    # a cubic lattice
    >>> round(normalized_radius3(g), 4)    # (pi / 6 / FCC_DENSITY)^(1/3)
    0.8909
    """
    X = domain.check(points)
    tree = cKDTree(X, boxsize=domain.size if domain.periodic else None)
    d, _ = tree.query(X, k=2, workers=-1)   # every core: half the time at 100k points
    return 0.5 * float(d[:, 1].min()) / fcc_radius(len(X), domain.volume)


def as_box3(box):
    """The 3D domain `box` names: None or ``"torus"``, ``"WxHxD"`` or ``(W, H, D)``.

    Examples
    --------
    >>> as_box3("2x1x1")
    Domain3(width=2.0, height=1.0, depth=1.0, periodic=False)
    """
    if box is None or (isinstance(box, str) and box == "torus"):
        return Domain3.torus()
    if isinstance(box, Domain3):
        return box
    return Domain3.box(*box_sizes(box, "WxHxD"))


def dart_throwing3(n, domain=Domain3.torus(), *, rel_radius=0.65, seed=None, max_batches=200):
    """Dart throwing in 3D: uniform darts kept at least ``2 rel_radius fcc_radius(n)`` apart.

    Darts come in batches checked against the kept points (a KD-tree,
    periodic on the torus) and, within a batch, in order
    (:func:`diskpack_cl.sampling.first_come`).  Random sequential
    adsorption saturates near rho 0.8 in 3D; the default 0.65 fills fast.
    In a box the darts keep half the distance from the walls, where the
    relaxation would push them (about 4x fewer iterations).  Returns fewer
    than `n` points only if `max_batches` run out.

    Examples
    --------
    >>> p = dart_throwing3(500, seed=0)
    >>> p.shape, bool(normalized_radius3(p) >= 0.65)
    ((500, 3), True)
    """
    rng = make_rng(seed)
    d = 2.0 * rel_radius * fcc_radius(n, domain.volume)
    box = domain.size if domain.periodic else None
    # in a box, darts keep a radius from the walls, as relaxed points do
    inset = 0.0 if domain.periodic else min(0.5 * d, 0.25 * domain.size.min())
    pts, kept = np.empty((0, 3)), _KeptDarts(d, box)
    for _ in range(max_batches):
        cand = rng.random((max(1024, 2 * (n - len(pts))), 3)) * (domain.size - 2 * inset) + inset
        cand = cand[kept.free(pts, cand)]
        cand = cand[first_come(cand, d, box)] if len(cand) else cand
        pts = np.vstack([pts, cand[: n - len(pts)]])
        if len(pts) == n:
            break
    return pts


class _KeptDarts:
    """Which darts lie at least `d` from the points kept so far: the points in two
    KD-trees, one of them kept while the points added since are fewer than a quarter
    of it (at 100 000 points 30 batches rebuilt a tree of all points each, 1.4 s)."""

    def __init__(self, d, box):
        self.d, self.box, self.big, self.size = d, box, None, 0

    def free(self, pts, cand):
        """A mask of the darts `cand` at least d from every point of `pts` (the points so
        far: those of the last call and more after them)."""
        if not len(pts):
            return np.ones(len(cand), dtype=bool)
        if self.big is None or len(pts) - self.size > 0.25 * self.size:
            self.big, self.size = cKDTree(pts, boxsize=self.box), len(pts)
        dist = self._nearest(self.big, cand)
        if len(pts) > self.size:
            dist = np.minimum(dist, self._nearest(cKDTree(pts[self.size:], boxsize=self.box), cand))
        return dist >= self.d

    def _nearest(self, tree, cand):
        return tree.query(cand, distance_upper_bound=self.d, workers=-1)[0]


def relax_poisson3(points, eps=0.75, *, domain=None, max_iter=1000, patience=100, backend="auto",
                   device=None, callback=None, certify=True):
    """Relax a 3D point set to the centres of its cells' maximal inscribed spheres until rho >= eps.

    Parameters
    ----------
    points : (n, 3) array_like
    eps : float
        Target rho (normalized by FCC), in (0, 1).
    domain : Domain3, optional
        The unit 3-torus (default) or a box.
    max_iter, patience, callback :
        As in :func:`diskpack_cl.relax_poisson`.
    backend : {"auto", "opencl", "exact"}
        ``opencl``: :class:`CellMIC3`; ``exact``: :func:`exact_mis` (one
        linprog per cell: small sets only); ``auto``: opencl if possible.
    certify : bool
        False: the iterates take the device's proven spheres without the
        host's re-solve and certificate of every cell (``CellMIC3.solve``);
        rho is measured exactly on the host either way.

    Returns
    -------
    RelaxResult

    Examples
    --------
    >>> X = np.random.default_rng(0).random((200, 3))
    >>> res = relax_poisson3(X, 0.7)
    >>> res.stop_reason, bool(res.rho[-1] >= 0.7)
    ('eps', True)
    """
    dom = Domain3.torus() if domain is None else domain
    X = dom.check(points)
    if not 0.0 < eps < 1.0:
        raise ValueError(f"eps must be in (0, 1), got {eps}")
    solve, name, where, fallback = _solver(dom, backend, device, certify)
    t0 = time.perf_counter()
    rho, best_at, it, reason = [normalized_radius3(X, dom)], 0, 0, "max_iter"
    stats = {"fallback": fallback} if fallback else {}
    with freed_memory_kept():   # every step makes and drops the same large temporaries
        while rho[-1] < eps and it < max_iter:
            it += 1
            step = solve(X)
            for k, v in step.stats.items():
                stats[k] = stats.get(k, 0) + v
            X = dom.check(step.centers)
            rho.append(normalized_radius3(X, dom))
            if callback is not None:
                callback(it, rho[-1])
            if rho[-1] > rho[best_at] + max(1e-12, STALL_GAIN * min(rho[best_at], eps - rho[best_at])):
                best_at = it
            elif it - best_at >= patience:
                reason = "stalled"
                break
    if rho[-1] >= eps:
        reason = "eps"
    return RelaxResult(X, np.array(rho), it, reason, time.perf_counter() - t0, {},
                       name, where, stats)


def _solver(domain, backend, device, certify=True):
    """``(points -> MIS, backend, device, fallback)``: the solver of `backend`, where it
    runs, and why ``auto`` took the exact one (None where it did not)."""
    if backend not in ("auto", "opencl", "exact"):
        raise ValueError(f"backend must be 'auto', 'opencl' or 'exact', got {backend!r}")
    fallback = None
    if backend != "exact":
        try:
            engine = CellMIC3(domain, device)
            return (lambda X: engine.solve(X, certify)), "opencl", engine.device_name, None
        except (NoOpenCLError, RuntimeError) as exc:
            if backend == "opencl":
                raise
            # the 2D engine's words (diskpack_cl.engine.make_engine)
            fallback = f"no OpenCL device ({exc})" if isinstance(exc, NoOpenCLError) else str(exc)
    return (lambda X: exact_mis(X, domain)), "exact", HOST_DEVICE, fallback
