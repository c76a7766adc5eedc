"""Local tail iterations (diskpack_cl.relax_local): the two facts they rest on, checked by
brute force; a local step against exact_mic of the whole set; relax_poisson(local=True)."""

from unittest import mock

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import reference as ref
from diskpack_cl import relax
from diskpack_cl.domain import Domain
from diskpack_cl.geometry import exact_mic
from diskpack_cl.measures import hexagonal_radius, min_distance_at_most, nearest_neighbor_distances
from diskpack_cl.relax import OVER_RELAX, _moved, relax_poisson
from diskpack_cl.relax_local import HALO, _bad_pairs, _within, bad_points, local_step, relax_local
from diskpack_cl.sampling import dart_throwing

TORUS = Domain.torus()


def _pair_distances(X):
    d = X[:, None, :] - X[None, :, :]
    d -= np.round(d)
    D = np.hypot(d[..., 0], d[..., 1])
    np.fill_diagonal(D, np.inf)
    return D


@settings(max_examples=40)
@given(n=st.integers(8, 120), seed=st.integers(0, 2**32 - 1), share=st.floats(0.05, 1.0),
       t=st.floats(0.3, 1.2))
def test_a_partial_move_keeps_the_minimum_and_new_bad_pairs_hold_an_old_bad_point(n, seed, share,
                                                                                  t):
    rng = np.random.default_rng(seed)
    X = rng.random((n, 2))
    D0 = _pair_distances(X)
    nn0 = D0.min(axis=1)
    thr = t * 2 * hexagonal_radius(n)
    moved = np.flatnonzero(rng.random(n) < share)
    mic = exact_mic(X, cells=moved)
    Y = X.copy()
    Y[moved] = mic.centers
    D1 = _pair_distances(Y)
    assert D1.min() >= D0.min() * (1 - 1e-12)
    i, j = np.nonzero(np.triu(D1 < thr))
    was_bad = nn0 < thr
    assert np.all(was_bad[i] | was_bad[j])


def _awkward(kind, n, rng):
    """Uniform points, a lattice (pairs exactly at its multiples) or coincident points."""
    if kind == "lattice":
        return rng.integers(0, 16, (n, 2)) / 16
    X = rng.random((n, 2))
    if kind == "coincident":
        X[rng.integers(0, n, n // 3)] = X[rng.integers(0, n, n // 3)]
    return X


@given(n=st.integers(2, 400), seed=st.integers(0, 2**32 - 1), share=st.floats(0.0, 1.0),
       r=st.sampled_from([0.01, 1 / 16, 0.1, 2 / 16, 0.3]),
       kind=st.sampled_from(["uniform", "lattice", "coincident"]))
def test_the_grid_finds_the_kdtrees_neighbourhoods_and_the_brute_force_bad_pairs(n, seed, share,
                                                                                  r, kind):
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    X = _awkward(kind, n, rng)
    C = np.flatnonzero(rng.random(n) < share)
    lists = cKDTree(X, boxsize=1.0).query_ball_point(X[C], r) if len(C) else []
    want = np.unique(np.concatenate([np.array(lst, dtype=np.int64) for lst in lists] or [[]]))
    np.testing.assert_array_equal(_within(X, C, r, TORUS), want.astype(np.int64))
    D = _pair_distances(X)
    i, j = np.nonzero(D[C] < r)
    got = _bad_pairs(X, C, r, TORUS)
    assert sorted(zip(got[0].tolist(), got[1].tolist(), got[2].tolist())) == \
        sorted(zip(C[i].tolist(), j.tolist(), D[C[i], j].tolist()))


@settings(max_examples=15)
@given(seed=st.integers(0, 2**32 - 1), eps=st.floats(0.6, 0.8))
def test_a_local_step_moves_its_points_to_the_mics_of_the_whole_set(seed, eps):
    n = 600
    X = dart_throwing(n, rel_radius=0.5, seed=seed)
    B = bad_points(nearest_neighbor_distances(X), eps, 1.0)
    Y = X.copy()
    B2, d_min, held = local_step(Y, B, eps, TORUS)
    moved = np.flatnonzero(np.any(Y != X, axis=1))
    assert len(moved) > held >= 0   # a held cell reached past the halo: it stays
    want = exact_mic(X, cells=moved).centers
    d = Y[moved] - want
    d -= np.round(d)
    assert np.abs(d).max() <= 1e-12
    # the bad points it reports are those of a brute-force search, with their distance
    D = _pair_distances(Y)
    thr = 2 * eps * hexagonal_radius(n)
    assert sorted(B2.tolist()) == np.flatnonzero(D.min(axis=1) < thr).tolist()
    assert d_min == (pytest.approx(D.min(), abs=1e-15) if len(B2) else np.inf)


@settings(max_examples=8)
@given(seed=st.integers(0, 2**32 - 1), eps=st.floats(0.6, 0.8))
def test_a_local_step_on_the_device_moves_as_on_the_host(ctx, seed, eps):
    """The step's cells solved by the per-cell kernel on a list (CellMIC.solve with
    cells) land where exact_mic puts them, and leave the same bad points."""
    from diskpack_cl.device.cells import CellMIC

    X = dart_throwing(600, rel_radius=0.5, seed=seed)
    B = bad_points(nearest_neighbor_distances(X), eps, 1.0)
    Y, Z = X.copy(), X.copy()
    B_host, d_host, held_host = local_step(Y, B, eps, TORUS)
    B_dev, d_dev, held_dev = local_step(Z, B, eps, TORUS, solver=CellMIC(TORUS, device=ctx))
    d = Z - Y
    d -= np.round(d)
    assert np.abs(d).max() <= 1e-12 and held_dev == held_host
    assert B_dev.tolist() == B_host.tolist() and d_dev == pytest.approx(d_host, abs=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_relax_local_reaches_eps_and_its_rho_is_the_brute_force_one(seed):
    n, eps = 400, 0.78
    X = np.random.default_rng(seed).random((n, 2))
    seen = []
    Y, rho, reason = relax_local(X, nearest_neighbor_distances(X), eps, TORUS,
                                 callback=lambda it, r: seen.append((it, r)))
    assert reason == "eps" and [it for it, _ in seen] == list(range(1, len(rho) + 1))
    assert ref.min_distance_ref(Y, TORUS) >= 2 * eps * hexagonal_radius(n)
    assert np.all(np.diff(rho) >= 0)


@settings(max_examples=60)
@given(seed=st.integers(0, 2**32 - 1), step=st.floats(0.01, 0.3))
def test_kept_cells_find_every_point_near_after_moves(seed, step):
    """After points move (across cells too) and are reported, :meth:`near` still holds
    every point within the grid's side of the chosen points."""
    from diskpack_cl.relax_local import _Neighbourhoods

    rng = np.random.default_rng(seed)
    X = rng.random((600, 2))
    cells = _Neighbourhoods(X, 0.08, TORUS)
    moved = rng.choice(600, 200, replace=False)
    X[moved] = TORUS.wrap(X[moved] + rng.normal(0, step, (200, 2)))
    cells.moved(moved, X)
    B = rng.choice(600, 5, replace=False)
    S, everything = cells.near(B)
    diff = X[B][:, None, :] - X[None, :, :]
    diff -= np.round(diff)
    within = np.flatnonzero((np.hypot(diff[..., 0], diff[..., 1]) <= 0.08).any(axis=0))
    assert not everything and set(within.tolist()) <= set(S.tolist())


@settings(max_examples=60)
@given(seed=st.integers(0, 2**32 - 1), step=st.floats(0.0, 0.05), k=st.integers(1, 40),
       radius=st.floats(0.0, 0.08), periodic=st.booleans())
def test_a_search_among_a_wider_ones_points_finds_what_a_search_of_all_finds(seed, step, k,
                                                                             radius, periodic):
    """:meth:`near` with `among` (the points a search of the grid's side found around
    B, some of the others moved since) gives what a pass over every point gives."""
    from diskpack_cl.relax_local import _Neighbourhoods

    dom = TORUS if periodic else Domain.rect(1.0, 1.0)
    rng = np.random.default_rng(seed)
    X = rng.random((800, 2))
    cells = _Neighbourhoods(X, 0.08, dom)
    B = rng.choice(800, k, replace=False)
    S, everything = cells.near(B)
    assume(not everything)
    moved = np.setdiff1d(S[rng.random(len(S)) < 0.3], B)
    X[moved] = np.clip(X[moved] + rng.normal(0, step, (len(moved), 2)), 0.0, np.nextafter(1, 0))
    cells.moved(moved, X)
    np.testing.assert_array_equal(cells.near(B, radius, among=S)[0], cells.near(B, radius)[0])


def _near_both_ways(cells, B, radius):
    """:meth:`near` of `cells` from the cells' lists, and by a pass over every point."""
    import diskpack_cl.relax_local as rl

    saved = rl.SPARSE_CELLS
    try:
        rl.SPARSE_CELLS = 1.0    # the lists for any share of the cells
        listed = cells.near(B, radius)[0]
        rl.SPARSE_CELLS = -1.0   # a pass over all points for any
        passed = cells.near(B, radius)[0]
    finally:
        rl.SPARSE_CELLS = saved
    return listed, passed


@settings(max_examples=60)
@given(seed=st.integers(0, 2**32 - 1), step=st.floats(0.0, 0.1), k=st.integers(1, 30),
       radius=st.floats(0.0, 0.08), rounds=st.integers(1, 4), periodic=st.booleans())
def test_the_cells_lists_find_what_a_pass_over_all_points_finds(seed, step, k, radius, rounds,
                                                                periodic):
    """:meth:`near` of few cells gathers their points from lists made once, the points
    moved since (some twice, some across cells) tracked: the points a pass finds."""
    from diskpack_cl.relax_local import _Neighbourhoods

    dom = TORUS if periodic else Domain.rect(1.0, 1.0)
    rng = np.random.default_rng(seed)
    X = rng.random((700, 2))
    cells = _Neighbourhoods(X, 0.08, dom)
    assume(cells.flat is not None)
    for _ in range(rounds):   # the first search makes the lists; moves follow each
        B = rng.choice(700, k, replace=False)
        listed, passed = _near_both_ways(cells, B, radius)
        np.testing.assert_array_equal(listed, passed)
        moved = np.flatnonzero(rng.random(700) < 0.2)
        X[moved] = np.clip(X[moved] + rng.normal(0, step, (len(moved), 2)), 0.0, np.nextafter(1, 0))
        cells.moved(moved, X)
    listed, passed = _near_both_ways(cells, rng.choice(700, k, replace=False), radius)
    np.testing.assert_array_equal(listed, passed)


@given(idx=st.lists(st.integers(0, 99), max_size=300), extra=st.integers(0, 5))
def test_distinct_gives_the_values_np_unique_gives(idx, extra):
    """relax_local's marks give np.unique's sorted values of indices below a size."""
    from diskpack_cl.relax_local import _distinct

    idx = np.array(idx, dtype=np.int64)
    size = int(idx.max(initial=-1)) + 1 + extra
    np.testing.assert_array_equal(_distinct(idx, size), np.unique(idx))


@pytest.mark.parametrize("seed", [3, 4])
def test_relax_local_keeps_the_cells_of_the_points_it_moves(seed):
    """The grid cells kept from step to step give the steps that cells found anew give."""
    n, eps = 20000, 0.78
    X = dart_throwing(n, rel_radius=0.6, seed=seed)
    Y, rho, reason = relax_local(X, nearest_neighbor_distances(X), eps, TORUS)
    Z = X.copy()
    B = bad_points(nearest_neighbor_distances(Z), eps, 1.0)
    halo, again = HALO, []
    while len(B):
        B, d, held = local_step(Z, B, eps, TORUS, halo)
        halo = halo * 1.5 if held else halo
        again.append(min(d / (2 * hexagonal_radius(n)), eps))
    assert reason == "eps" and len(rho) > 2
    np.testing.assert_array_equal(Y, Z)
    assert rho == again


@pytest.mark.parametrize("n", [300, 3000])
def test_relax_poisson_local_certified_monotone_and_reproducible(n):
    X = dart_throwing(n, rel_radius=0.6, seed=n)
    res = relax_poisson(X, 0.8, backend="exact", local=True)
    again = relax_poisson(X, 0.8, backend="exact", local=True)
    np.testing.assert_array_equal(res.points, again.points)
    assert res.stop_reason == "eps" and res.stats["local_iterations"] > 0
    assert np.all(np.diff(res.rho) >= -1e-12)
    exact = (ref.min_distance_ref(res.points, TORUS) if n <= 300
             else min_distance_at_most(res.points, 1.0, TORUS, grow=True))
    assert res.rho[-1] == pytest.approx(exact / 2 / hexagonal_radius(n), abs=1e-12)
    assert res.rho[-1] >= 0.8


def test_local_route_on_the_device_skips_the_host_resolve(ctx):
    """On the device, the local route's global iterates take the kernel's proven MICs
    without the host's re-solve of every cell (``refine``); the set it returns is still
    certified (rho against a KD-tree), monotone and reproducible."""
    X = dart_throwing(3000, rel_radius=0.6, seed=7)
    res = relax_poisson(X, 0.8, backend="opencl", device=ctx, local=True)
    again = relax_poisson(X, 0.8, backend="opencl", device=ctx, local=True)
    np.testing.assert_array_equal(res.points, again.points)
    assert "refine" not in res.timings and res.stats["local_iterations"] > 0
    assert "refine" in relax_poisson(X, 0.8, backend="opencl", device=ctx, max_iter=1).timings
    assert np.all(np.diff(res.rho) >= -1e-12)
    exact = min_distance_at_most(res.points, 1.0, TORUS, grow=True)
    assert res.rho[-1] == pytest.approx(exact / 2 / hexagonal_radius(3000), abs=1e-12)
    assert res.rho[-1] >= 0.8


@pytest.mark.parametrize("soon", [0.0, 1.0])
def test_nearest_alone_before_going_local_changes_no_iterate(ctx, monkeypatch, soon):
    """The iterates whose MICs the device skips (nearest neighbours alone, where the set
    will probably go local) are those of the route that solves every MIC: with the
    nearest neighbours first at every iterate (``LOCAL_SOON`` 1) or at none (0), the
    same rho after each iteration and the same points."""
    import diskpack_cl.relax_local as rl

    X = dart_throwing(3000, rel_radius=0.6, seed=8)
    want = relax_poisson(X, 0.8, backend="opencl", device=ctx, local=True)
    monkeypatch.setattr(rl, "LOCAL_SOON", soon)
    res = relax_poisson(X, 0.8, backend="opencl", device=ctx, local=True)
    np.testing.assert_array_equal(res.points, want.points)
    np.testing.assert_allclose(res.rho, want.rho, rtol=0, atol=1e-15)
    assert res.stats["local_iterations"] == want.stats["local_iterations"] > 0


def _over_relaxed_ref(X, mic, d_min, omega):
    """The over-relaxed move point by point: the image of each MIC centre nearest its
    site (of the 9), `omega` times the way there, no farther past the centre than the
    radius less half `d_min`."""
    Y = np.empty_like(X)
    for i, (x, c, R) in enumerate(zip(X, mic.centers, mic.radii)):
        c = min((c + (sx, sy) for sx in (-1, 0, 1) for sy in (-1, 0, 1)),
                key=lambda p: np.hypot(*(p - x)))
        past = (omega - 1.0) * (c - x)
        room = max(R - d_min / 2, 0.0)
        if np.hypot(*past) > room:
            past *= room / np.hypot(*past)
        Y[i] = np.mod(c + past, 1.0)
    return Y


@settings(max_examples=40)
@given(n=st.integers(3, 60), seed=st.integers(0, 2**32 - 1), omega=st.floats(1.0, 3.0))
def test_an_over_relaxed_move_keeps_the_minimum_distance(n, seed, omega):
    """The local route's over-relaxed global moves (relax._moved) against a point-by-point
    reference, and never closer than the set's minimum distance (brute force; random
    sets, whose cells are far from their MICs, need the cap); moved in slices of rows on
    the cores as in one (MOVE_PART), bit for bit."""
    X = np.random.default_rng(seed).random((n, 2))
    mic = exact_mic(X, domain=TORUS)
    d_min = ref.min_distance_ref(X, TORUS)
    Y = _moved(X, mic, d_min / 2 / hexagonal_radius(n), TORUS, omega)
    Z = _over_relaxed_ref(X, mic, d_min, omega)
    dz = Y - Z
    np.testing.assert_allclose(dz - np.round(dz), 0.0, rtol=0, atol=1e-14)
    assert ref.min_distance_ref(Y, TORUS) >= d_min * (1 - 1e-12)
    with mock.patch.object(relax, "MOVE_PART", 2):
        np.testing.assert_array_equal(_moved(X, mic, d_min / 2 / hexagonal_radius(n), TORUS, omega), Y)


def test_only_the_local_routes_first_moves_are_over_relaxed():
    """relax_poisson's first global move: over-relaxed on the local route, the MIC centres
    (Algorithm 1) otherwise."""
    X = dart_throwing(500, rel_radius=0.6, seed=3)
    mic = exact_mic(X, domain=TORUS)
    d_min = ref.min_distance_ref(X, TORUS)
    local = relax_poisson(X, 0.8, backend="exact", local=True, max_iter=1).points
    plain = relax_poisson(X, 0.8, backend="exact", max_iter=1).points
    dz = local - _over_relaxed_ref(X, mic, d_min, OVER_RELAX[0])
    np.testing.assert_allclose(dz - np.round(dz), 0.0, rtol=0, atol=1e-14)
    np.testing.assert_array_equal(plain, mic.centers)
    assert not np.array_equal(local, plain)


@pytest.mark.parametrize("size", [(2.0, 1.0), (1.0, 0.1)])
def test_local_in_a_box_reaches_eps_certified(size):
    """A box goes local too: the last rho is the brute-force one, and rho does not fall
    in the local steps (their moving points have the MIC radii the bounds use)."""
    box = Domain.rect(*size)
    X = dart_throwing(3000, rel_radius=0.6, seed=9) * size
    res = relax_poisson(X, 0.8, backend="exact", domain=box, local=True)
    assert res.stop_reason == "eps" and res.stats["local_iterations"] > 0
    k = res.stats["local_iterations"]
    assert np.all(np.diff(res.rho[-k - 1:]) >= -1e-15)
    exact = ref.min_distance_ref(res.points, box)
    assert res.rho[-1] == pytest.approx(exact / 2 / hexagonal_radius(3000, box.area), abs=1e-12)
    assert res.rho[-1] >= 0.8


@settings(max_examples=60)
@given(n=st.integers(8, 150), seed=st.integers(0, 2**32 - 1), eps=st.floats(0.6, 0.85),
       size=st.sampled_from([(1.0, 1.0), (2.0, 0.5), (1.0, 0.1)]))
def test_a_local_step_in_a_box_keeps_the_minimum_and_finds_every_bad_point(n, seed, eps, size):
    """Walls cut the disks the bounds need: only the points with wide enough MICs move,
    so the minimum distance does not fall and the bad points returned are all of them."""
    box = Domain.rect(*size)
    X = np.random.default_rng(seed).random((n, 2)) * size
    D0 = _box_distances(X)
    B = bad_points(D0.min(axis=1), eps, box.area)
    assume(len(B))
    Y = X.copy()
    B2, d, held = local_step(Y, B, eps, box, d_min=float(D0.min()))
    D1 = _box_distances(Y)
    assert D1.min() >= D0.min() * (1 - 1e-12)
    np.testing.assert_array_equal(np.sort(B2), bad_points(D1.min(axis=1), eps, box.area))
    Z = X.copy()   # the smallest distance found from the bad pairs when not given
    local_step(Z, B, eps, box)
    np.testing.assert_array_equal(Z, Y)


def _box_distances(X):
    D = np.hypot(*(X[:, None, :] - X[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(D, np.inf)
    return D


def test_local_in_a_box_on_the_device_skips_the_host_resolve(ctx):
    """A box's global iterates take the kernel's proven MICs without the host's re-solve,
    as the torus's do, and its tail goes local; rho is certified."""
    box = Domain.rect(2.0, 1.0)
    X = dart_throwing(3000, rel_radius=0.6, seed=11) * (2, 1)
    fast = relax_poisson(X, 0.8, backend="opencl", device=ctx, domain=box, local=True)
    again = relax_poisson(X, 0.8, backend="opencl", device=ctx, domain=box, local=True)
    plain = relax_poisson(X, 0.8, backend="opencl", device=ctx, domain=box)
    np.testing.assert_array_equal(fast.points, again.points)
    assert "refine" not in fast.timings and "refine" in plain.timings
    assert fast.stats["local_iterations"] > 0 and "local_iterations" not in plain.stats
    exact = min_distance_at_most(fast.points, 1.0, box, grow=True)
    assert fast.rho[-1] == pytest.approx(exact / 2 / hexagonal_radius(3000, box.area), abs=1e-12)
    assert fast.rho[-1] >= 0.8


@settings(max_examples=40)
@given(n=st.integers(2, 60), seed=st.integers(0, 2**32 - 1), periodic=st.booleans(),
       scale=st.floats(0.3, 3.0))
def test_min_distance_at_most_is_the_brute_force_minimum(n, seed, periodic, scale):
    dom = TORUS if periodic else Domain.rect(1.5, 1.0)
    X = np.random.default_rng(seed).random((n, 2)) * (dom.width, dom.height)
    best = ref.min_distance_ref(X, dom)
    got = min_distance_at_most(X, scale * best, dom)
    if scale >= 1 or scale < 1 - 1e-8:
        assert got == (pytest.approx(best, rel=1e-14) if scale >= 1 else np.inf)
    assert min_distance_at_most(X, 0.2 * best, dom, grow=True) == pytest.approx(best, rel=1e-14)


def test_poisson_disk_goes_local_on_the_torus_unless_told_not_to():
    from diskpack_cl.poisson import poisson_disk

    a = poisson_disk(3000, seed=0, backend="exact")
    b = poisson_disk(3000, seed=0, backend="exact", local=False)
    assert "local" in a.timings and "local" not in b.timings
    assert a.rho >= 0.8 and b.rho >= 0.8


@pytest.mark.parametrize("eps", [0.8, 0.84])
def test_a_failed_guess_of_going_local_is_not_repeated(ctx, monkeypatch, eps):
    """Where an iterate got its nearest neighbours alone (the set would probably go
    local) and did not go local, the next iterates solve their MICs directly: with the
    guess made at every iterate (``LOCAL_SOON`` 1), one nearest-neighbour call, not one
    every other iterate (5 and 13 of them before), and the same points."""
    import diskpack_cl.relax_local as rl
    from diskpack_cl.device.cells import CellMIC

    X = dart_throwing(3000, rel_radius=0.6, seed=8)
    want = relax_poisson(X, eps, backend="opencl", device=ctx, local=True)
    calls = []
    nearest = CellMIC.nearest
    monkeypatch.setattr(CellMIC, "nearest", lambda self, pts: calls.append(len(pts)) or nearest(self, pts))
    monkeypatch.setattr(rl, "LOCAL_SOON", 1.0)
    res = relax_poisson(X, eps, backend="opencl", device=ctx, local=True)
    np.testing.assert_array_equal(res.points, want.points)
    assert len(calls) == 1 and len(res.rho) > 6
