"""The float64 per-cell MIC kernel against linprog, exact_mic and brute force."""

import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import reference as ref
from diskpack_cl.device.cells import FLAGS, NO_CODE, CellMIC, _bucket_maxima, _scatter, refine_active
from diskpack_cl.domain import Domain
from diskpack_cl.geometry import exact_mic
from diskpack_cl.sampling import dart_throwing

SETTINGS = settings(max_examples=25)


@pytest.fixture(scope="module")
def solvers(ctx):
    """One CellMIC per domain kind, built once (programs compile once)."""
    cache = {}

    def get(domain):
        if domain not in cache:
            cache[domain] = CellMIC(domain, device=ctx)
        return cache[domain]
    return get


def _wrapped_diff(a, b, dom):
    d = a - b
    if dom.periodic:
        d -= np.round(d)
    return np.abs(d).max(initial=0.0)


def _same_as_exact(dom, pts, w, res, atol=1e-12):
    m = exact_mic(pts, w, dom)
    scale = max(dom.width, dom.height)
    assert np.array_equal(res.empty, m.empty)
    live = ~m.empty if dom.periodic else np.ones(len(pts), bool)   # see test_mic_matches_linprog
    assert np.abs(res.radii[live] - m.radii[live]).max(initial=0.0) <= atol * scale
    live = ~m.empty
    assert _wrapped_diff(res.centers[live], m.centers[live], dom) <= 1e-9 * scale


@st.composite
def cell_sets(draw):
    periodic = draw(st.booleans())
    dom = Domain.torus() if periodic else Domain.rect(draw(st.sampled_from([1.0, 7.0, 300.0])),
                                                      draw(st.sampled_from([1.0, 3.0, 40.0])))
    n = draw(st.integers(2, 40))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    kind = draw(st.sampled_from(["uniform", "cluster", "border", "power", "power-1000"]))
    pts = rng.random((n, 2))
    if kind == "cluster":      # most sites in a tiny patch
        pts[: n // 2 + 1] = 0.3 + 1e-3 * rng.random((n // 2 + 1, 2))
    if kind == "border" and not periodic:   # sites exactly on the rectangle's edges
        pts[::2, 0] = rng.choice([0.0, 1.0], size=len(pts[::2]))
    pts = pts * (dom.width, dom.height)
    pts = np.unique(pts, axis=0)
    spacing = np.sqrt(dom.area / len(pts))
    w = None
    if kind == "power":
        w = (0.5 * spacing * rng.random(len(pts))) ** 2
    elif kind == "power-1000":   # weights spanning a factor 1000: empty cells
        w = (spacing * rng.random(len(pts))) ** 2 * 10.0 ** rng.uniform(-3, 0, len(pts))
    return dom, pts, w


@SETTINGS
@given(cell_sets(), st.booleans())
def test_mic_matches_linprog_on_every_cell(solvers, case, certify):
    """With and without the host's re-solve (``certify=False``: the device's proven
    answers, which must be the same MICs)."""
    dom, pts, w = case
    assume(len(pts) >= 2)
    res = solvers(dom).solve(pts, w, certify=certify)
    scale = max(dom.width, dom.height)
    # the host's re-solve is exact to rounding; the device's own float64 vertex
    # solve loses digits where sites nearly coincide (2e-9 for two sites 4.5e-4 apart)
    tol = (1e-9 if certify else 1e-8) * scale
    for i in range(len(pts)):
        r = ref.chebyshev_ref(pts, w, dom, i)
        assert res.empty[i] == (r.radius < 0)
        # (an empty cell's negative LP value on a torus depends on how many
        # periodic images enter: only its sign means anything there)
        if r.radius >= 0 or not dom.periodic:
            assert abs(res.radii[i] - r.radius) <= tol, (i, res.radii[i], r.radius)
        if r.unique and r.radius > 0:
            assert _wrapped_diff(res.centers[i], r.center, dom) <= 1e-6 * scale


@SETTINGS
@given(cell_sets(), st.booleans(), st.integers(0, 2**32 - 1))
def test_a_list_of_cells_is_solved_as_exact_mic_solves_it(solvers, case, certify, seed):
    """``solve(cells=...)`` runs the kernel on those cells only: any order, repeats, none
    at all; each row the MIC of its cell in the whole set (exact_mic's radius, the
    centre where it is unique, and the full solve's nearest-neighbour distance)."""
    dom, pts, w = case
    assume(len(pts) >= 2)
    rng = np.random.default_rng(seed)
    cells = rng.integers(0, len(pts), rng.integers(0, 2 * len(pts)))
    res = solvers(dom).solve(pts, w, certify=certify, cells=cells)
    full = solvers(dom).solve(pts, w)
    m = exact_mic(pts, w, dom, cells=cells)
    scale = max(dom.width, dom.height)
    assert res.radii.shape == (len(cells),) and res.centers.shape == (len(cells), 2)
    assert np.array_equal(res.empty, m.empty)
    live = ~m.empty
    assert np.abs(res.radii[live] - m.radii[live]).max(initial=0.0) <= 1e-8 * scale
    for k, i in enumerate(cells):
        r = ref.chebyshev_ref(pts, w, dom, i)
        if r.unique and r.radius > 0:
            assert _wrapped_diff(res.centers[k], r.center, dom) <= 1e-6 * scale
    assert np.array_equal(res.nn, full.nn[cells])


@SETTINGS
@given(cell_sets(), st.integers(0, 2**32 - 1))
def test_the_host_puts_cell_mics_answers_by_row_as_mic_rows_does(solvers, case, seed):
    """With the host's re-solve only cell_mic's own arrays come back, and the host puts
    each cell's nearest-neighbour distance in its row and reads its flag word; without
    it, mic_rows does both on the device: the same distances bit for bit and the same
    flag counts, for all cells and for a list of cells (any order, repeats)."""
    dom, pts, w = case
    assume(len(pts) >= 2)
    rng = np.random.default_rng(seed)
    solver = solvers(dom)
    for cells in (None, rng.integers(0, len(pts), rng.integers(1, 2 * len(pts)))):
        host = solver.solve(pts, w, cells=cells)
        device = solver.solve(pts, w, certify=False, cells=cells)
        assert host.nn.tobytes() == device.nn.tobytes()
        assert {k: host.stats[k] for k in FLAGS} == {k: device.stats[k] for k in FLAGS}
        assert np.array_equal(host.empty, device.empty)


@settings(max_examples=15)
@given(st.lists(st.tuples(st.sampled_from([3, 40, 300]), st.sampled_from(["all", "some", "nearest"]),
                          st.booleans()), min_size=3, max_size=6), st.integers(0, 2**32 - 1))
def test_one_solver_for_sets_of_every_size_answers_as_a_fresh_one(ctx, calls, seed):
    """The packed transfers are laid out anew when a call's sizes differ from the last
    one's, in the host memory of the last where it is large enough (a relaxation's
    local steps): a solver called with sets of varied sizes, lists of cells and
    nearest-neighbour queries in between gives bit for bit what a fresh solver gives."""
    dom = Domain.torus()
    rng = np.random.default_rng(seed)
    solver = CellMIC(dom, device=ctx)
    for n, kind, certify in calls:
        pts = rng.random((n, 2))
        fresh = CellMIC(dom, device=ctx)
        if kind == "nearest":
            assert solver.nearest(pts).tobytes() == fresh.nearest(pts).tobytes()
            continue
        cells = rng.integers(0, n, rng.integers(1, n + 1)) if kind == "some" else None
        got, want = (s.solve(pts, certify=certify, cells=cells) for s in (solver, fresh))
        for a, b in zip((got.centers, got.radii, got.nn), (want.centers, want.radii, want.nn)):
            assert a.tobytes() == b.tobytes()


def test_a_solver_takes_the_kernels_of_one_no_longer_alive_and_never_a_live_ones(ctx):
    """A solver's kernel objects go back to the pool when it is collected, and the next
    solver takes them (no new kernel objects, no second warm call); two live solvers never
    share one: each sets a kernel's arguments only where they differ from its own last
    call's, so a kernel shared by two solvers called in turn would run on the other's
    sites (planted: a kernel handed to the pool while its solver lives fails)."""
    import gc
    from unittest import mock

    from diskpack_cl.device import cells as cells_mod

    dom = Domain.torus()
    rng = np.random.default_rng(5)
    first = CellMIC(dom, device=ctx)
    kernel = first._kernel.kernel
    first.solve(rng.random((300, 2)))
    del first
    gc.collect()   # (other tests' dead solvers may go to the pool too)
    spare = cells_mod._SPARE_KERNELS[(kernel.program.int_ptr, "cell_mic")]
    assert any(k is kernel for k in spare)
    pooled = list(spare)
    with mock.patch.object(CellMIC, "_warm", side_effect=AssertionError("warmed twice")):
        taker = CellMIC(dom, device=ctx)
    assert any(k is taker._kernel.kernel for k in pooled)
    assert not any(k is taker._kernel.kernel for k in spare)
    other = CellMIC(dom, device=ctx)
    assert other._kernel.kernel is not taker._kernel.kernel
    for certify in (True, True, False, False):   # each solver's arguments the same as its last
        for solver in (taker, other):
            pts = rng.random((200, 2))
            _same_as_exact(dom, pts, None, solver.solve(pts, certify=certify))


@settings(max_examples=15)
@given(st.sampled_from([Domain.torus(), Domain.rect(30.0, 20.0)]),
       st.lists(st.tuples(st.sampled_from([3, 40, 300, 3000]),
                          st.sampled_from(["all", "some", "nearest"]), st.booleans(), st.booleans()),
                min_size=2, max_size=5), st.integers(0, 2**32 - 1))
def test_lent_inputs_answer_as_copied_ones(ctx, dom, calls, seed):
    """On a CPU device the kernels read the packed inputs where the host wrote them
    (``LEND_BYTES`` 0 here: every pack lent) instead of a device copy (no pack lent):
    a solver called with sets of varied sizes and weights, lists of cells and
    nearest-neighbour queries in between answers bit for bit as the copying one."""
    from unittest import mock
    from diskpack_cl.device import cells as cells_mod

    lent, copied = CellMIC(dom, device=ctx), CellMIC(dom, device=ctx)
    if not lent.is_cpu:
        pytest.skip("inputs are lent to CPU devices only")
    rng = np.random.default_rng(seed)
    for n, kind, weighted, certify in calls:
        pts = np.unique(rng.random((n, 2)) * (dom.width, dom.height), axis=0)
        w = (0.3 * rng.random(len(pts)) * np.sqrt(dom.area / n)) ** 2 if weighted else None
        cells = rng.integers(0, len(pts), rng.integers(1, len(pts) + 1)) if kind == "some" else None
        answers = []
        for solver, bytes_lent in ((lent, 0), (copied, 1 << 62)):
            with mock.patch.object(cells_mod, "LEND_BYTES", bytes_lent):
                answers.append(solver.nearest(pts) if kind == "nearest" else
                               solver.solve(pts, w, certify=certify, cells=cells))
            assert solver._packs["inputs"].lent == (bytes_lent == 0)
        got, want = answers
        if kind == "nearest":
            assert got.tobytes() == want.tobytes()
            continue
        for name in ("centers", "radii", "nn", "empty"):
            assert getattr(got, name).tobytes() == getattr(want, name).tobytes()


@pytest.mark.parametrize("certify", [True, False])
@pytest.mark.parametrize("start", ["dart", "random", "relaxed"])
def test_large_sets_match_exact_mic_bit_for_bit_radii(solvers, start, certify):
    dom = Domain.torus()
    n = 5000
    if start == "dart":
        pts = dart_throwing(n, seed=3)
    else:
        pts = np.random.default_rng(4).random((n, 2))
    if start == "relaxed":
        for _ in range(5):
            pts = exact_mic(pts).centers
    res = solvers(dom).solve(pts, certify=certify)
    _same_as_exact(dom, pts, None, res)
    from scipy.spatial import cKDTree

    d, _ = cKDTree(pts, boxsize=1.0).query(pts, k=2)
    assert np.abs(res.nn - d[:, 1]).max() <= 1e-15


def _brute_nearest(pts, dom):
    """Distance from each site to its nearest other one, over all periodic images."""
    P, gid = ref.images(pts, dom)
    d = np.hypot(*(pts[:, None, :] - P[None, :, :]).transpose(2, 0, 1))
    d[(np.arange(len(pts))[:, None] == gid[None, :]) & (d == 0)] = np.inf   # the site itself
    return d.min(axis=1)


@pytest.mark.parametrize("periodic", [True, False])
def test_nearest_neighbour_distance_by_brute_force(solvers, periodic):
    dom = Domain.torus() if periodic else Domain.rect(3.0, 2.0)
    pts = np.random.default_rng(10).random((300, 2)) * (dom.width, dom.height)
    res = solvers(dom).solve(pts)
    assert np.abs(res.nn - _brute_nearest(pts, dom)).max() <= 1e-15
    assert float(res.nn.min()) == pytest.approx(ref.min_distance_ref(pts, dom), abs=1e-15)


@pytest.mark.parametrize("periodic", [True, False])
@pytest.mark.parametrize("kind", ["uniform", "cluster"])
def test_nearest_alone_by_brute_force(solvers, periodic, kind):
    """CellMIC.nearest: the kernel's distances, and the KD-tree's for the sites with no
    other within a bucket side (a tight cluster leaves the sites outside it alone)."""
    dom = Domain.torus() if periodic else Domain.rect(3.0, 2.0)
    rng = np.random.default_rng(11)
    pts = rng.random((300, 2))
    if kind == "cluster":
        pts[:270] = 0.4 + 0.01 * pts[:270]
    pts *= (dom.width, dom.height)
    solver = solvers(dom)
    want = _brute_nearest(pts, dom)
    _, _, bw, bh = solver._grid(len(pts))
    assert kind == "uniform" or np.any(want > min(bw, bh))   # the KD-tree's route is taken
    assert np.abs(solver.nearest(pts) - want).max() <= 1e-15


def test_power_cells_of_a_stippling_like_set(solvers):
    """Dense dark parts, sparse light parts, weights from the local spacing."""
    rng = np.random.default_rng(5)
    W, H = 300.0, 200.0
    dom = Domain.rect(W, H)
    x = rng.random(20000) * W
    keep = rng.random(20000) < (0.05 + x / W) ** 2      # density grows to the right
    pts = np.column_stack([x[keep], rng.random(keep.sum()) * H])
    spacing = 1.0 / np.sqrt((0.05 + pts[:, 0] / W) ** 2)
    w = (0.3 * spacing) ** 2
    res = solvers(dom).solve(pts, w)
    _same_as_exact(dom, pts, w, res)
    assert res.stats["fallback"] <= 0.01 * len(pts)


def test_power_cells_across_a_sharp_density_step(solvers):
    """A dense half beside a sparse half of heavy sites (100x the weight): the
    cells on the step gather only dense-side sites at first, so their first
    cutter radius spans much of the image and the proof scan must grow its
    box round by round."""
    rng = np.random.default_rng(11)
    W, H = 200.0, 100.0
    dense = rng.random((12000, 2)) * (100.0, H)
    sparse = rng.random((60, 2)) * (100.0, H) + (100.0, 0.0)
    pts = np.vstack([dense, sparse])
    w = np.r_[np.full(len(dense), 0.1), np.full(len(sparse), 10.0)] + 0.01 * rng.random(len(pts))
    dom = Domain.rect(W, H)
    res = solvers(dom).solve(pts, w)
    _same_as_exact(dom, pts, w, res)
    assert res.stats["fallback"] <= 0.01 * len(pts)


def test_square_lattice_non_unique_mics(solvers):
    """Every cell of a square lattice is a square: unique radius, unique centre
    (the site); a rectangular lattice has a segment of centres: radius only."""
    dom = Domain.torus()
    g = (np.arange(16) + 0.5) / 16
    pts = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    res = solvers(dom).solve(pts)
    assert np.allclose(res.radii, 0.5 / 16, rtol=0, atol=1e-15)
    assert _wrapped_diff(res.centers, pts, dom) <= 1e-12
    gy = (np.arange(8) + 0.5) / 8
    rect = np.stack(np.meshgrid(g, gy), -1).reshape(-1, 2)
    r2 = solvers(dom).solve(rect)
    assert np.allclose(r2.radii, 0.5 / 16, rtol=0, atol=1e-15)


def test_near_coincident_sites(solvers):
    dom = Domain.torus()
    pts = np.random.default_rng(6).random((400, 2))
    pts[1] = pts[0] + 1e-9
    res = solvers(dom).solve(pts)
    _same_as_exact(dom, pts, None, res)
    assert res.nn[0] == pytest.approx(np.sqrt(2) * 1e-9, rel=1e-6)


def test_flags_fire_when_the_gather_is_too_small(solvers):
    """A site alone in a huge empty region: the rings never reach its nearest
    neighbour, and the cells at the cluster's rim reach past one period of
    the torus. The kernel must say so, and the answer (from the host
    fallback) is still exact."""
    dom = Domain.torus()
    rng = np.random.default_rng(7)
    pts = np.vstack([0.05 * rng.random((4000, 2)), [[0.55, 0.55]]])
    res = solvers(dom).solve(pts)
    assert res.stats["flagged"] >= 1
    assert res.stats["nn"] >= 1 and res.stats["shift"] >= 1
    _same_as_exact(dom, pts, None, res)


def test_flags_fire_when_a_cell_has_too_many_tight_constraints(solvers):
    """80 sites on a circle around one: the centre's cell has 80 sides, all
    tight at its MIC; more than the list or the near-tight slots hold."""
    dom = Domain.rect(10.0, 10.0)
    t = np.arange(80) * 2 * np.pi / 80
    ring = np.column_stack([5 + np.cos(t), 5 + np.sin(t)])
    other = np.random.default_rng(8).random((300, 2)) * 10
    other = other[np.hypot(*(other - 5).T) > 1.5]
    pts = np.vstack([[5.0, 5.0], ring, other])
    res = solvers(dom).solve(pts)
    assert res.stats["list_full"] + res.stats["near_full"] >= 1
    _same_as_exact(dom, pts, None, res)
    assert res.radii[0] == pytest.approx(0.5, abs=1e-12)


def test_host_refinement_rejects_what_it_can_check():
    """refine_active re-solves the device's basis and rejects it when it is not
    dual feasible, or when the vertex violates a reported near-tight constraint.
    (That no other site cuts the disk is the kernel's proof; the outputs keep
    their independent certificates.)"""
    from scipy.spatial import cKDTree

    dom = Domain.torus()
    pts = dart_throwing(300, seed=9)
    w = np.zeros(len(pts))
    m = exact_mic(pts)
    _, nb = cKDTree(pts, boxsize=1.0).query(pts, k=13)
    # three sites on one side of the site: no multipliers l >= 0 exist
    right = pts[None, :, 0] > pts[:, None, 0] + 0.01
    dist = np.where(right, np.hypot(*(pts[None] - pts[:, None]).transpose(2, 0, 1)), 9.0)
    side = np.argsort(dist, axis=1)[:, :3]
    inner = pts[:, 0] < 0.8        # these have three sites to their right
    q, R, ok = refine_active(pts, w, dom, 9 * side + 4, np.full((len(pts), 1), NO_CODE))
    assert not np.any(ok[inner])
    # the three nearest sites (dual feasible where they surround the site),
    # with the twelve nearest reported as near-tight: a too-large vertex fails
    q, R, ok = refine_active(pts, w, dom, 9 * nb[:, 1:4] + 4, 9 * nb[:, 4:] + 4)
    wrong = np.abs(R - m.radii) > 1e-12
    assert wrong.any() and not np.any(ok & wrong)
    # a basis holding a code that names neither a site nor an edge (the kernel's
    # artificial half-planes, -5 and below) is refused, whatever its vertex
    active = 9 * nb[:, 1:4] + 4
    odd = np.arange(0, len(pts), 7)
    active[odd, odd % 3] = -5 - odd % 5
    _, _, ok_odd = refine_active(pts, w, dom, active, np.full((len(pts), 1), NO_CODE))
    _, _, ok_all = refine_active(pts, w, dom, 9 * nb[:, 1:4] + 4, np.full((len(pts), 1), NO_CODE))
    assert ok_all[odd].any() and not ok_odd[odd].any()


def test_flag_bits_match_the_kernel():
    import re

    from diskpack_cl.device.programs import kernel_dir

    src = (kernel_dir() / "cells.cl").read_text()
    defined = {m[1].lower(): int(m[2]) for m in re.finditer(r"#define F_(\w+)\s+(\d+)", src)}
    assert defined == FLAGS


def test_dense_cluster_beside_sparse_sites_keeps_the_basis(solvers):
    """Rings grown after the first solve reach a dense cluster and fill the
    list: the kernel must drop the far sites, not overwrite a basic
    constraint (which once gave a dual-infeasible answer the host rejected)."""
    dom = Domain.rect(200.0, 200.0)
    for seed in (0, 1, 4):    # each gave one rejected cell before the fix
        rng = np.random.default_rng(seed)
        ns, nc, sig = int(rng.integers(50, 400)), int(rng.integers(500, 4000)), rng.uniform(0.5, 5)
        sparse = rng.random((ns, 2)) * 200
        cluster = np.clip(100 + sig * rng.standard_normal((nc, 2)), 0, 200)
        pts = np.vstack([sparse, cluster])
        w = np.where(np.arange(len(pts)) < ns, 4.0, 1e-4) * rng.random(len(pts))
        res = solvers(dom).solve(pts, w)
        assert res.stats["rejected"] == 0
        _same_as_exact(dom, pts, w, res)


@pytest.mark.parametrize("limit", [12, 5, 1])
def test_small_work_group_limits_give_identical_results(ctx, monkeypatch, limit):
    """A kernel that may run only `limit` work items per group: the group
    follows the limit, every enqueue holds whole groups (a group reaching
    into the next enqueue would solve its cells twice), and the MICs are the
    same, bit for bit."""
    from diskpack_cl.device import context as _device
    from diskpack_cl.device import cells as cells_mod
    dom = Domain.rect(30.0, 20.0)
    rng = np.random.default_rng(5)
    pts = rng.random((700, 2)) * (30.0, 20.0)
    w = (rng.random(700) * 0.4) ** 2
    want = CellMIC(dom, device=ctx).solve(pts, w)
    monkeypatch.setattr(_device, "kernel_group_limit", lambda kernel, device: limit)
    monkeypatch.setattr(cells_mod, "CHUNK", 100)
    small = CellMIC(dom, device=ctx)
    assert small.group <= limit and small.chunk % small.group == 0 and small.chunk <= 100
    got = small.solve(pts, w)
    for name in ("centers", "radii", "empty", "nn"):
        np.testing.assert_array_equal(getattr(want, name), getattr(got, name))


@pytest.mark.parametrize("pts, w, match", [
    (np.zeros((1, 2)), None, r"need at least 2 point\(s\), got 1"),
    ([[0.1, 0.2], [0.5, np.nan]], None, "points contain NaN or infinite coordinates"),
    ([[0.1, 0.2], [0.5, 0.5]], [0.0, np.nan], "weights must be n finite numbers"),
])
def test_solve_refuses_sites_it_cannot_bound(solvers, pts, w, match):
    with pytest.raises(ValueError, match=match):
        solvers(Domain.torus()).solve(pts, w)


def _power_cell_slack(pts, w, centers, radii, dom):
    """Smallest distance, over every other site and periodic image, from each disk to the
    bisector of its power cell (>= 0: the disk lies in its cell)."""
    shifts = [(sx, sy) for sx in (-1, 0, 1) for sy in (-1, 0, 1)] if dom.periodic else [(0, 0)]
    slack = np.full(len(pts), np.inf)
    rel = centers - pts
    if dom.periodic:
        rel -= np.round(rel / (dom.width, dom.height)) * (dom.width, dom.height)
    for sx, sy in shifts:
        other = pts + (sx * dom.width, sy * dom.height)
        d = other[None, :, :] - pts[:, None, :]                     # x_j - x_i
        L = np.hypot(d[..., 0], d[..., 1])
        c = rel[:, None, :]
        beta = (L * L - w[None, :] + w[:, None]) / (2 * np.where(L > 0, L, 1))
        s = beta - np.einsum("ijk,ijk->ij", d, c) / np.where(L > 0, L, 1) - radii[:, None]
        s[L == 0] = np.inf
        slack = np.minimum(slack, s.min(axis=1))
    return slack


@pytest.mark.parametrize("kind", ["lattice", "dart"])
def test_host_check_certifies_centres_not_only_radii(solvers, kind):
    """Every returned disk lies in its cell (a wrong centre with the right radius does not),
    and on these sets the host re-solve agrees with the device on every cell."""
    dom = Domain.torus()
    if kind == "lattice":   # a sheared lattice: cells are all alike, x and y differ
        g = np.arange(12) / 12
        pts = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
        pts = np.mod(pts + [0.3 / 12, 0.0] * (np.arange(len(pts)) // 12 % 2)[:, None]
                     + [0.01, 0.02], 1.0)
    else:
        pts = dart_throwing(600, seed=3)
    w = np.zeros(len(pts))
    res = solvers(dom).solve(pts)
    scale = max(dom.width, dom.height)
    assert _power_cell_slack(pts, w, res.centers, res.radii, dom).min() >= -1e-9 * scale
    assert res.stats["rejected"] == 0 and res.stats["fallback"] == 0


@pytest.mark.parametrize("kind", ["rows", "fortran rows", "negative zeros", "radii", "flags"])
def test_scatter_puts_every_row_where_numpys_row_scatter_does(kind):
    rng = np.random.default_rng(3)
    a = {"rows": rng.random((257, 2)), "fortran rows": np.asfortranarray(rng.normal(size=(257, 2))),
         "negative zeros": np.where(rng.random((257, 2)) < 0.5, -0.0, np.nan),
         "radii": rng.random(257), "flags": rng.random(257) < 0.5}[kind]
    rows = rng.permutation(len(a))
    want = np.empty_like(a)
    want[rows] = a
    got = _scatter(a, rows)
    assert got.dtype == a.dtype and got.shape == a.shape
    assert np.ascontiguousarray(got).tobytes() == np.ascontiguousarray(want).tobytes()


@pytest.mark.parametrize("dom", [Domain.torus(), Domain.rect(3.0, 2.0)])
def test_the_call_free_math_gives_the_builtins_answers(ctx, dom, monkeypatch):
    """kernels/common.h's INLINE_MATH (clang's builtins on PoCL's CPU device) and the
    OpenCL builtins give the same MICs and nearest neighbours, bit for bit: both are the
    IEEE operations.  Weighted sites too, so that the proof scan runs."""
    from diskpack_cl.device import programs as _kernels
    from diskpack_cl.device import stage as device_stage

    rng = np.random.default_rng(5)
    pts = rng.random((3000, 2)) * (dom.width, dom.height)
    w = rng.random(3000) * 1e-4 * dom.area

    def answers():
        solver = CellMIC(dom, device=ctx)
        res = solver.solve(pts, w, certify=False)
        return res.centers, res.radii, res.nn, solver.nearest(pts)

    if not _kernels.inline_math(ctx):
        pytest.skip("INLINE_MATH is for PoCL's CPU device only")
    first = answers()
    build = _kernels.build_program
    monkeypatch.setattr(device_stage, "build_program",
                        lambda c, stem, defines=None: build(c, stem, {**(defines or {}), "INLINE_MATH": 0}))
    for a, b in zip(first, answers()):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("dom", [Domain.torus(), Domain(3.0, 2.0, True), Domain.rect(3.0, 2.0)])
def test_the_rows_kernel_wraps_and_places_as_the_host_does(ctx, dom):
    """``mic_rows`` (cells.cl) puts each cell's answer in its result row, the site
    itself for an empty cell, and on a torus wraps the centre as ``Domain.wrap`` (numpy's
    mod) does, bit for bit: -0.0, a sum that rounds up to the period, a period or more
    out.  Its flag words stay in list order."""
    import pyopencl as cl
    import pyopencl.array as cla

    from diskpack_cl.device.context import padded
    from diskpack_cl.device.programs import build_program
    from diskpack_cl.device.cells import MAXC, MAXNEAR

    W, H = dom.width, dom.height
    edge = [-1e-17, -0.0, 0.0, W, np.nextafter(W, 0), -0.25 * W, 1.25 * W, 2.5 * W, -3.75 * W, 0.5 * W]
    rng = np.random.default_rng(2)
    m = 64
    cx = np.concatenate([edge, rng.uniform(-W, 2 * W, m - len(edge))])
    cy = np.concatenate([rng.uniform(-H, 2 * H, m - len(edge)), np.array(edge) * H / W])
    R = np.where(rng.random(m) < 0.2, -1.0, rng.random(m))
    mic = np.column_stack([cx, cy, R, rng.random(m)])
    codes = rng.integers(-9, 500, (m, 4 + MAXNEAR)).astype(np.int32)
    site = rng.random((m + 5, 2)) * (W, H)
    cells = np.sort(rng.choice(m + 5, m, replace=False)).astype(np.int32)
    rows = rng.permutation(m).astype(np.int32)
    q = cl.CommandQueue(ctx)
    dev = {k: cla.to_device(q, np.ascontiguousarray(v)) for k, v in
           {"site": site, "cells": cells, "rows": rows, "mic": mic, "codes": codes}.items()}
    out = {"center": cla.empty(q, (m, 2), np.float64), "radius": cla.empty(q, m, np.float64),
           "nn": cla.empty(q, m, np.float64), "flags": cla.empty(q, m, np.int32)}
    kernel = build_program(ctx, "cells", {"PERIODIC": int(dom.periodic), "MAXC": MAXC,
                                             "MAXNEAR": MAXNEAR})["mic_rows"]
    kernel(q, (padded(m, 1),), None, dev["site"].data, dev["cells"].data, dev["rows"].data,
           np.int32(m), np.float64(W), np.float64(H), dev["mic"].data, dev["codes"].data,
           *(a.data for a in out.values()))
    centre = np.where((R < 0)[:, None], site[cells], mic[:, :2])
    want = {"center": _scatter(dom.wrap(centre) if dom.periodic else centre, rows),
            "radius": _scatter(R, rows), "nn": _scatter(mic[:, 3], rows), "flags": codes[:, 3]}
    for name, a in out.items():
        assert a.get().tobytes() == np.ascontiguousarray(want[name]).tobytes(), name


def test_a_sub_problem_with_its_whole_sets_density_gets_the_same_mics(solvers):
    """A local step's sub-problem (the sites around a few, out of many) solved on buckets
    sized for the whole set's density, as ``relax_local`` asks: the MICs of exact_mic."""
    dom = Domain.torus()
    pts = dart_throwing(20000, rel_radius=0.7, seed=4)
    rng = np.random.default_rng(4)
    centres = pts[rng.choice(len(pts), 30, replace=False)]
    near = dom.shortest(pts[:, None, :] - centres[None, :, :])
    sub = pts[(np.hypot(*near.transpose(2, 0, 1)) < 0.03).any(axis=1)]
    cells = np.flatnonzero((np.hypot(*dom.shortest(sub[:, None, :] - centres[None]).transpose(2, 0, 1))
                            < 0.012).any(axis=1))
    solver = solvers(dom)
    want = exact_mic(sub, domain=dom, cells=cells)
    for density in (None, len(pts) / dom.area):
        got = solver.solve(sub, cells=cells, density=density)
        np.testing.assert_allclose(got.radii, want.radii, rtol=0, atol=1e-12)
        assert _wrapped_diff(got.centers, want.centers, dom) <= 1e-9


@SETTINGS
@given(periodic=st.booleans(), n=st.integers(2, 30), lattice=st.booleans(),
       seed=st.integers(0, 2**32 - 1))
def test_nearest_on_grids_of_one_or_two_buckets_across(solvers, periodic, n, lattice, seed):
    """CellMIC.nearest where the bucket grid is one to four buckets across: a row's three
    buckets are then not one run of sites, and on a torus the same bucket comes back
    shifted by a period; lattices put sites on bucket edges."""
    dom = Domain.torus() if periodic else Domain.rect(3.0, 2.0)
    rng = np.random.default_rng(seed)
    if lattice:
        k = int(np.ceil(np.sqrt(n)))
        pts = np.stack(np.meshgrid(np.arange(k) / k, np.arange(k) / k), -1).reshape(-1, 2)[:n]
    else:
        pts = rng.random((n, 2))
    pts = pts * (dom.width, dom.height)
    assert np.abs(solvers(dom).nearest(pts) - _brute_nearest(pts, dom)).max() <= 1e-15


def _brute_slacks(X, w, dom, p, q, R):
    """Slack at the vertex (q relative to site p, radius R) of every half-plane of cell p,
    by brute force: every other site and its images one period away (on a torus), and
    the four edges (on a rectangle).  ``{code: (slack, |beta|)}`` with the kernel's codes
    (beta grows like 1/|a| where sites nearly coincide, and the digits of the slack
    and of a vertex it fixes go with it)."""
    shifts = [(sx, sy) for sx in (-1, 0, 1) for sy in (-1, 0, 1)] if dom.periodic else [(0, 0)]
    out = {}
    for sx, sy in shifts:
        a = X + (sx * dom.width, sy * dom.height) - X[p]
        L = np.hypot(a[:, 0], a[:, 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            be = (L * L - w + w[p]) / (2 * L)
            s = be - (a @ q) / L - R
        for j in np.flatnonzero(L > 0):
            out[9 * j + 3 * (sx + 1) + (sy + 1)] = (s[j], abs(be[j]))
    if not dom.periodic:
        x, y = X[p] + q
        for code, s in zip((-1, -2, -3, -4), (x, dom.width - x, y, dom.height - y)):
            out[code] = (s - R, s)
    return out


@st.composite
def kernel_sets(draw):
    """cell_sets, and the degenerate sets where the kernel's ties and near-tight
    constraints matter: lattices (exact ties), coincident and near-coincident sites."""
    kind = draw(st.sampled_from(["cells", "lattice", "coincident"]))
    if kind == "cells":
        return draw(cell_sets())
    periodic = draw(st.booleans())
    dom = Domain.torus() if periodic else Domain.rect(1.0, 1.0)
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    if kind == "lattice":
        k = draw(st.integers(2, 9))
        g = (np.arange(k) + draw(st.sampled_from([0.0, 0.5]))) / k
        pts = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
        pts[:, 1] += 0.5 / k * draw(st.sampled_from([0.0, 0.5])) * (np.arange(len(pts)) // k % 2)
        pts = np.mod(pts, 1.0) if periodic else np.clip(pts, 0.0, 1.0)
    else:
        pts = rng.random((draw(st.integers(3, 40)), 2))
        pts[1::3] = pts[::3][: len(pts[1::3])] + draw(st.sampled_from([0.0, 1e-12, 1e-7]))
        pts = np.clip(pts, 0.0, 0.999)
    w = None if draw(st.booleans()) else (0.3 / np.sqrt(len(pts)) * rng.random(len(pts))) ** 2
    return dom, pts, w


@settings(max_examples=60)
@given(kernel_sets())
def test_the_kernels_basis_and_near_tight_codes_by_brute_force(solvers, case):
    """cell_mic's own outputs (before the host's re-solve): at each proven cell's vertex no
    half-plane is violated, the three basic ones are tight, and the near-tight codes are
    exactly the other half-planes within the near-tight tolerance, whatever the list
    order, the pivots or the counts the kernel took on its way."""
    dom, pts, w = case
    X0 = np.unique(pts, axis=0)
    assume(len(X0) >= 2 and len(pts) == len(X0))
    solver = solvers(dom)
    seen = {}
    finish = solver._finish

    def keep(X, w, out, pos, rows):
        seen.update(X=np.array(X), w=np.array(w), mic=np.array(out["mic"]), codes=np.array(out["codes"]),
                    pos=np.array(pos))
        return finish(X, w, out, pos, rows)

    solver._finish = keep   # on the instance, for this call (hypothesis: no function-scoped fixture)
    try:
        solver.solve(pts, w, certify=True)
    finally:
        del solver._finish
    X, ws, mic, codes, pos = seen["X"], seen["w"], seen["mic"], seen["codes"], seen["pos"]
    scale = max(dom.width, dom.height)
    near_tol = 1e-7 * np.sqrt(dom.area / len(X))
    for row, p in enumerate(pos):
        if codes[row, 3] & ~FLAGS["nn"]:
            continue   # not proven: exact_mic answers for it
        slack = _brute_slacks(X, ws, dom, p, mic[row, :2] - X[p], mic[row, 2])
        basis = set(codes[row, :3])
        # rounding of either computation: of the constraint's own beta, and of the
        # vertex, which the basis' betas fix
        fixed = max(slack[c][1] for c in basis)
        err = {c: 1e-10 * scale + 1e-11 * (b + fixed) for c, (s, b) in slack.items()}
        assert all(s >= -err[c] for c, (s, b) in slack.items()), row
        assert all(abs(slack[c][0]) <= err[c] for c in basis), row
        near = set(codes[row, 4:]) - {NO_CODE}
        # (the error either side of the tolerance: numpy's and the kernel's rounding differ)
        assert {c for c, (s, b) in slack.items() if s < near_tol - err[c]} - basis <= near, row
        assert all(slack[c][0] < near_tol + err[c] for c in near), row


def _sextant_start(X, w, dom, p, grid, box):
    """The start basis cell_mic's start_basis takes for cell p, as numpy computes it:
    the constraints of its first list (the rectangle's edges, then the sites of the
    bucket box `box` = (x0, y0, x1, y1), inclusive, inside `grid`), the nearest of each
    60-degree sextant, and the nearest of three 120-degree sectors where they bound a
    triangle (else the sectors turned by 60 degrees).  ``(codes, inverse)`` of that
    basis, or None where the kernel's start is the artificial triangle, or where
    rounding could decide between sextants, nearest sites or the triangle test."""
    a, codes = _first_list(X, w, dom, p, grid, box)
    L = np.hypot(a[:, 0], a[:, 1])
    il = 1.0 / L
    nx, ny = a[:, 0] * il, a[:, 1] * il
    be = np.where(codes < 0, a[:, 2], 0.5 * a[:, 2] * il)
    site = codes >= 0
    if np.any(site & ((np.abs(np.abs(nx) - 0.5) < 1e-9) | (np.abs(ny) < 1e-9))):
        return None
    up = ny >= 0.0
    sext = np.where(up, 2 - (nx > 0.5) - (nx > -0.5), 3 + (nx >= -0.5) + (nx >= 0.5))
    near = []
    for j in range(6):
        ks = np.flatnonzero(sext == j)
        order = ks[np.argsort(be[ks], kind="stable")]
        if len(order) > 1 and be[order[1]] - be[order[0]] < 1e-9 * (1 + abs(be[order[0]])):
            return None   # a tie, which the list's order decides
        near.append((order[0], be[order[0]]) if len(order) else (-1, np.inf))
    for first in (0, 1):
        pick = []
        for k in range(3):
            (ku, bu), (kv, bv) = near[(first + 2 * k) % 6], near[(first + 2 * k + 1) % 6]
            pick.append(kv if bv < bu else ku)
        if min(pick) < 0:
            continue
        M = np.column_stack([nx[pick], ny[pick], np.ones(3)])
        if abs(np.linalg.det(M)) < 1e-9:
            return None
        inv = np.linalg.inv(M)
        if np.any(np.abs(inv[2]) < 1e-9):
            return None
        if np.all(inv[2] > 0):
            return codes[pick], inv @ be[pick]
    return None


def _first_list(X, w, dom, p, grid, box):
    """The constraints of cell p's first list: rows ``(a_x, a_y, beta numerator)``
    (sites: offset and ``|a|^2 - w_j + w_i``; edges: normal and distance) and codes."""
    x0, y0, x1, y1 = box
    bx = np.clip((X[:, 0] / grid[2]).astype(np.int64), 0, grid[0] - 1)
    by = np.clip((X[:, 1] / grid[3]).astype(np.int64), 0, grid[1] - 1)
    js = np.flatnonzero((bx >= x0) & (bx <= x1) & (by >= y0) & (by <= y1))
    a = X[js] - X[p]
    len2 = a[:, 0] * a[:, 0] + a[:, 1] * a[:, 1]
    keep = len2 > 0
    rows = np.column_stack([a[keep], (len2 - w[js] + w[p])[keep]])
    codes = 9 * js[keep] + 4
    if not dom.periodic:
        x, y = X[p]
        edges = np.array([[-1.0, 0.0, x], [1.0, 0.0, dom.width - x], [0.0, -1.0, y],
                          [0.0, 1.0, dom.height - y]])
        rows, codes = np.vstack([edges, rows]), np.concatenate([[-1, -2, -3, -4], codes])
    return rows, codes


def _first_box(X, grid, p):
    """The bucket box cell_mic gathers for cell p before its first solve (rings until
    14 sites, at least one ring), or None where it reaches past the grid (wrapped
    rings, shifted images) or its list would fill (48 sites)."""
    nbx, nby, bw, bh = grid
    hx, hy = min(int(X[p, 0] / bw), nbx - 1), min(int(X[p, 1] / bh), nby - 1)
    bx = np.clip((X[:, 0] / bw).astype(np.int64), 0, nbx - 1)
    by = np.clip((X[:, 1] / bh).astype(np.int64), 0, nby - 1)
    for ring in range(1, 7):
        box = (hx - ring, hy - ring, hx + ring, hy + ring)
        if box[0] < 0 or box[1] < 0 or box[2] >= nbx or box[3] >= nby:
            return None
        inside = (np.abs(bx - hx) <= ring) & (np.abs(by - hy) <= ring)
        count = np.count_nonzero(inside & np.any(X != X[p], axis=1))
        if count >= 48:
            return None
        if count >= 14 or ring == 6:
            return box
    return None


@st.composite
def start_sets(draw):
    """Random sites, many to a cell's rings: a torus or a rectangle, with or without weights."""
    dom = Domain.torus() if draw(st.booleans()) else Domain.rect(draw(st.sampled_from([1.0, 3.0])), 1.0)
    n = draw(st.integers(60, 400))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    pts = rng.random((n, 2)) * (dom.width, dom.height)
    w = None if draw(st.booleans()) else (0.3 * np.sqrt(dom.area / n) * rng.random(n)) ** 2
    return dom, pts, w


@settings(max_examples=25)
@given(start_sets())
def test_the_kernels_basis_is_its_sector_start_where_that_start_is_optimal(solvers, case):
    """Where the start basis of the sextants' nearest constraints (numpy's, from the
    list the kernel gathers first) is optimal over all sites, cell_mic pivots nowhere
    and reports that basis in its start's order: the kernel's start (its sextant
    minima, sector pairs, triangle test) is numpy's, constraint for constraint."""
    dom, pts, w = case
    solver = solvers(dom)
    seen = {}
    finish, buckets = solver._finish, solver._buckets

    def keep(X, w, out, pos, rows):
        seen.update(X=np.array(X), w=np.array(w), codes=np.array(out["codes"]), pos=np.array(pos))
        return finish(X, w, out, pos, rows)

    def grid(*args, **kw):
        out = buckets(*args, **kw)
        seen["grid"] = out[3]
        return out

    solver._finish, solver._buckets = keep, grid
    try:
        solver.solve(pts, w, certify=True)
    finally:
        del solver._finish, solver._buckets
    X, ws, codes, pos = seen["X"], seen["w"], seen["codes"], seen["pos"]
    checked = 0
    for row, p in enumerate(pos):
        box = _first_box(X, seen["grid"], p)
        start = None if box is None else _sextant_start(X, ws, dom, p, seen["grid"], box)
        if start is None:
            continue
        basis, z = start
        slack = _brute_slacks(X, ws, dom, p, z[:2], z[2])
        if min(s for c, (s, _) in slack.items() if c not in basis) < 1e-9 * max(dom.width, dom.height):
            continue   # not optimal as it stands: the kernel pivots on
        assert list(codes[row, :3]) == list(basis), row
        checked += 1
    assume(checked > 0)


@given(st.integers(1, 300), st.integers(1, 50), st.sampled_from(["spread", "zero", "ties"]),
       st.integers(0, 2**32 - 1))
def test_bucket_maxima_are_reduceats_over_the_sites_in_bucket_order(n, nb, kind, seed):
    # the formula _bucket_maxima replaced: a maximum.reduceat over the sorted sites
    rng = np.random.default_rng(seed)
    bid = rng.integers(0, nb, n)
    w = {"spread": rng.random(n) * 10.0 ** rng.integers(-3, 4), "zero": np.zeros(n),
         "ties": rng.integers(0, 3, n).astype(float)}[kind]
    w -= w.min()   # as CellMIC.solve shifts them
    order = np.argsort(bid, kind="stable")
    counts = np.bincount(bid, minlength=nb)
    start = np.concatenate([[0], np.cumsum(counts)])
    nonempty = counts > 0
    expect = np.zeros(nb)
    expect[nonempty] = np.maximum.reduceat(w[order], start[:-1][nonempty])
    assert np.array_equal(_bucket_maxima(w, bid, nb), expect)


_EMPTY_FAR = textwrap.dedent("""
    import numpy as np
    from diskpack_cl.device.cells import CellMIC
    from diskpack_cl.domain import Domain
    from diskpack_cl.geometry import exact_mic
    pts = np.array([[0.03056459710235948, 0.5534426318376761],
                    [0.03056459710335948, 0.553442631838676],
                    [0.3804227502986096, 0.4081990975562555]])
    w = np.array([0.02940231276327682, 0.00023778427364327, 0.01045311859950472])
    for dom in (Domain.torus(), Domain.rect(1.0, 1.0)):
        got, want = CellMIC(dom).solve(pts, w, certify=True), exact_mic(pts, w, domain=dom)
        assert got.radii[1] < -1e9, got.radii   # the lighter twin's cell is empty
        assert np.allclose(got.radii, want.radii, rtol=1e-9, atol=1e-12), (got.radii, want.radii)
        assert np.allclose(got.centers, want.centers, rtol=0, atol=1e-9)
    print("ok")
""")


def test_an_empty_cell_whose_centre_lies_far_away_ends(ctx):
    """Two sites 1e-12 apart with unequal weights (hypothesis found them): the lighter
    one's power cell is empty, its LP's centre lies some 1e10 bucket widths away, and the
    proof scan's bucket bounds, clamped on one side only, overflowed int there (INT_MIN
    on x86): the kernel scanned from INT_MIN and never ended.  In a child process, so
    that a hang fails the test instead of holding up the suite."""
    proc = subprocess.run([sys.executable, "-c", _EMPTY_FAR], capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0 and proc.stdout.strip() == "ok", proc.stderr[-3000:]


def _probe(ctx, source, name):
    """Kernel `name` of cells.cl with the probe `source` appended (it calls cells.cl's
    static functions on lists the host fills), and a queue."""
    import pyopencl as cl

    from diskpack_cl.device import programs as _kernels
    from diskpack_cl.device.cells import MAXC, MAXNEAR
    from diskpack_cl.device.programs import kernel_dir

    defines = {"INLINE_MATH": _kernels.inline_math(ctx), "PERIODIC": 0, "MAXC": MAXC,
               "MAXNEAR": MAXNEAR}
    src = (kernel_dir() / "cells.cl").read_text() + source
    opts = ["-I", str(kernel_dir())] + [f"-D{k}={v}" for k, v in defines.items()]
    return getattr(cl.Program(ctx, src).build(options=opts), name), cl.CommandQueue(ctx)


_REPLACE_PROBE = """
/* replace_slackest on a list the host fills: where the new constraint (code 12345)
 * went, -1 where it found no place */
__kernel void probe_replace(__global const double *nx, __global const double *ny,
                            __global const double *be, __global const int *code, const int m,
                            __global const int *basis, __global const double *zin,
                            const double sl, __global int *out)
{
    clist L;
    for (int k = 0; k < m; ++k) {
        L.nx[k] = nx[k]; L.ny[k] = ny[k]; L.be[k] = be[k]; L.d[k] = 1.0; L.code[k] = code[k];
    }
    L.m = m; L.raw = m;
    const int b[3] = {basis[0], basis[1], basis[2]};
    const double z[3] = {zin[0], zin[1], zin[2]};
    int pos = -1;
    if (replace_slackest(&L, b, z, sl, 3.0, 4.0, 25.0, 0.0, 0.0, 12345))
        for (int k = 0; k < m; ++k) pos = L.code[k] == 12345 ? k : pos;
    out[0] = pos;
}
"""


@pytest.mark.parametrize("seed", range(3))
def test_a_full_list_evicts_its_slackest_non_basic_site(ctx, seed):
    """replace_slackest (cells.cl) puts the new constraint in place of the non-basic site
    (code >= 0) with the most slack, when that has more than the new one, the lowest
    position on ties; its two lanes of even and odd positions must merge to exactly
    that.  Slacks drawn from a few values, so that ties and equal lane maxima are common,
    on lists of both parities."""
    import pyopencl as cl

    from diskpack_cl.device.cells import MAXC

    probe, queue = _probe(ctx, _REPLACE_PROBE, "probe_replace")
    mf = cl.mem_flags
    rng = np.random.default_rng(seed)
    for _ in range(200):
        m = int(rng.integers(4, MAXC + 1))
        nx, ny = np.zeros(m), np.zeros(m)
        z = np.array([0.0, 0.0, 1.0])
        be = 1.0 + rng.integers(0, 4, m).astype(float)      # slack be - 1: 0, 1, 2 or 3
        code = np.where(rng.random(m) < 0.15, -1 - rng.integers(0, 7, m), 9 * np.arange(m) + 4)
        basis = rng.choice(np.arange(3, m), size=min(3, m - 3), replace=False)
        basis = np.concatenate([basis, [0, 1, 2]])[:3].astype(np.int32)
        sl = float(rng.integers(-1, 3))
        slack = be - 1.0
        ok = (np.arange(m) >= 3) & (code >= 0) & ~np.isin(np.arange(m), basis) & (slack > sl)
        want = int(np.flatnonzero(ok & (slack == slack[ok].max()))[0]) if ok.any() else -1
        bufs = [cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a) for a in
                (nx, ny, be, code.astype(np.int32), basis, z)]
        out = np.zeros(1, np.int32)
        obuf = cl.Buffer(ctx, mf.WRITE_ONLY, out.nbytes)
        probe(queue, (1,), None, *bufs[:4], np.int32(m), bufs[4], bufs[5], np.float64(sl), obuf)
        cl.enqueue_copy(queue, out, obuf)
        assert out[0] == want, (m, sl, slack.tolist(), code.tolist(), basis.tolist())


_WARM_PROBE = """
/* warm_basis on a list the host fills: whether it found a basis, and the basis
 * (b as it was, -100s, where it found none) */
__kernel void probe_warm(__global const double *nx, __global const double *ny,
                         __global const int *code, const int m, __global const int *newpos,
                         __global const int *prev_in, __global int *out)
{
    clist L;
    for (int k = 0; k < m; ++k) {
        L.nx[k] = nx[k]; L.ny[k] = ny[k]; L.be[k] = 1.0; L.d[k] = 1.0; L.code[k] = code[k];
    }
    L.m = m; L.raw = m;
    const int prev[3] = {prev_in[0], prev_in[1], prev_in[2]};
    int b[3] = {-100, -100, -100};
    double inv[9];
    out[0] = warm_basis(&L, newpos, prev, b, inv);
    out[1] = b[0]; out[2] = b[1]; out[3] = b[2];
}
"""


def _warm_case(rng, maxc):
    """A cell's list (the artificial triangle, then walls and sites of distinct codes
    ``9 pos + image`` by the new sort's positions), the sort's move `newpos` (old position
    to new), and a last basis `prev` in old positions: mostly constraints of the list,
    some sites it lacks, now and then none or an artificial half-plane."""
    m, sites = int(rng.integers(6, maxc + 1)), 2 * maxc
    newpos = rng.permutation(sites).astype(np.int32)
    oldpos = np.argsort(newpos)
    sites_in = rng.choice(sites, m - 3, replace=False)
    code = 9 * sites_in + rng.integers(0, 9, m - 3)
    walls = rng.choice(m - 3, int(rng.integers(0, 4)), replace=False)
    code[walls] = -1 - np.arange(len(walls))
    code = np.concatenate([[-5, -6, -7], code]).astype(np.int32)
    theta = rng.random(m) * 2 * np.pi
    picks = rng.choice(np.arange(3, m), 3, replace=False)
    if rng.random() < 0.5:   # normals about 120 degrees apart: a triangle, mostly
        theta[picks] = theta[picks[0]] + np.array([0.0, 2.1, 4.2]) + rng.normal(0, 0.3, 3)
    prev = []
    for j in picks:
        u = rng.random()
        c = int(code[j])
        if u < 0.8:      # a constraint of the list, as the last sort numbered it
            prev.append(c if c < 0 else 9 * int(oldpos[c // 9]) + c % 9)
        elif u < 0.93:    # a site the list does not hold
            out = np.setdiff1d(np.arange(sites), sites_in)
            prev.append(9 * int(oldpos[rng.choice(out)]) + int(rng.integers(0, 9)))
        else:             # none, or an artificial half-plane
            prev.append(int(rng.choice([-9, -5, -6, -7])))
    return code, np.cos(theta), np.sin(theta), newpos, np.array(prev, np.int32)


def _warm_want(code, nx, ny, newpos, prev):
    """warm_basis by numpy: the list positions of the last basis' constraints renumbered
    by the move, where all three are there and their normals span the plane positively
    (the dual multipliers of the 3 x 3 system are > 0)."""
    if (prev < -4).any():
        return 0, [-100] * 3
    c = np.where(prev < 0, prev, 9 * newpos[np.maximum(prev, 0) // 9] + prev % 9)
    f = [int(np.flatnonzero(code[3:] == ck)[-1]) + 3 if (code[3:] == ck).any() else -1 for ck in c]
    if min(f) < 0:
        return 0, [-100] * 3
    M = np.array([nx[f], ny[f], np.ones(3)])
    if abs(np.linalg.det(M)) < 1e-12:
        return None, None   # singular to rounding: either answer
    lam = np.linalg.solve(M, [0.0, 0.0, 1.0])
    return (1, f) if (lam > 0).all() else (0, [-100] * 3)


@pytest.mark.parametrize("seed", range(3))
def test_a_warm_start_takes_the_last_basis_renumbered_by_the_sort(ctx, seed):
    """warm_basis (cells.cl) finds the last call's basis in the cell's new list: each
    site's code renumbered from the last sort's position to this one's (``newpos``), walls
    as they are, and takes it where the three bound a triangle; no basis where one is
    missing, was none or artificial.  A wrong renumbering only costs pivots (the simplex
    still reaches the optimum), so no answer of the kernel shows it: this probe does."""
    import pyopencl as cl

    from diskpack_cl.device.cells import MAXC

    probe, queue = _probe(ctx, _WARM_PROBE, "probe_warm")
    mf = cl.mem_flags
    rng = np.random.default_rng(seed)
    found = 0
    for _ in range(300):
        code, nx, ny, newpos, prev = _warm_case(rng, MAXC)
        want, basis = _warm_want(code, nx, ny, newpos, prev)
        if want is None:
            continue
        bufs = [cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a) for a in (nx, ny, code, newpos, prev)]
        out = np.zeros(4, np.int32)
        obuf = cl.Buffer(ctx, mf.WRITE_ONLY, out.nbytes)
        probe(queue, (1,), None, *bufs[:3], np.int32(len(code)), bufs[3], bufs[4], obuf)
        cl.enqueue_copy(queue, out, obuf)
        assert out.tolist() == [want, *basis], (code.tolist(), newpos.tolist(), prev.tolist())
        found += want
    assert found >= 30   # the cases reach the basis often enough to test it
