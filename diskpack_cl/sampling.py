"""Start sets on the unit torus: dart throwing, uniform random points, Bridson.

All samplers are deterministic for a given ``seed`` (a ``numpy.random.Generator``
is built with ``numpy.random.default_rng(seed)``; a ready Generator is accepted
as well) and return ``(n, 2)`` float64 arrays in ``[0, 1)^2``. Distances are
periodic (minimum image on the unit torus).

Radii follow the paper's normalisation: for ``n`` points the hexagonal packing
radius is ``r_max = sqrt(1 / (2 sqrt(3) n))`` and the normalized Poisson disk
radius of a set is ``rho = (d_min / 2) / r_max`` (both in :mod:`diskpack_cl.measures`).
"""

from __future__ import annotations

import warnings

import numpy as np

from ._checks import check_count
from .measures import hexagonal_radius, normalized_radius

__all__ = [
    "DartThrowingWarning",
    "bridson",
    "dart_throwing",
    "random_points",
]


class DartThrowingWarning(UserWarning):
    """Dart throwing could not place n points at the requested radius and shrank it.

    Examples
    --------
    Above the saturation of dart throwing (about rho 0.78) it warns at once:

    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     points = dart_throwing(200, rel_radius=0.9, seed=0)
    >>> points.shape, {w.category.__name__ for w in caught}
    ((200, 2), {'DartThrowingWarning'})
    """


#: Relative radius at which maximal dart throwing saturates (0.77 to 0.78 with n):
#: a larger request is said to be out of reach before any dart is thrown.
DART_SATURATION = 0.78


def make_rng(seed):
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


def random_points(n, seed=None):
    """`n` independent uniform points on the unit torus.

    Examples
    --------
    >>> random_points(3, seed=1).shape
    (3, 2)
    """
    n = check_count(n)
    return make_rng(seed).random((n, 2))


def _offsets(k):
    o = np.arange(-k, k + 1)
    oy, ox = np.meshgrid(o, o, indexing="ij")
    return oy.ravel(), ox.ravel()


def _wrap_diff(q):
    q -= np.round(q)
    return q


class _Darts:
    """Grid state of batched dart throwing at one disk radius.

    The occupancy grid has cells of side ``c <= d / sqrt(2)`` (``d = 2 r`` the
    minimum distance), so a cell holds at most one point. Each cell is split
    into ``2 x 2`` children; a child whose four corners all lie within ``d`` of
    one accepted point is dead (every dart there would be rejected) and is no
    longer sampled. Darts are drawn uniformly over the live children, which is
    uniform dart throwing with part of the certain rejections skipped.
    """

    SUB = 2

    def __init__(self, r, n, pts, m):
        self.d2 = (2.0 * r) ** 2
        d = 2.0 * r
        g = max(1, int(np.ceil(1.0 / (r * np.sqrt(2.0)))))
        c = 1.0 / g
        k = int(np.ceil(d / c))
        oy, ox = _offsets(k)
        # neighbour cells that can hold a point closer than d to the own cell
        keep = (np.maximum(np.abs(oy) - 1, 0) ** 2 + np.maximum(np.abs(ox) - 1, 0) ** 2) * c * c < self.d2
        self.oy, self.ox = oy[keep], ox[keep]
        G = self.SUB * g
        h = c / self.SUB
        kk = int(np.ceil(d / h))
        coy, cox = _offsets(kk)
        # children that a disk centred in the own child can cover completely
        keep = (np.maximum(np.abs(coy), 0.5) ** 2 + np.maximum(np.abs(cox), 0.5) ** 2) * h * h < self.d2
        self.coy, self.cox = coy[keep], cox[keep]
        self.g, self.G, self.h = g, G, h
        self.corners = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], dtype=np.float64) * h
        self.pts = pts
        self.occ = np.full(g * g, -1, dtype=np.int64)
        self.alive = np.ones(G * G, dtype=bool)
        if m:
            self.insert(pts[:m], np.arange(m))

    def cells(self, p):
        child = np.minimum((p * self.G).astype(np.int64), self.G - 1)
        return child[:, 0], child[:, 1]

    def insert(self, p, index):
        cx, cy = self.cells(p)
        s, g, G = self.SUB, self.g, self.G
        self.occ[(cy // s) * g + cx // s] = index
        for lo in range(0, len(p), 8192):  # bound the (m, K, 4, 2) temporary
            sl = slice(lo, lo + 8192)
            ncx = (cx[sl, None] + self.cox) % G
            ncy = (cy[sl, None] + self.coy) % G
            base = np.stack([ncx, ncy], axis=-1) * self.h
            q = _wrap_diff(base[:, :, None, :] + self.corners - p[sl, None, None, :])
            covered = ((q * q).sum(-1) < self.d2).all(-1)
            self.alive[(ncy * G + ncx)[covered]] = False

    def conflicts(self, cand, cx, cy):
        s, g = self.SUB, self.g
        ix, iy = cx // s, cy // s
        bad = np.zeros(len(cand), dtype=bool)
        near = (np.abs(self.oy) <= 1) & (np.abs(self.ox) <= 1)
        todo = np.arange(len(cand))
        for sel in (near, ~near):  # the 3x3 block rejects most darts cheaply
            if not todo.size or not sel.any():
                continue
            nb = self.occ[((iy[todo, None] + self.oy[sel]) % g) * g + (ix[todo, None] + self.ox[sel]) % g]
            q = _wrap_diff(self.pts[np.maximum(nb, 0)] - cand[todo, None, :])
            hit = ((nb >= 0) & ((q * q).sum(-1) < self.d2)).any(1)
            bad[todo[hit]] = True
            todo = todo[~hit]
        return bad


def first_come(cand, d, boxsize=1.0):
    """Sequential acceptance inside one batch: a dart is kept unless an earlier kept
    dart of the batch lies closer than `d` (vectorized rounds, no per-dart loop);
    `boxsize`: the torus (any dimension), or None in a box."""
    from scipy.spatial import cKDTree  # not loaded at start-up: a Poisson set of parallel darts needs none

    m = len(cand)
    pairs = cKDTree(cand, boxsize=boxsize).query_pairs(d, output_type="ndarray")
    if not len(pairs):
        return np.ones(m, dtype=bool)
    pi, pj = pairs.min(axis=1), pairs.max(axis=1)
    state = np.zeros(m, dtype=np.int8)  # 0 undecided, 1 kept, -1 rejected
    while (state == 0).any():
        hit = np.zeros(m, dtype=bool)
        hit[pj[state[pi] == 1]] = True
        state[(state == 0) & hit] = -1
        blocked = np.zeros(m, dtype=bool)
        blocked[pj[state[pi] == 0]] = True
        state[(state == 0) & ~blocked] = 1  # includes the lowest undecided index
    return state == 1


def _dart_arguments(n, rel_radius, shrink, max_attempts):
    """Checked ``(n, max_attempts)`` of :func:`dart_throwing`."""
    n = check_count(n)
    if not 0.0 < rel_radius < 1.0:
        raise ValueError(f"rel_radius must be in (0, 1), got {rel_radius}")
    if not 0.0 < shrink < 1.0:
        raise ValueError(f"shrink must be in (0, 1), got {shrink}")
    if max_attempts is None:
        max_attempts = 50 * n + 10000
    if max_attempts < 1:
        raise ValueError(f"max_attempts must be positive, got {max_attempts}")
    return n, max_attempts


def _throw(state, rng, live, batch, pts, m, remaining, r):
    """Throw `batch` darts into the `live` cells; accept them in order into ``pts[m:]``.

    Returns how many were accepted (at most `remaining`).
    """
    child = live[rng.integers(0, live.size, batch)]
    cx, cy = child % state.G, child // state.G
    cand = (np.stack([cx, cy], axis=1) + rng.random((batch, 2))) * state.h
    cand[cand >= 1.0] = 0.0  # rounding at the far edge wraps to 0
    cx, cy = state.cells(cand)
    ok = np.flatnonzero(~state.conflicts(cand, cx, cy))
    if not ok.size:
        return 0
    ok = ok[first_come(cand[ok], 2.0 * r)][:remaining]
    pts[m:m + ok.size] = cand[ok]
    state.insert(cand[ok], np.arange(m, m + ok.size))
    return ok.size


def _beyond_saturation(rel, n, shrink):
    """Warn at once (before any dart) when `rel` is past the saturation; True if it is."""
    if rel <= DART_SATURATION:
        return False
    warnings.warn(f"relative radius {rel:g} is above maximal dart throwing's saturation (about "
                  f"{DART_SATURATION}): {n} points will not fit, the radius shrinks by {shrink:g} "
                  f"a step until they do", DartThrowingWarning, stacklevel=3)
    return True


def _warn_saturated(rel_radius, m, n, shrink):
    warnings.warn(f"dart throwing saturated at relative radius {rel_radius:g} with {m} of {n} "
                  f"points placed; shrinking the radius by {shrink:g} a step",
                  DartThrowingWarning, stacklevel=3)


def dart_throwing(n, *, rel_radius=0.74, seed=None, max_attempts=None, shrink=0.98,
                  full_output=False):
    """Dart throwing on the unit torus at a relative radius.

    A uniform dart is accepted when it lies at least ``2 r`` (periodic distance)
    from every accepted point, ``r = rel_radius * sqrt(1 / (2 sqrt(3) n))``,
    until `n` points are accepted. Darts are thrown in vectorized batches
    checked against a bucket grid; inside a batch, darts are accepted in order,
    exactly as if thrown one by one. Cells already covered by one disk are not
    sampled (their darts would all be rejected), which speeds up the end of the
    run without changing the distribution. The result has ``rho >= rel_radius``.

    Parameters
    ----------
    n : int
        Number of points (at least 1).
    rel_radius : float, optional
        Requested normalized radius, in (0, 1). Maximal dart throwing saturates
        near 0.77 to 0.78 (depending on n); above that `n` points cannot be placed.
    seed : int, numpy.random.Generator or None, optional
        Seed for ``numpy.random.default_rng`` (deterministic for a seed).
    max_attempts : int, optional
        Darts allowed at one radius before it is declared saturated. Default
        ``50 * n + 10000``.
    shrink : float, optional
        Fallback: when a radius saturates before `n` points, the radius is
        multiplied by `shrink` (the accepted points stay, they are farther apart
        than the new radius asks) and throwing goes on, repeatedly if needed.
        A :class:`DartThrowingWarning` names the final relative radius.
    full_output : bool, optional
        Also return a dict with ``rel_radius_requested``, ``rel_radius`` (final),
        ``radius`` (final r), ``shrinks``, ``darts`` and ``rho`` (measured).

    Returns
    -------
    points : ndarray, shape (n, 2), float64 in [0, 1)^2
    info : dict
        Only with ``full_output=True``.

    Examples
    --------
    >>> p = dart_throwing(256, seed=0)
    >>> p.shape
    (256, 2)
    >>> p2, info = dart_throwing(256, seed=0, full_output=True)
    >>> bool((p == p2).all()), info["shrinks"], info["rho"] >= 0.74
    (True, 0, True)
    """
    n, max_attempts = _dart_arguments(n, rel_radius, shrink, max_attempts)
    rng = make_rng(seed)
    rel = float(rel_radius)
    r = rel * hexagonal_radius(n)
    warned = _beyond_saturation(rel, n, shrink)
    pts = np.empty((n, 2), dtype=np.float64)
    m = darts_total = shrinks = darts_level = 0
    state, rate = _Darts(r, n, pts, m), 1.0
    while m < n:
        live = np.flatnonzero(state.alive)
        if not live.size or darts_level >= max_attempts:
            if not (shrinks or warned):  # say so at once, not after the remaining shrinks
                _warn_saturated(rel_radius, m, n, shrink)
            shrinks += 1
            rel *= shrink
            r = rel * hexagonal_radius(n)
            state, darts_level, rate = _Darts(r, n, pts, m), 0, 1.0
            continue
        batch = int(np.clip(1.5 * (n - m) / max(rate, 1e-4), 256, 1 << 16))
        batch = min(batch, max_attempts - darts_level)
        accepted = _throw(state, rng, live, batch, pts, m, n - m, r)
        m, darts_level, darts_total = m + accepted, darts_level + batch, darts_total + batch
        rate = 0.5 * rate + 0.5 * max(accepted / batch, 1e-5)
    if shrinks:
        warnings.warn(
            f"dart throwing could not place {n} points at relative radius {rel_radius:g}; "
            f"shrank it {shrinks} time(s) to {rel:.4f}", DartThrowingWarning, stacklevel=2)
    if not full_output:
        return pts
    return pts, {"rel_radius_requested": float(rel_radius), "rel_radius": rel, "radius": r,
                 "shrinks": shrinks, "darts": darts_total,
                 "rho": normalized_radius(pts) if len(pts) >= 2 else float("nan")}


def bridson(n=None, *, radius=None, k=30, seed=None, max_tries=8):
    """Bridson-style Poisson disk sampling on the unit torus.

    Starting from one uniform point, an active point spawns up to `k` uniform
    candidates in the annulus ``[d, 2 d]`` around it (``d = 2 * radius``, the
    minimum distance); the first candidate at least ``d`` from all points is
    accepted and becomes active, and a point whose `k` candidates all fail
    leaves the active list. (R. Bridson, "Fast Poisson disk sampling in
    arbitrary dimensions", SIGGRAPH 2007 sketches.)

    Give exactly one of `n` or `radius`. With `radius`, the sample holds as many
    points as fit. With `n`, the radius is tuned over up to `max_tries` runs
    until a run yields at least `n` points; the surplus is removed at random
    (this keeps the minimum distance and usually removes under 1 % of the points).

    Returns
    -------
    points : ndarray, shape (m, 2), float64 in [0, 1)^2

    Examples
    --------
    >>> bridson(200, seed=3).shape
    (200, 2)
    """
    if (n is None) == (radius is None):
        raise ValueError("give exactly one of n or radius")
    rng = make_rng(seed)
    if radius is not None:
        if not 0.0 < radius < 0.25:
            raise ValueError(f"radius must be in (0, 0.25), got {radius}")
        return _bridson_run(float(radius), int(k), rng)
    n = check_count(n, 2)
    radius = 0.725 * hexagonal_radius(n)  # Bridson with k=30 packs at rho ~ 0.727
    best = None
    for _ in range(max_tries):
        pts = _bridson_run(radius, int(k), rng)
        m = len(pts)
        if m >= n and (best is None or m < len(best)):
            best = pts
        if n <= m <= 1.01 * n + 1:
            break
        radius *= np.sqrt(m / n) * (0.997 if m < n else 1.0)
    if best is None:
        raise RuntimeError(f"bridson: could not reach {n} points")  # pragma: no cover
    if len(best) > n:
        best = best[np.sort(rng.choice(len(best), n, replace=False))]
    return best


def _bridson_run(radius, k, rng):
    d = 2.0 * radius
    d2 = d * d
    g = max(1, int(np.ceil(np.sqrt(2.0) / d)))  # cell side <= d / sqrt(2): one point a cell
    c = 1.0 / g
    kc = int(np.ceil(d / c))
    oy, ox = _offsets(kc)
    capacity = g * g + 1
    pts = np.empty((capacity, 2), dtype=np.float64)
    occ = np.full(g * g, -1, dtype=np.int64)

    def cell(p):
        i = np.minimum((p * g).astype(np.int64), g - 1)
        return i[..., 0], i[..., 1]

    pts[0] = rng.random(2)
    ix, iy = cell(pts[0])
    occ[iy * g + ix] = 0
    m = 1
    active = [0]
    while active:
        j = int(rng.integers(len(active)))
        base = pts[active[j]]
        rad = d * np.sqrt(1.0 + 3.0 * rng.random(k))  # uniform over the annulus area
        ang = 2.0 * np.pi * rng.random(k)
        cand = np.mod(base + np.stack([rad * np.cos(ang), rad * np.sin(ang)], axis=1), 1.0)
        cand[cand >= 1.0] = 0.0
        cx, cy = cell(cand)
        nb = occ[((cy[:, None] + oy) % g) * g + (cx[:, None] + ox) % g]
        q = _wrap_diff(pts[np.maximum(nb, 0)] - cand[:, None, :])
        good = ~((nb >= 0) & ((q * q).sum(-1) < d2)).any(1)
        if good.any():
            i = int(np.argmax(good))
            pts[m] = cand[i]
            occ[cy[i] * g + cx[i]] = m
            active.append(m)
            m += 1
        else:
            active[j] = active[-1]
            active.pop()
    return pts[:m].copy()
