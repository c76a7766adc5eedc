"""``scipy.stats.qmc.PoissonDisk``'s engine, by disk packing in 2D and 3D.

:class:`PoissonDisk` is a :class:`scipy.stats.qmc.QMCEngine` with scipy's
signature, errors and state: ``random(n)`` hands out at most `n` new points
that keep ``radius`` from every point handed out since the last
:meth:`~PoissonDisk.reset`, :meth:`~PoissonDisk.fill_space` the rest.  In
2D and 3D the points come from one relaxed set per reset
(:func:`diskpack_cl.poisson_disk` with ``walls="points"``), handed out in a
random order; in any other dimension scipy's own engine draws them.
"""

from __future__ import annotations

import inspect

import numpy as np
import scipy
from scipy.stats import qmc

from .poisson import count_for_distance, poisson_disk

__all__ = ["PoissonDisk"]

#: scipy's candidate draws (Bridson's algorithm), which the packing has no use for.
HYPERSPHERES = ("volume", "surface")

#: The dimensions the packing serves; scipy's engine serves the others.
PACKED_DIMS = (2, 3)

#: scipy's engine (Bridson's algorithm), named here once: tests swap ``qmc.PoissonDisk``.
_Bridson = qmc.PoissonDisk

# scipy 1.15 renamed QMCEngine's `seed` to `rng` (SPEC 7); scipy 1.13's PoissonDisk takes no bounds
_RNG_KEYWORD = "rng" if "rng" in inspect.signature(qmc.QMCEngine.__init__).parameters else "seed"
_BRIDSON_BOUNDS = "l_bounds" in inspect.signature(_Bridson.__init__).parameters


class PoissonDisk(qmc.QMCEngine):
    """Poisson disk sampling with the interface of ``scipy.stats.qmc.PoissonDisk``.

    In 2D and 3D the points are a relaxed disk packing (more points than
    scipy's at the same radius, more evenly spread), made once per reset
    for the whole box and handed out in a random order; the points reach the
    walls.  In any other dimension (0, 1, 4, ...), and where the box holds
    fewer than two packed points, scipy's own engine draws them.  The 3D
    packing wants an OpenCL device: the host alone solves every cell and
    is much slower than scipy's engine.

    Parameters
    ----------
    d : int
        Dimension of the space.
    radius : float, optional
        The smallest distance between two points (scipy's meaning: the
        points may lie on the walls).
    hypersphere : {"volume", "surface"}, optional
        How scipy's engine draws its candidates around a point (in its
        dimensions); the packing draws no candidates and ignores it.
    ncandidates : int, optional
        Candidates per point for scipy's engine (in its dimensions); the
        packing ignores it.
    optimization : {None, "random-cd", "lloyd"}, optional
        Applied by :class:`~scipy.stats.qmc.QMCEngine` to each ``random``
        draw, as for scipy's engines (it does not keep the radius).
    rng : numpy.random.Generator, int or None, optional
        Seeds the engine (passed to ``numpy.random.default_rng``); a
        ``Generator`` is spawned, not consumed.
    l_bounds, u_bounds : array_like (d,), optional
        The box's corners (default the unit hypercube).
    seed : int, numpy.random.Generator, numpy.random.RandomState or None, optional
        scipy's older name of `rng`, with its older meaning (a
        ``RandomState`` is used as given); give one of the two.

    Raises
    ------
    ValueError
        As scipy's engine does: a bad `d`, `optimization`, `hypersphere` or
        bounds; and a `radius` that is not positive and finite or
        `ncandidates` that is not a non-negative integer.
    TypeError
        Both `rng` and `seed`.

    See Also
    --------
    diskpack_cl.poisson_disk : a count or a distance, a torus, a mask, a density.

    Examples
    --------
    >>> from scipy.spatial.distance import pdist
    >>> eng = PoissonDisk(2, radius=0.1, rng=1)
    >>> first, rest = eng.random(10), eng.fill_space()
    >>> len(first), eng.num_generated == len(first) + len(rest)
    (10, True)
    >>> bool(pdist(np.vstack([first, rest])).min() >= 0.1), len(eng.random(5))
    (True, 0)
    >>> bool(np.array_equal(eng.reset().random(10), first))
    True

    Side by side with scipy's engine, at the same radius and seed:

    >>> from scipy.stats import qmc
    >>> ours = PoissonDisk(2, radius=0.05, seed=7).fill_space()
    >>> theirs = qmc.PoissonDisk(2, radius=0.05, seed=7).fill_space()
    >>> len(ours) > len(theirs), bool(min(pdist(ours).min(), pdist(theirs).min()) >= 0.05)
    (True, True)
    """

    def __init__(self, d, *, radius=0.05, hypersphere="volume", ncandidates=30, optimization=None,
                 rng=None, l_bounds=None, u_bounds=None, seed=None):
        seeding = _seeding(rng, seed)
        bridson = dict(radius=radius, hypersphere=hypersphere, ncandidates=ncandidates,
                       l_bounds=l_bounds, u_bounds=u_bounds, **seeding)
        # scipy's engine before the base class, so that it spawns from a Generator what a
        # scipy engine made from it would (and checks the arguments as scipy does)
        self._bridson = None if d in PACKED_DIMS else _scipy_engine(d, bridson)
        super().__init__(d=d, optimization=optimization, **seeding)
        # what scipy.integrate.qmc_quad passes to make more engines like this one
        self._init_quad = {"d": d, "radius": radius, "hypersphere": hypersphere,
                           "ncandidates": ncandidates, "optimization": optimization}
        _check(radius, hypersphere, ncandidates)
        self.radius, self.hypersphere, self.ncandidates = radius, hypersphere, ncandidates
        self.l_bounds, self.u_bounds = _bounds(l_bounds, u_bounds, int(d))
        # the disks of radius/2 lie in the box grown by radius/2 on every side
        grown = float(np.prod(self.u_bounds - self.l_bounds + radius))
        if self._bridson is None and count_for_distance(radius, grown, dim=d) < 2:
            self._bridson = _scipy_engine(d, bridson)
        self.packed = self._bridson is None
        self._points, self._handed = None, 0

    def random(self, n=1, *, workers=1):
        """At most `n` new points, each at least ``radius`` from every point drawn so far.

        Parameters
        ----------
        n : int, optional
        workers : int, optional
            Unused (scipy's signature).

        Returns
        -------
        (m, d) ndarray
            ``m <= n``: fewer once the box is full.
        """
        if self.packed:
            n = min(n, len(self._packing()) - self._handed)
        return super().random(n, workers=workers)

    def _random(self, n=1, *, workers=1):
        if not self.packed:
            return self._bridson.random(n)
        new = self._packing()[self._handed:self._handed + n]
        self._handed += len(new)
        return new

    def fill_space(self):
        """All the points that still fit: the rest of the packed set (or scipy's fill).

        Returns
        -------
        (m, d) ndarray
        """
        return self.random(len(self._packing()) - self._handed if self.packed else np.inf)

    def reset(self):
        """Start over: the same points again, in the same order.

        Returns
        -------
        PoissonDisk
            This engine.
        """
        super().reset()
        self._points, self._handed = None, 0
        if not self.packed:
            self._bridson.reset()
        return self

    def _packing(self):
        """The relaxed set of the whole box in the order it is handed out (made on first use).

        The box is scaled so that its longest side is 1, so a scaled and shifted box
        with a scaled radius gives the same points scaled and shifted.
        """
        if self._points is None:
            rng = _generator(self.rng)
            span = self.u_bounds - self.l_bounds
            side = float(span.max())
            res = poisson_disk(min_distance=self.radius / side, box=tuple(span / side),
                               walls="points", dim=self.d, seed=rng)
            points = self.l_bounds + side * _apart(res.points, res.min_distance, self.radius / side)
            self._points = points[rng.permutation(len(points))]
        return self._points


def _check(radius, hypersphere, ncandidates):
    """scipy's message for a bad `hypersphere`; the other two fail only later in scipy."""
    if hypersphere not in HYPERSPHERES:
        raise ValueError(f"{hypersphere!r} is not a valid hypersphere sampling method. "
                         f"It must be one of {set(HYPERSPHERES)!r}")
    if not (np.issubdtype(type(ncandidates), np.integer) and ncandidates >= 0):
        raise ValueError(f"ncandidates must be a non-negative integer, got {ncandidates!r}")
    if not (np.isfinite(radius) and radius > 0):
        raise ValueError(f"radius must be positive and finite, got {radius!r}")


def _apart(points, d_min, distance):
    """`points` less one of each pair closer than `distance` (a relaxation that stopped
    short of the distance; none when it reached it)."""
    if d_min >= distance:
        return points
    from scipy.spatial import cKDTree

    keep = np.ones(len(points), dtype=bool)
    for i, j in cKDTree(points).query_pairs(distance, output_type="ndarray"):
        if keep[i]:
            keep[j] = False
    return points[keep]


def _seeding(rng, seed):
    """The keyword that seeds :class:`~scipy.stats.qmc.QMCEngine` as scipy's engine would."""
    if seed is not None:
        if rng is not None:
            raise TypeError("PoissonDisk() got multiple values for argument now known as "
                            "`rng`. Specify one of `rng` or `seed`.")
        return {"seed": seed}
    # an older QMCEngine takes only `seed`: the Generator that `rng` would make
    return {_RNG_KEYWORD: rng if _RNG_KEYWORD == "rng" else np.random.default_rng(rng)}


def _scipy_engine(d, kwargs):
    """scipy's engine with `kwargs`, the bounds only where given (scipy 1.13's takes none)."""
    kwargs = {k: v for k, v in kwargs.items() if not (k.endswith("_bounds") and v is None)}
    if not _BRIDSON_BOUNDS and kwargs.keys() & {"l_bounds", "u_bounds"}:
        raise TypeError(f"scipy {scipy.__version__}'s PoissonDisk, which draws the points in "
                        f"d = {d} or in a box too small for two packed points, takes no bounds")
    return _Bridson(d, **kwargs)


def _generator(rng):
    """A ``Generator`` drawing from `rng` (a legacy ``RandomState`` seeds a new one)."""
    if isinstance(rng, np.random.Generator):
        return rng
    return np.random.default_rng(rng.randint(2 ** 31, size=4))


def _bounds(l_bounds, u_bounds, d):
    """``l_bounds, u_bounds`` as float arrays of length `d`, checked with scipy's messages."""
    lower = np.zeros(d) if l_bounds is None else l_bounds
    upper = np.ones(d) if u_bounds is None else u_bounds
    try:
        lower, upper = np.broadcast_to(lower, d), np.broadcast_to(upper, d)
    except ValueError:
        raise ValueError("'l_bounds' and 'u_bounds' must be broadcastable and respect the "
                         "sample dimension") from None
    if not np.all(lower < upper):
        raise ValueError("Bounds are not consistent 'l_bounds' < 'u_bounds'")
    return lower.astype(np.float64), upper.astype(np.float64)
