"""Parallel dart throwing (diskpack_cl.parallel_darts): distances by brute force, counts,
seeds, small grids, and no lattice in the spectrum."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import reference as ref
from diskpack_cl.analysis import anisotropy, periodogram, radial_power
from diskpack_cl.domain import Domain
from diskpack_cl.measures import hexagonal_radius
from diskpack_cl.parallel_darts import parallel_darts


@settings(max_examples=40)
@given(n=st.integers(1, 400), rel=st.floats(0.2, 0.7), seed=st.integers(0, 2**32 - 1))
def test_count_range_and_every_distance(n, rel, seed):
    p = parallel_darts(n, rel_radius=rel, seed=seed)
    assert p.shape == (n, 2) and p.dtype == np.float64
    assert ((p >= 0) & (p < 1)).all()
    if n > 1:   # brute force over all pairs, periodic minimum image
        assert ref.min_distance_ref(p, Domain.torus()) >= 2 * rel * hexagonal_radius(n)


@settings(max_examples=20)
@given(n=st.integers(500, 5000), rel=st.floats(0.2, 0.7), seed=st.integers(0, 2**32 - 1))
def test_the_points_cover_the_torus_evenly(n, rel, seed):
    """The last round's surplus is dropped at random: keeping the first darts in row
    order put every point of 2000 at rel 0.3 in the bottom half of the torus."""
    p = parallel_darts(n, rel_radius=rel, seed=seed)
    for axis in (0, 1):
        assert abs((p[:, axis] < 0.5).mean() - 0.5) < 5 * 0.5 / np.sqrt(n)


def test_a_radius_past_saturation_shrinks_and_keeps_the_distance_it_says():
    n = 2000
    p = parallel_darts(n, rel_radius=0.77, seed=3)
    rho = ref.min_distance_ref(p, Domain.torus()) / 2 / hexagonal_radius(n)
    # shrunk by 2 % steps from 0.77 until 2000 points fit (about 0.72 here)
    assert len(p) == n and 0.7 < rho < 0.77


def test_deterministic_for_a_seed_and_a_generator():
    a = parallel_darts(3000, seed=7)
    np.testing.assert_array_equal(a, parallel_darts(3000, seed=7))
    np.testing.assert_array_equal(a, parallel_darts(3000, seed=np.random.default_rng(7)))
    assert not np.array_equal(a, parallel_darts(3000, seed=8))


@pytest.mark.parametrize("rel", [0.0, 0.78, -1.0])
def test_radius_out_of_range_is_refused(rel):
    with pytest.raises(ValueError, match=r"rel_radius must be in \(0, 0.78\)"):
        parallel_darts(10, rel_radius=rel)


def test_no_lattice_peaks_in_the_spectrum():
    """Wei's 9 phase groups left spikes of 20-27 dB (anisotropy) at the phase lattice's
    frequencies; random priorities must leave none: every radial band stays within
    noise of isotropic (a few dB at this size)."""
    p = parallel_darts(20000, seed=1)
    freqs, P = periodogram(p)
    f, power = radial_power(P, freqs)
    _, aniso = anisotropy(P, freqs)
    assert np.max(aniso[f > 4]) < 6.0, (f[np.argmax(aniso)], np.max(aniso))
    assert power.max() < 3.0


@settings(max_examples=6)
# from 1296 points every radius here makes a grid of at least 64 cells across, the device's
@given(n=st.integers(1300, 6000), rel=st.floats(0.5, 0.74), seed=st.integers(0, 2**32 - 1))
def test_the_device_kernels_give_the_numpy_points(ctx, n, rel, seed):
    """kernels/parallel_darts.cl does the distance tests of the numpy path in the same float64
    operations, on the same hashed darts: the same points, bit for bit."""
    from diskpack_cl import parallel_darts as pd

    assert isinstance(pd._grid_for(2 * rel * hexagonal_radius(n), ctx), pd._DeviceGrid)
    a = parallel_darts(n, rel_radius=rel, seed=seed, device=ctx)
    b = parallel_darts(n, rel_radius=rel, seed=seed, device=False)
    np.testing.assert_array_equal(a, b)


def _torus_d2(a, b):
    """Squared distances between the rows of `a` and of `b` on the unit torus (all pairs)."""
    diff = a[:, None, :] - b[None, :, :]
    diff -= np.round(diff)
    return (diff ** 2).sum(axis=-1)


def _unbeaten(darts, cells, key, d2):
    """Which of the darts in `cells` no dart of higher priority (of key `key`) lies within
    sqrt(d2) of, by brute force."""
    from diskpack_cl.parallel_darts import _uniform

    prio = _uniform(key, cells)
    return ~((_torus_d2(darts, darts) < d2) & (prio[None, :] > prio[:, None])).any(axis=1)


def _grid_case(ctx, g, seed, coarse, fill):
    """A device grid of g x g cells with points in a share `fill` of them, and darts in
    a random share of the others (`coarse`: on a cell's near corner or just short of the
    others: aligned, and the only way to reach the corner cells of the 5 x 5 ring)."""
    from diskpack_cl.parallel_darts import _DeviceGrid

    rng = np.random.default_rng(seed)
    # the largest d for g cells a side: pairs two cells apart both ways can be within d
    grid = _DeviceGrid(np.sqrt(2.0) / (g - 1) * (1 - 1e-9), ctx)
    assert grid.g == g
    order = rng.permutation(g * g)
    full, rest = np.split(order, [int(fill * g * g)])
    empty = np.sort(rest[rng.random(rest.size) < rng.random()])

    def inside(cells):
        u = (rng.choice([0.0, 1 - 2.0**-20], (cells.size, 2)) if coarse
             else rng.random((cells.size, 2)))
        return (np.column_stack((cells % g, cells // g)) + u) / g

    pts = inside(full)
    grid.insert(full, pts[:, 0], pts[:, 1])
    return grid, pts, full, empty.astype(np.int32), inside(empty)


@settings(max_examples=20)
@given(g=st.integers(5, 14), seed=st.integers(0, 2**32 - 1), coarse=st.booleans(),
       fill=st.floats(0.0, 0.6))
def test_the_list_kernels_answer_as_every_pair_does(ctx, g, seed, coarse, fill):
    """dart_free, dart_keep and cell_covered on lists of cells (edge cells wrap, empty
    lists, no points, darts on cell corners) against all pairs on the torus, by brute force:
    sparse points, so that the far cells of the 5 x 5 ring decide too."""
    grid, pts, full, cells, darts = _grid_case(ctx, g, seed, coarse, fill)
    d2 = grid.d2
    free = grid.free(cells, darts)
    np.testing.assert_array_equal(free, (_torus_d2(darts, pts) >= d2).all(axis=1))

    key = np.uint64(seed)
    np.testing.assert_array_equal(grid.kept(cells, darts, key), _unbeaten(darts, cells, key, d2))
    # again: the first call's priorities were cleared
    np.testing.assert_array_equal(grid.kept(cells, darts, key), _unbeaten(darts, cells, key, d2))

    # covered: the 4 corners and the centre each within d of a point of the 8 cells around
    row, col = np.divmod(cells, g)
    prow, pcol = np.divmod(full, g)
    ring = (np.isin((row[:, None] - prow[None, :]) % g, (0, 1, g - 1))
            & np.isin((col[:, None] - pcol[None, :]) % g, (0, 1, g - 1))
            & ~((row[:, None] == prow[None, :]) & (col[:, None] == pcol[None, :])))
    want = np.ones(cells.size, dtype=bool)
    for sx, sy in ((0, 0), (1, 0), (0, 1), (1, 1), (0.5, 0.5)):
        sample = np.column_stack((col + sx, row + sy)) * grid.c
        want &= ((_torus_d2(sample, pts) < d2) & ring).any(axis=1)
    np.testing.assert_array_equal(grid.covered(cells), want)


@settings(max_examples=20)
@given(g=st.integers(5, 8), cell=st.integers(0, 63), u=st.tuples(*[st.floats(0, 0.999)] * 2))
@example(g=9, cell=40, u=(0.0, 0.0))   # the point in the middle cell at each corner:
@example(g=9, cell=40, u=(0.999, 0.0))  # every dart's cell is an inner one (no wrap), and
@example(g=9, cell=40, u=(0.0, 0.999))  # each corner cell of the ring decides for one
@example(g=9, cell=40, u=(0.999, 0.999))
def test_every_cell_of_the_ring_is_looked_at(ctx, g, cell, u):
    """One point, and a dart in each of the 24 cells around its own (wrapping at the edges)
    at the spot of that cell nearest the point: the corner cells of the ring decide only
    here.  Free darts, and darts beaten by a top-priority dart in the point's place (or by
    one another), against brute force."""
    from diskpack_cl.parallel_darts import _DeviceGrid, _uniform

    grid = _DeviceGrid(np.sqrt(2.0) / (g - 1) * (1 - 1e-9), ctx)
    r, c = divmod(cell % (g * g), g)
    p = (np.array([c, r]) + u) * grid.c
    off = np.array([(oy, ox) for oy in range(-2, 3) for ox in range(-2, 3) if oy or ox])
    lo = np.column_stack((c + off[:, 1], r + off[:, 0])) * grid.c   # unwrapped cells' corners
    darts = np.mod(np.clip(p, lo, lo + (1 - 2.0**-20) * grid.c), 1.0)
    cells = (((r + off[:, 0]) % g) * g + (c + off[:, 1]) % g).astype(np.int32)
    near = _torus_d2(darts, p[None, :])[:, 0] < grid.d2
    assert near.any()
    grid.insert(np.array([r * g + c]), p[:1], p[1:])
    np.testing.assert_array_equal(grid.free(cells, darts), ~near)
    # the point as a dart too, of the highest priority (the first key that gives it that)
    every = np.append(cells, r * g + c).astype(np.int32)
    key = next(np.uint64(k) for k in range(1000) if np.argmax(_uniform(np.uint64(k), every)) == 24)
    kept = _DeviceGrid(grid.d, ctx).kept(every, np.vstack((darts, p)), key)
    want = _unbeaten(np.vstack((darts, p)), every, key, grid.d2)
    np.testing.assert_array_equal(kept, want)
    assert kept[-1] and not kept[:-1][near].any()


@settings(max_examples=20)
@given(g=st.integers(5, 300), seed=st.integers(0, 2**32 - 1), key=st.integers(0, 2**64 - 1))
def test_dart_place_computes_the_hosts_coordinates_bit_for_bit(ctx, g, seed, key):
    """dart_place puts ``((col + u) c, (row + v) c)`` into the dart grid as numpy rounds
    it, u and v the hashed uniforms of numpy's _uniform (keys up to 2**64 - 1), set_prio
    writes that hash's priorities bit for bit, and dart_free reads the darts placed."""
    import pyopencl as cl

    from diskpack_cl.parallel_darts import _DeviceGrid, _uniform

    rng = np.random.default_rng(seed)
    grid = _DeviceGrid(np.sqrt(2.0) / g * (1 + 1e-12), ctx)
    cells = np.sort(rng.choice(grid.g * grid.g, rng.integers(1, 2 * grid.g), replace=False)).astype(np.int32)
    ku, kv = np.uint64(key), np.uint64(key ^ 0x5555)
    grid.place(cells, ku, kv)
    got = np.empty((grid.g * grid.g, 2))
    cl.enqueue_copy(grid.queue, got, grid.b_dart)
    row, col = np.divmod(cells, grid.g)
    want = np.column_stack(((col + _uniform(ku, cells)) * grid.c, (row + _uniform(kv, cells)) * grid.c))
    np.testing.assert_array_equal(got[cells], want)
    grid._launch("set_prio", len(cells), grid.b_prio, grid._up("cells", cells), np.int32(len(cells)), ku, np.int32(0))
    prio = np.empty(grid.g * grid.g)
    cl.enqueue_copy(grid.queue, prio, grid.b_prio)
    np.testing.assert_array_equal(prio[cells], _uniform(ku, cells))
    np.testing.assert_array_equal(grid.free(cells), np.ones(cells.size, bool))


def test_the_hashed_uniforms_are_uniform():
    """_uniform over a million counters of one key: mean, variance and a 64-bin histogram
    within a few standard errors of U(0, 1), and a different key gives other numbers."""
    from diskpack_cl.parallel_darts import _uniform

    u = _uniform(np.uint64(12345), np.arange(1_000_000))
    assert abs(u.mean() - 0.5) < 5 * np.sqrt(1 / 12 / u.size)
    assert abs(u.var() - 1 / 12) < 0.002
    counts = np.bincount((u * 64).astype(int), minlength=64)
    chi2 = ((counts - u.size / 64) ** 2 / (u.size / 64)).sum()
    assert chi2 < 120   # 63 degrees of freedom: p < 1e-5 above
    assert not np.array_equal(u[:100], _uniform(np.uint64(12346), np.arange(100)))
