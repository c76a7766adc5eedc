"""The per-cell MIC kernel started warm (from the last call's bases) against cold starts."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from diskpack_cl.device.cells import CellMIC
from diskpack_cl.domain import Domain
from diskpack_cl.geometry import exact_mic
from diskpack_cl.stipple import stipple


@pytest.fixture(scope="module")
def solvers(ctx):
    """One CellMIC per domain kind, built once; each records the warm bits of its calls."""
    cache = {}

    def get(domain):
        if domain not in cache:
            solver = CellMIC(domain, device=ctx)
            solver.bits = []
            solve_cells = solver._solve_cells

            def record(*args):
                solver.bits.append(args[-1])
                return solve_cells(*args)
            solver._solve_cells = record   # on the instance: the module's solvers only
            cache[domain] = solver
        return cache[domain]
    return get


def _agree(dom, pts, w, got, want):
    """`got` has the MICs `want` has of `pts`: the same empty cells and radii (to 1e-12
    of the domain), and centres whose disks lie in their cells (to 1e-9 of it); where a
    cell's centre is not unique (a lattice's rectangles) two solves may differ there."""
    scale = max(dom.width, dom.height)
    assert np.array_equal(got.empty, want.empty)
    assert np.abs(got.radii - want.radii).max(initial=0.0) <= 1e-12 * scale
    assert _least_slack(dom, pts, w, got) >= -1e-9 * scale


def _least_slack(dom, pts, w, mic):
    """The smallest slack of any live cell's disk against any bisector (every periodic
    image) and edge, by brute force."""
    w = np.zeros(len(pts)) if w is None else np.asarray(w)
    live = np.flatnonzero(~mic.empty)
    c, R = mic.centers[live], mic.radii[live]
    q = c - pts[live]
    if dom.periodic:
        q -= np.round(q)   # centres come wrapped: the offset from the site, not from the wrap
    least = np.inf
    shifts = [(sx, sy) for sx in (-1, 0, 1) for sy in (-1, 0, 1)] if dom.periodic else [(0, 0)]
    for sx, sy in shifts:
        a = pts[None, :, :] + (sx * dom.width, sy * dom.height) - pts[live, None, :]
        L = np.hypot(a[..., 0], a[..., 1])
        other = L > 0
        beta = (L ** 2 - w[None, :] + w[live, None]) / (2 * np.where(other, L, 1.0))
        s = beta - (a[..., 0] * q[:, None, 0] + a[..., 1] * q[:, None, 1]) / np.where(other, L, 1.0) - R[:, None]
        least = min(least, s[other].min(initial=np.inf))
    if not dom.periodic:
        least = min(least, (c[:, 0] - R).min(initial=np.inf), (dom.width - c[:, 0] - R).min(initial=np.inf),
                    (c[:, 1] - R).min(initial=np.inf), (dom.height - c[:, 1] - R).min(initial=np.inf))
    return least


def _lattice(n, rng):
    """A square lattice of about n sites on the unit square, in random order: every
    cell a square, ties everywhere."""
    k = max(2, int(np.sqrt(n)))
    g = (np.arange(k) + 0.5) / k
    return rng.permutation(np.stack(np.meshgrid(g, g), -1).reshape(-1, 2))


@st.composite
def warm_pairs(draw):
    """A domain, a set, and a second set of as many sites (and weights or None) that
    starts from the first one's bases: the set moved a little (a step), moved far,
    its sites in another order (each basis names other sites), another set, or a
    lattice (degenerate cells) from a random set or the reverse."""
    periodic = draw(st.booleans())
    dom = Domain.torus() if periodic else Domain.rect(draw(st.sampled_from([1.0, 40.0])), 1.0)
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    kind = draw(st.sampled_from(["step", "far", "permuted", "other", "to-lattice", "from-lattice"]))
    n = draw(st.integers(3, 300))
    a = _lattice(n, rng) if kind == "from-lattice" else rng.random((n, 2))
    n = len(a)
    spacing = 1.0 / np.sqrt(n)
    b = {"step": lambda: a + 0.1 * spacing * rng.standard_normal(a.shape),
         "far": lambda: a + 2.0 * spacing * rng.standard_normal(a.shape),
         "permuted": lambda: rng.permutation(a),
         "other": lambda: rng.random(a.shape),
         "to-lattice": lambda: _lattice(n, rng),
         "from-lattice": lambda: rng.random(a.shape)}[kind]()
    assume(len(b) == n)
    b = np.mod(b, 1.0) if periodic else np.clip(b, 0.0, 1.0 - 1e-9)
    scale = np.array([dom.width, dom.height])
    a, b = a * scale, b * scale
    assume(len(np.unique(b, axis=0)) == n)
    w = None
    if draw(st.booleans()):   # power cells, weights from the spacing, as a stippling's
        w = [(0.5 * spacing * scale.min() * rng.random(n)) ** 2 for _ in range(2)]
    return dom, a, b, w


@settings(max_examples=40)
@given(warm_pairs(), st.booleans())
def test_a_warm_start_finds_the_cold_starts_mics(solvers, case, certify):
    dom, a, b, w = case
    solver = solvers(dom)
    wa, wb = (None, None) if w is None else w
    solver.solve(a, wa, certify=certify, warm=True)
    warm = solver.solve(b, wb, certify=certify, warm=True)
    assert solver.bits[-1] == 3   # the second call read the first one's bases
    cold = solver.solve(b, wb, certify=certify)
    _agree(dom, b, wb, warm, cold)
    _agree(dom, b, wb, warm, exact_mic(b, wb, dom))


def test_no_warm_start_for_a_list_of_cells(solvers):
    pts = np.random.default_rng(0).random((50, 2))
    with pytest.raises(ValueError, match="warm"):
        solvers(Domain.torus()).solve(pts, cells=[1, 2], warm=True)


def test_a_cold_call_between_warm_ones_starts_the_next_afresh(solvers):
    """The bases on the device are by the sorted positions of the warm call that wrote
    them: after another call's sort they name other sites, and are not read."""
    dom = Domain.torus()
    solver = solvers(dom)
    rng = np.random.default_rng(1)
    sets = [rng.random((200, 2)) for _ in range(3)]
    solver.solve(sets[0], warm=True)
    solver.solve(sets[1])
    got = solver.solve(sets[2], warm=True)
    assert solver.bits[-2:] == [0, 2]
    _agree(dom, sets[2], None, got, exact_mic(sets[2], None, dom))


def test_every_step_of_a_stippling_has_the_cold_starts_mics(ctx, monkeypatch):
    """Each MIC solve of a short stippling (warm after its first) against a cold solve of
    the same sites by another solver."""
    g = np.clip(np.add.outer(np.linspace(0.1, 0.9, 48), np.linspace(0.0, 0.6, 64)), 0, 1)
    g[12:24, 20:36] = 0.0   # a black rectangle: dense dots beside sparse ones
    dom = Domain.rect(64.0, 48.0)
    cold = CellMIC(dom, device=ctx)
    solve, warm_mode, checked, bits = CellMIC.solve, CellMIC._warm_mode, [], []

    def compare(self, points, weights=None, **kw):
        got = solve(self, points, weights, **kw)
        if self is not cold:
            checked.append(kw.get("warm", False))
            _agree(dom, np.asarray(points), weights, got, solve(cold, points, weights))
        return got

    def record(self, warm, cells):
        bits.append(warm_mode(self, warm, cells))
        return bits[-1]

    monkeypatch.setattr(CellMIC, "solve", compare)
    monkeypatch.setattr(CellMIC, "_warm_mode", record)
    stipple(g, 600, schedule=[("mix", 6, 0.7), ("pack", 3)], device=ctx, backend="opencl", seed=2)
    if not checked:
        pytest.skip("the raster route: no per-cell kernel")
    assert sum(checked) >= 8   # the steps' solves were warm,
    assert bits.count(3) >= sum(checked) - 1   # and all but the first read the last one's bases


def test_a_warm_stippling_gives_the_same_dots_twice(ctx, monkeypatch):
    """Same picture and seed, same dots bit for bit, also after another stippling of
    as many dots in the same process: each run starts its bases afresh, and the kernel
    reads the last step's bases from one buffer while it writes this step's to the other."""
    g = np.clip(np.add.outer(np.linspace(0.1, 0.9, 48), np.linspace(0.0, 0.6, 64)), 0, 1)
    g[12:24, 20:36] = 0.0
    warm_mode, bits = CellMIC._warm_mode, []

    def record(self, warm, cells):
        bits.append(warm_mode(self, warm, cells))
        return bits[-1]

    monkeypatch.setattr(CellMIC, "_warm_mode", record)
    kw = dict(schedule=[("mix", 6, 0.7), ("pack", 3)], device=ctx, backend="opencl")
    first = stipple(g, 600, seed=2, **kw).points
    stipple(1.0 - g, 600, seed=5, **kw)
    again = stipple(g, 600, seed=2, **kw).points
    if 3 not in bits:
        pytest.skip("the raster route: no per-cell kernel")
    np.testing.assert_array_equal(first, again)
