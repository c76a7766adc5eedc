"""Parallel dart throwing on a background grid, vectorized in numpy.

The unit torus is cut into ``g x g`` cells of side ``c <= d / sqrt(2)``
(``d`` the minimum distance), so a cell holds at most one point, and a
point can conflict only with the points of the 24 cells around its own.
A round throws one dart into every live cell at once, each with a random
priority; a dart is kept when it is at least ``d`` from every point placed
before and from every higher-priority dart of the round that is itself
free of the old points.  Two kept darts are then never closer than ``d``
(the lower-priority one would have seen the other).  A cell stops being
live when it holds a point, or, from the second round on (every second
round), when its corners and
centre all lie within ``d`` of points (darts there would almost surely be
rejected).

Why not Wei's phase groups (L.-Y. Wei, "Parallel Poisson disk sampling",
SIGGRAPH 2008), which throw into the cells of one of 9 phases
``(row % 3, col % 3)`` at a time and need no priorities: the first phase
of the first round places a jittered lattice of period ``3 c``, and that
order outlives the later phases and the relaxation (at 100k points, a
ring peak of 10.8 and axis-aligned spikes of 20-27 dB at the lattice's
frequencies, against 1.8 for dart throwing).  Random priorities have no
such lattice: the darts of a round are a full-cell jittered grid, whose
spectrum vanishes at the grid's frequencies.

The points are stored in the grid itself, with a two-cell border that
mirrors the opposite side shifted by one period, so a neighbour is a fixed
offset in a flat array and the torus needs no modulo in the inner loop.
"""

from __future__ import annotations

import numpy as np
import pyopencl as cl

from ._checks import check_count
from .measures import hexagonal_radius
from .device.context import NoOpenCLError, get_context, group_size, padded
from .device.checks import UntrustedProgram, warn_fallback
from .device.stage import DeviceStage

__all__ = ["parallel_darts"]

_PAD = 2          # border cells mirroring the far side
_EMPTY = 1e9      # coordinate of an empty cell: farther than any d
_SAMPLES = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [0.5, 0.5]])


class _Grid:
    """A padded grid of at most one point a cell for the minimum distance `d` on the unit torus."""

    def __init__(self, d):
        self.d = d
        self.d2 = d * d
        self.g = g = max(1, int(np.ceil(np.sqrt(2.0) / d)))
        self.c = 1.0 / g
        self.G = G = g + 2 * _PAD
        self.x = np.full(G * G, _EMPTY)
        self.y = np.full(G * G, _EMPTY)
        off = [(dy, dx) for dy in range(-2, 3) for dx in range(-2, 3) if (dy, dx) != (0, 0)]
        near = [dy * G + dx for dy, dx in off if max(abs(dy), abs(dx)) == 1]
        far = [dy * G + dx for dy, dx in off if max(abs(dy), abs(dx)) == 2]
        self.offsets = np.array(near + far)   # the 3x3 block rejects most darts

    def flat(self, cells):
        """Padded flat index of interior cells ``row * g + col``."""
        row, col = np.divmod(cells, self.g)
        return (row + _PAD) * self.G + col + _PAD

    def free(self, flat, x, y, prio=None, mine=None, near_only=False):
        """Which points (x, y), in the cells `flat`, are at least d from every point of the
        grid (with `prio`: from every one whose priority is above `mine`; with `near_only`:
        of the 3 x 3 cells around)."""
        ok = np.ones(len(flat), dtype=bool)
        idx = np.arange(len(flat))
        mine = np.zeros(len(flat)) if mine is None else mine
        for block in (self.offsets[:8], self.offsets[8:16], self.offsets[16:]):
            hit = np.zeros(len(idx), dtype=bool)
            for o in block:
                k = flat + o
                dx, dy = self.x[k] - x, self.y[k] - y
                h = dx * dx + dy * dy < self.d2
                hit |= h if prio is None else h & (prio[k] > mine)
            ok[idx[hit]] = False
            if near_only:
                break
            idx, flat, x, y, mine = (a[~hit] for a in (idx, flat, x, y, mine))
        return ok

    def spread(self, arrays, cells, values):
        """Write `values` (one tuple of per-cell arrays) into `arrays` at `cells`, and into
        the border copies of edge cells (coordinates shifted by a period: ``shift=True``)."""
        g, G = self.g, self.G
        row, col = np.divmod(cells, g)
        edge = (row < _PAD) | (row >= g - _PAD) | (col < _PAD) | (col >= g - _PAD)
        for sy in (-1, 0, 1):
            for sx in (-1, 0, 1):
                sel = slice(None) if sx == sy == 0 else edge
                r, c = row[sel] + _PAD - sy * g, col[sel] + _PAD - sx * g
                m = (r >= 0) & (r < G) & (c >= 0) & (c < G)
                at = r[m] * G + c[m]
                for a, (v, shift) in zip(arrays, values):
                    a[at] = v[sel][m] - (shift * (sx if a is self.x else sy) if shift else 0)

    def insert(self, cells, x, y):
        """Put points into their cells (and the border copies)."""
        self.spread((self.x, self.y), cells, ((x, True), (y, True)))

    def covered(self, cells):
        """Cells whose corners and centre all lie within d of a point of the 3 x 3 cells around."""
        row, col = np.divmod(cells, self.g)
        flat = self.flat(cells)
        allc = np.ones(len(cells), dtype=bool)
        for sx, sy in _SAMPLES:   # points of the 3 x 3 cells cover most (test stays sound)
            allc &= ~self.free(flat, (col + sx) * self.c, (row + sy) * self.c, near_only=True)
        return allc

    def hand_on(self):
        """Nothing to hand on (:meth:`_DeviceGrid.hand_on`): the grid is host arrays."""

    def points(self):
        inner = np.zeros((self.G, self.G), dtype=bool)
        inner[_PAD:-_PAD, _PAD:-_PAD] = True
        keep = inner.ravel() & (self.x < _EMPTY)
        return np.column_stack([self.x[keep], self.y[keep]])

    def cells_of(self, pts):
        ij = np.minimum((pts / self.c).astype(np.int64), self.g - 1)
        return ij[:, 1] * self.g + ij[:, 0]

    def throw(self, live, rng, room, empty):
        return _round(self, live, rng, room, empty)


def _keys(rng):
    """A round's three keys (uniforms along x, along y, priorities) from `rng`."""
    return rng.integers(0, 2**64, size=3, dtype=np.uint64)


def _uniform(key, cells):
    """Uniforms in [0, 1), one per cell of `cells`: the top 53 bits of splitmix64's
    output number ``cell + 1`` of the stream `key`, as ``uniform`` in
    ``kernels/parallel_darts.cl``: the device draws its darts itself, and nothing but
    lists of cells goes up to it.

    Examples
    --------
    >>> u = _uniform(np.uint64(7), np.arange(4))
    >>> bool(((u >= 0) & (u < 1)).all()), bool(u[2] == _uniform(np.uint64(7), [2])[0])
    (True, True)
    """
    z = key + (np.asarray(cells).astype(np.uint64) + np.uint64(1)) * np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return ((z ^ (z >> np.uint64(31))) >> np.uint64(11)).astype(np.float64) * 2.0**-53


def _room(keep, room, rng):
    """`keep`, or `room` of them at random where it holds more (in their order): the
    first `room` would fill the last round's rows from the bottom of the torus up."""
    return keep if len(keep) <= room else np.sort(rng.choice(keep, room, replace=False))


def _round(grid, live, rng, room, empty):
    """One round: a dart into every live cell at once, with a random priority each
    (`empty`: the grid holds no point yet).

    Returns the cells still live and how many points were placed (at most `room`).
    """
    ku, kv, kp = _keys(rng)
    row, col = np.divmod(live, grid.g)
    x = (col + _uniform(ku, live)) * grid.c
    y = (row + _uniform(kv, live)) * grid.c
    flat = grid.flat(live)
    keep = np.arange(live.size) if empty else np.flatnonzero(grid.free(flat, x, y))
    darts = _Grid(grid.d)
    prio = np.full(grid.G * grid.G, -1.0)
    mine = _uniform(kp, live[keep])
    darts.spread((darts.x, darts.y, prio), live[keep], ((x[keep], True), (y[keep], True),
                                                         (mine, False)))
    keep = _room(keep[darts.free(flat[keep], x[keep], y[keep], prio, mine)], room, rng)
    grid.insert(live[keep], x[keep], y[keep])
    gone = np.zeros(live.size, dtype=bool)
    gone[keep] = True
    return live[~gone], keep.size


class _DeviceGrid(DeviceStage):
    """The grid of :class:`_Grid` on an OpenCL device (``kernels/parallel_darts.cl``).

    The host draws a round's keys with the same generator calls and keeps a
    copy of the points; the kernels hash the darts' uniforms and priorities
    from the keys as :func:`_uniform` does, place the darts and do the
    distance tests in the same float64 operations, so both give the same
    points for a seed.  The host computes the coordinates of the kept darts
    only (a pass over 3.5M cells fewer in the first round).  The
    grids of points, darts and priorities stay on the device from round to
    round and every kernel takes a list of cells: after two rounds a quarter
    of the cells are live, and dense passes over the whole grid (3.5M cells
    at 1M points) were what a round cost.
    """

    def __init__(self, d, ctx):
        self.d, self.d2 = d, d * d
        self.g = g = max(1, int(np.ceil(np.sqrt(2.0) / d)))
        self.c = 1.0 / g
        super().__init__(ctx, fp64=True)
        self.k = self.program("parallel_darts")
        # explicit groups: left to itself, PoCL takes a divisor of the global size (1 for a prime)
        self.group = {name: group_size(k, ctx.devices[0], 64) for name, k in self.k.items()}
        # the host keeps the points it placed, by round (a full grid of 3.5M cells at 1M
        # points, filled on the host and copied over, took 0.2 s; the device fills its own)
        self.placed = []
        # the three grids in one buffer, handed on as one when the rounds are done (a
        # relaxation's MIC outputs fit in it: DeviceStage.hand_on)
        self.b_pt, self.b_dart, self.b_prio = self.regions("grids", (16 * g * g, 16 * g * g, 8 * g * g))
        self._fill(self.b_pt, _EMPTY)
        # dart_keep reads every neighbour's dart and masks the ones without a priority:
        # filled, so that no read is of memory never written (one pass, about 5 ms at 1M)
        self._fill(self.b_dart, _EMPTY)
        self._fill(self.b_prio, -1.0)

    def _fill(self, buf, value):
        """Set every float64 of the device buffer `buf` to `value` (kernel ``fill``)."""
        m = np.int64(buf.size // 8)   # 2 g * g passes 2**31 at g = 32768
        self._launch("fill", m, buf, np.float64(value), m)

    def _up(self, name, a):
        """The non-empty host array `a` for the kernels, read-only (:meth:`DeviceStage.lend`:
        on a CPU device the array itself, which a copy would put in fresh pages), as `name`."""
        return self.lend(name, np.ascontiguousarray(a))

    def _test(self, name, m, *args):
        """Kernel `name` over `m` cells, its other arguments `args` (host arrays are
        uploaded): its 0/1 answers as bools."""
        out = np.zeros(m, dtype=bool)
        if m:
            b_out = cl.Buffer(self.ctx, cl.mem_flags.WRITE_ONLY, m)
            args = [self._up(f"{name}{k}", a) if isinstance(a, np.ndarray) else a
                    for k, a in enumerate(args)]
            self._launch(name, m, *args, b_out)
            cl.enqueue_copy(self.queue, out.view(np.int8), b_out)
        return out

    def _put(self, name, grid, b_cells, values):
        """Write `values` into device grid `grid` at the cells of `b_cells` (kernel `name`)."""
        self._launch(name, len(values), grid, b_cells, self._up(name, values), np.int32(len(values)))

    def _launch(self, name, m, *args):
        """Kernel `name` over `m` work items (the kernels skip the padding past `m`)."""
        group = self.group[name]
        self.k[name](self.queue, (padded(m, group),), (group,), *args)

    def _darts_at(self, cells, xy):
        """The device buffer of `cells`, with the darts `xy` written there first (None: those
        :meth:`place` put in the dart grid)."""
        b_cells = self._up("cells", cells)
        if xy is not None:
            self._put("put_pair", self.b_dart, b_cells, xy)
        return b_cells

    def free(self, cells, xy=None):
        """Which darts, one in each of the distinct empty `cells` (int32), are at least
        d from every point: `xy`, or (None) those :meth:`place` put in the dart grid."""
        if not len(cells):
            return np.zeros(0, dtype=bool)
        return self._free_at(self._darts_at(cells, xy), len(cells))

    def _free_at(self, b_cells, m):
        """:meth:`free` of the darts at the `m` cells of the device list `b_cells`."""
        m = np.int32(m)
        return self._test("dart_free", m, self.b_pt, b_cells, self.b_dart, m, np.int32(self.g),
                          np.float64(self.d2))

    def place(self, cells, ku, kv):
        """Put the darts ``((col + u) c, (row + v) c)`` of the distinct `cells` (int32,
        non-empty) into the dart grid, on the device: u, v the uniforms of keys `ku`, `kv`."""
        self._place_at(self._up("cells", cells), len(cells), ku, kv)

    def _place_at(self, b_cells, m, ku, kv):
        """:meth:`place` at the `m` cells of the device list `b_cells`."""
        m = np.int32(m)
        self._launch("dart_place", m, self.b_dart, b_cells, m, np.int32(self.g),
                     np.float64(self.c), np.uint64(ku), np.uint64(kv))

    def kept(self, cells, xy, key):
        """Which free darts, one in each of the distinct `cells` (int32), with the
        priorities of key `key` (:func:`_uniform`), have no dart of higher priority
        within d: `xy`, or (None) those in the dart grid."""
        if not len(cells):
            return np.zeros(0, dtype=bool)
        return self._kept_at(self._darts_at(cells, xy), len(cells), key)

    def _kept_at(self, b_cells, k, key):
        """:meth:`kept` of the darts at the `k` cells of the device list `b_cells`."""
        k = np.int32(k)
        self._launch("set_prio", k, self.b_prio, b_cells, k, np.uint64(key), np.int32(0))
        kept = self._test("dart_keep", k, self.b_dart, self.b_prio, b_cells, k,
                          np.int32(self.g), np.float64(self.d2))
        # clear these priorities, so that the next round's darts see none of them
        self._launch("set_prio", k, self.b_prio, b_cells, k, np.uint64(key), np.int32(1))
        return kept

    def throw(self, live, rng, room, empty):
        """One round (as :func:`_round`): the cells still live and the points placed."""
        ku, kv, kp = _keys(rng)
        b_live = self._up("live", live)   # the live cells, for the round's kernels
        self._place_at(b_live, live.size, ku, kv)
        if empty:   # no point yet: every dart is free, and its cells' list is up already
            keep = np.flatnonzero(self._kept_at(b_live, live.size, kp))
        else:
            keep = np.flatnonzero(self._free_at(b_live, live.size))
            keep = keep[self.kept(live[keep], None, kp)]
        keep = _room(keep, room, rng)
        cells = live[keep]
        row, col = np.divmod(cells, self.g)
        # (col + u) c and (row + v) c as in _round and dart_place, for the kept darts only
        self.insert(cells, (col + _uniform(ku, cells)) * self.c, (row + _uniform(kv, cells)) * self.c)
        gone = np.zeros(live.size, dtype=bool)
        gone[keep] = True
        return live[~gone], keep.size

    def insert(self, cells, x, y):
        """Put points into their (empty) cells, on the host and on the device."""
        xy = np.column_stack((x, y))
        self.placed.append((cells, xy))
        if len(cells):
            self._put("put_pair", self.b_pt, self._up("placed", cells.astype(np.int32)), xy)

    def covered(self, cells):
        """Cells whose corners and centre all lie within d of a point of the 3 x 3 cells around."""
        m = np.int32(cells.size)
        return self._test("cell_covered", m, self.b_pt, cells.astype(np.int32, copy=False), m,
                          np.int32(self.g), np.float64(self.c), np.float64(self.d2))

    def points(self):
        """The points placed, in the order of their cells (as :meth:`_Grid.points`)."""
        if not self.placed:
            return np.empty((0, 2))
        cells, xy = (np.concatenate(a) for a in zip(*self.placed))
        # np.take: a row gather several times faster than xy[...] (as in cells.CellMIC.solve)
        return np.take(xy, np.argsort(cells, kind="stable"), axis=0)

    cells_of = _Grid.cells_of


def _throw_rounds(grid, n, rng, max_rounds):
    """Rounds until the grid holds `n` points (or `max_rounds`); the points."""
    pts = grid.points()
    # int32 cells: what the kernels take, and integer division at half the cost
    live, m = np.arange(grid.g * grid.g, dtype=np.int32), len(pts)
    if m:
        live = np.setdiff1d(live, grid.cells_of(pts), assume_unique=True).astype(np.int32)
    for r in range(max_rounds):
        live, placed = grid.throw(live, rng, n - m, m == 0)
        m += placed
        if m >= n or not live.size:
            break
        if r % 2 == 1:   # after the second round: most live cells are covered by then
            live = live[~grid.covered(live)]
    return grid.points()


def _grid_for(d, device):
    """The device grid where `device` (a context or name; None: the default) has float64
    and the grid is large enough to gain, else the numpy grid."""
    if device is not False and np.sqrt(2.0) / d >= 64:
        try:
            ctx = get_context(None if device is True else device)
        except NoOpenCLError:
            ctx = None
        if ctx is not None and "cl_khr_fp64" in ctx.devices[0].extensions:
            try:
                return _DeviceGrid(d, ctx)
            except UntrustedProgram as exc:
                warn_fallback(exc, "dart rounds on the host")
    return _Grid(d)


def parallel_darts(n, *, rel_radius=0.7, seed=None, max_rounds=16, device=None):
    """`n` points on the unit torus by parallel dart throwing at a relative radius.

    Rounds of parallel dart throwing at the minimum distance
    ``d = 2 rel_radius r_max(n)`` run until `n` points are placed; the
    surplus of the last round is dropped at random (which keeps every
    distance).  When `max_rounds` rounds place fewer (a radius near the
    saturation of maximal sampling, about 0.75 here), the radius shrinks by
    2 % and throwing goes on around the points placed so far.

    Parameters
    ----------
    n : int
        Number of points (at least 1).
    rel_radius : float, optional
        Requested normalized radius, in (0, 0.78).
    seed : int, numpy.random.Generator or None, optional
    max_rounds : int, optional
        Rounds at one radius before it shrinks.
    device : str, pyopencl.Context, bool or None, optional
        Where the distance tests run: an OpenCL device with float64
        (``kernels/parallel_darts.cl``; None: the default one, if any), or
        numpy (False, or without a device, or for grids under 64 x 64).
        Both give the same points for a seed.

    Returns
    -------
    points : (n, 2) float64 in [0, 1)^2
        Every periodic distance is at least ``2 rel r_max(n)`` for the
        final relative radius ``rel``.

    Examples
    --------
    >>> p = parallel_darts(1000, seed=0)
    >>> from diskpack_cl.measures import normalized_radius
    >>> p.shape, bool(normalized_radius(p) >= 0.7)
    ((1000, 2), True)
    """
    n = check_count(n)
    if not 0.0 < rel_radius < 0.78:
        raise ValueError(f"rel_radius must be in (0, 0.78), got {rel_radius}")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    rel, pts = float(rel_radius), np.empty((0, 2))
    while True:
        grid = _grid_for(2.0 * rel * hexagonal_radius(n), device)
        if len(pts):
            grid.insert(grid.cells_of(pts), pts[:, 0], pts[:, 1])
        pts = _throw_rounds(grid, n, rng, max_rounds)
        grid.hand_on()
        if len(pts) >= n:
            return pts[np.sort(rng.choice(len(pts), n, replace=False))] if len(pts) > n else pts
        rel *= 0.98
