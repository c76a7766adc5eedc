"""``scipy.stats.qmc.PoissonDisk``'s engine, by disk packing in 2D and 3D.

:class:`PoissonDisk` is a :class:`scipy.stats.qmc.QMCEngine` with scipy's
signature, errors and state: ``random(n)`` hands out at most `n` new points
that keep ``radius`` from every point handed out since the last
:meth:`~PoissonDisk.reset`, :meth:`~PoissonDisk.fill_space` the rest.  In
2D and 3D the points come from one relaxed set per reset
(:func:`diskpack_cl.poisson_disk` with ``walls="points"``), handed out in a
random order; in any other dimension scipy's own engine draws them.  A
few points from a box that holds many are thrown as darts instead, so that
``random(10)`` does not pack a box of millions.
"""

from __future__ import annotations

import inspect
import operator

import numpy as np
import scipy
from scipy.stats import qmc

from .memory import check_poisson_memory
from .poisson import count_for_distance, poisson_disk

__all__ = ["PoissonDisk"]

#: scipy's candidate draws (Bridson's algorithm), which the packing has no use for.
HYPERSPHERES = ("volume", "surface")

#: The dimensions the packing serves; scipy's engine serves the others.
PACKED_DIMS = (2, 3)

#: Boxes that hold more packed points than this serve a few points by dart throwing:
#: below it the whole packing takes about a second (65536 points: 1.3 s on PoCL, 2 cores).
DART_FROM = 2 ** 16

#: The share of the box's packed points that darts serve; a dart then lands in room
#: with a chance of about 0.6 or more (the darts' exclusion disks cover at most ~40 %).
DART_SHARE = 1 / 8

#: The fewest darts thrown in one round (a round rebuilds the k-d tree of the darts).
DART_ROUND = 1024

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
    walls.  In a box that holds more than ``DART_FROM`` packed points, the
    first draws (together at most ``DART_SHARE`` of them) are thrown as
    darts over the whole box instead, each kept where it has the radius; a
    packing made after them leaves out its points within the radius of a
    dart.  The points are placed in coordinates relative to `l_bounds` and
    kept apart after rounding to the caller's: far from the origin, where
    float64 cannot resolve the radius, fewer points fit.  In any other dimension (0, 1, 4, ...), and where the box holds
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
        bounds (not broadcastable, not ``l_bounds < u_bounds``); and bounds
        that are not finite numbers or whose difference overflows, a
        `radius` that is not positive and finite or `ncandidates` that is
        not a non-negative integer.
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
        # checked first in every dimension: scipy's engine fails on some of them later,
        # with messages that name nothing ("negative dimensions are not allowed")
        _check(d, radius, hypersphere, ncandidates)
        lower, upper = _bounds(l_bounds, u_bounds, int(d))
        bridson = dict(radius=radius, hypersphere=hypersphere, ncandidates=ncandidates,
                       l_bounds=l_bounds, u_bounds=u_bounds, **seeding)
        # scipy's engine before the base class, so that it spawns from a Generator what a
        # scipy engine made from it would
        self._bridson = None if d in PACKED_DIMS else _scipy_engine(d, bridson)
        super().__init__(d=d, optimization=optimization, **seeding)
        # what scipy.integrate.qmc_quad passes to make more engines like this one
        self._init_quad = {"d": d, "radius": radius, "hypersphere": hypersphere,
                           "ncandidates": ncandidates, "optimization": optimization}
        self.radius, self.hypersphere, self.ncandidates = radius, hypersphere, ncandidates
        self.l_bounds, self.u_bounds = lower, upper
        # the disks of radius/2 lie in the box grown by radius/2 on every side
        grown = float(np.prod(self.u_bounds - self.l_bounds + radius))
        self.capacity = count_for_distance(radius, grown, dim=d) if d in PACKED_DIMS else 0
        if self._bridson is None and self.capacity < 2:
            self._bridson = _scipy_engine(d, bridson)
        self.packed = self._bridson is None
        self._points, self._handed, self._drawn = None, 0, None
        self._darts = np.empty((0, self.d))

    def random(self, n=1, *, workers=1):
        """At most `n` new points, each at least ``radius`` from every point drawn so far.

        Parameters
        ----------
        n : int, optional
            A non-negative integer (``inf``: all that fit, as :meth:`fill_space`).
        workers : int, optional
            Unused (scipy's signature).

        Returns
        -------
        (m, d) ndarray
            ``m <= n``: fewer once the box is full.

        Raises
        ------
        TypeError
            `n` not an integer.
        ValueError
            `n` negative.
        """
        # drawn first, so that the base class counts (and optimizes) what is handed out
        self._drawn = self._draw(_count(n))
        return super().random(len(self._drawn), workers=workers)

    def _random(self, n=1, *, workers=1):
        drawn, self._drawn = self._drawn, None
        return drawn

    def _draw(self, n):
        if not self.packed:
            return self._bridson.random(n)
        if n == 0:
            return np.empty((0, self.d))
        if self._points is None and self._dartable(n):
            return self._throw(n)
        points = self._packing()
        new = points[self._handed:self._handed + int(min(n, len(points) - self._handed))]
        self._handed += len(new)
        return new

    def fill_space(self):
        """All the points that still fit: the rest of the packed set (or scipy's fill).

        Returns
        -------
        (m, d) ndarray
        """
        return self.random(np.inf)

    def reset(self):
        """Start over: the same points again, in the same order.

        Returns
        -------
        PoissonDisk
            This engine.
        """
        super().reset()
        self._points, self._handed = None, 0
        self._darts = np.empty((0, self.d))
        if not self.packed:
            self._bridson.reset()
        return self

    def _packing(self):
        """The relaxed set of the whole box in the order it is handed out (made on first use),
        less its points within the radius of a dart handed out before.

        The box is scaled so that its longest side is 1, so a scaled and shifted box
        with a scaled radius gives the same points scaled and shifted.
        """
        if self._points is None:
            check_poisson_memory(self.capacity, names=("n", "radius"))
            rng = _generator(self.rng)
            side = self._side()
            res = poisson_disk(min_distance=self.radius / side, box=tuple(self._unit_box()),
                               walls="points", dim=self.d, seed=rng)
            points = self._placed(res.points)
            if res.min_distance * side - self._rounding() < self.radius:
                points = points[_apart(points, self.radius)]
            points = points[~_near(self._darts, points, self.radius)]
            self._points = points[rng.permutation(len(points))]
        return self._points

    def _dartable(self, n):
        """Whether darts serve `n` more points: a box too large to pack for a few points."""
        return (self.capacity > DART_FROM
                and len(self._darts) + n <= DART_SHARE * self.capacity)

    def _throw(self, n):
        """`n` darts over the whole box, each the radius from every point handed out.

        Rounds of twice the darts still missing (at least ``DART_ROUND``, and as many as
        are out already, so that rebuilding their k-d tree costs a constant factor).
        """
        rng = _generator(self.rng)
        new = np.empty((0, self.d))
        while len(new) < n:
            out = np.vstack([self._darts, new])
            size = max(2 * (n - len(new)), DART_ROUND, len(out))
            darts = self._placed(rng.random((size, self.d)) * self._unit_box())
            darts = darts[~_near(out, darts, self.radius)]
            new = np.vstack([new, darts[_apart(darts, self.radius)][:n - len(new)]])
        self._darts = np.vstack([self._darts, new])
        return new

    def _side(self):
        return float((self.u_bounds - self.l_bounds).max())

    def _unit_box(self):
        """The box's sides scaled so that the longest is 1."""
        return (self.u_bounds - self.l_bounds) / self._side()

    def _placed(self, unit):
        """Points of the unit-scaled box in the caller's coordinates, rounded into the box."""
        return np.clip(self.l_bounds + self._side() * unit, self.l_bounds, self.u_bounds)

    def _rounding(self):
        """A bound on what :meth:`_placed`'s float64 rounding takes off a distance:
        a few units in the last place of the bounds' largest magnitude, per axis."""
        largest = np.abs(np.concatenate([self.l_bounds, self.u_bounds])).max()
        return 8 * np.sqrt(self.d) * np.spacing(largest)


def _check(d, radius, hypersphere, ncandidates):
    """scipy's messages for a bad `d` and `hypersphere`; the other two fail only later in
    scipy, or not at all."""
    if not (np.issubdtype(type(d), np.integer) and d >= 0):
        raise ValueError(f"d must be a non-negative integer value, got {d!r}")
    if hypersphere not in HYPERSPHERES:
        raise ValueError(f"{hypersphere!r} is not a valid hypersphere sampling method. "
                         f"It must be one of {set(HYPERSPHERES)!r}")
    if not (np.issubdtype(type(ncandidates), np.integer) and ncandidates >= 0):
        raise ValueError(f"ncandidates must be a non-negative integer, got {ncandidates!r}")
    if not (np.isfinite(radius) and radius > 0):
        raise ValueError(f"radius must be positive and finite, got {radius!r}")


def _apart(points, distance):
    """A mask of `points` that leaves out one of each pair closer than `distance`
    (a relaxation that stopped short of the distance, rounding, darts of one round)."""
    from scipy.spatial import cKDTree

    keep = np.ones(len(points), dtype=bool)
    for i, j in cKDTree(points).query_pairs(distance, output_type="ndarray"):
        if keep[i]:
            keep[j] = False
    return keep


def _near(out, points, distance):
    """A mask of `points` closer than `distance` to a point of `out`."""
    from scipy.spatial import cKDTree

    if len(out) == 0:
        return np.zeros(len(points), dtype=bool)
    return cKDTree(out).query(points, distance_upper_bound=distance)[0] <= distance


def _count(n):
    """`n` checked as a count of :meth:`PoissonDisk.random` (``inf``: fill the space)."""
    if isinstance(n, (float, np.floating)) and n == np.inf:
        return np.inf
    try:
        count = operator.index(n)
    except TypeError:
        raise TypeError(f"n must be an integer, got {n!r}") from None
    if count < 0:
        raise ValueError(f"n must be a non-negative integer, got {n!r}")
    return count


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
    """``l_bounds, u_bounds`` as float arrays of length `d`, checked with scipy's messages
    (and finite numbers whose difference is finite: the box is scaled by it)."""
    lower = np.zeros(d) if l_bounds is None else l_bounds
    upper = np.ones(d) if u_bounds is None else u_bounds
    try:
        lower, upper = np.broadcast_to(lower, d), np.broadcast_to(upper, d)
    except ValueError:
        raise ValueError("'l_bounds' and 'u_bounds' must be broadcastable and respect the "
                         "sample dimension") from None
    try:
        lower, upper = lower.astype(np.float64), upper.astype(np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"'l_bounds' and 'u_bounds' must be numbers, got l_bounds={l_bounds!r}, "
                         f"u_bounds={u_bounds!r}") from None
    if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
        raise ValueError(f"'l_bounds' and 'u_bounds' must be finite, got l_bounds={lower}, "
                         f"u_bounds={upper}")
    if not np.all(lower < upper):
        raise ValueError("Bounds are not consistent 'l_bounds' < 'u_bounds'")
    with np.errstate(over="ignore"):
        if not np.all(np.isfinite(upper - lower)):
            raise ValueError(f"'u_bounds' - 'l_bounds' overflows float64, got "
                             f"l_bounds={lower}, u_bounds={upper}")
    return lower, upper
