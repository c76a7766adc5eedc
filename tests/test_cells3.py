"""3D: maximal inscribed spheres on the device against linprog per cell, rho by brute force."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import diskpack_cl.device.cells3 as cells3
from diskpack_cl.device.cells3 import CellMIC3, Domain3, certify_mis, exact_mis, inscribed_sphere_linprog
from diskpack_cl.poisson3 import (FCC_DENSITY, as_box3, dart_throwing3, fcc_radius, normalized_radius3,
                                  relax_poisson3)

SHIFTS = np.array(np.meshgrid(*[[-1, 0, 1]] * 3, indexing="ij")).reshape(3, -1).T


def _brute_sphere(X, i, dom):
    """linprog over every other site (all 27 periodic images on a torus) and the walls."""
    others = [X + s * dom.size for s in (SHIFTS if dom.periodic else [np.zeros(3)])]
    a = np.concatenate(others) - X[i]
    L = np.linalg.norm(a, axis=1)
    a, L = a[L > 0], L[L > 0]
    normals, beta = a / L[:, None], L / 2
    if not dom.periodic:
        normals = np.vstack([normals, -np.eye(3), np.eye(3)])
        beta = np.concatenate([beta, X[i], dom.size - X[i]])
    q, R = inscribed_sphere_linprog(normals, beta)
    return X[i] + q, R


def _brute_rho(X, dom):
    d = X[:, None, :] - X[None, :, :]
    if dom.periodic:
        d -= np.round(d / dom.size) * dom.size
    r = np.linalg.norm(d, axis=2)
    return 0.5 * r[np.triu_indices(len(X), 1)].min() / fcc_radius(len(X), dom.volume)


@pytest.fixture(scope="module")
def engines(ctx):
    return {True: CellMIC3(Domain3.torus(), ctx), False: CellMIC3(Domain3.box(2, 1, 0.5), ctx)}


@pytest.mark.parametrize("periodic", [True, False])
def test_kernel_matches_linprog_per_cell(engines, periodic):
    eng = engines[periodic]
    dom = eng.domain
    X = np.random.default_rng(1).random((120, 3)) * dom.size
    res = eng.solve(X)
    assert res.stats["fallback"] == 0
    for i in range(0, 120, 7):
        c, R = _brute_sphere(X, i, dom)
        assert res.radii[i] == pytest.approx(R, abs=1e-9)
        d = res.centers[i] - c
        if dom.periodic:
            d -= np.round(d)
        assert np.abs(d).max() < 1e-7


def _degenerate3(kind, n, rng, size):
    if kind == "lattice":
        m = max(2, round(n ** (1 / 3)))
        return (np.indices((m, m, m)).reshape(3, -1).T + 0.5) / m * size
    if kind == "cluster":
        return 0.3 * size + 1e-3 * rng.random((n, 3))
    if kind == "walls":
        p = rng.random((n, 3)) * size
        axis = rng.integers(0, 3, n)
        p[np.arange(n), axis] = rng.choice([0.0, 1.0], n) * size[axis]
        return p
    return rng.random((n, 3)) * size


@settings(max_examples=15)
@given(kind=st.sampled_from(["lattice", "cluster", "walls", "random"]), n=st.integers(4, 40),
       periodic=st.booleans(), seed=st.integers(0, 2 ** 16))
def test_kernel_hypothesis_against_linprog(engines, kind, n, periodic, seed):
    eng = engines[periodic]
    X = np.unique(_degenerate3(kind, n, np.random.default_rng(seed), eng.domain.size), axis=0)
    X = eng.domain.check(X)
    assume(len(np.unique(X, axis=0)) == len(X) and len(X) >= 2)
    res = eng.solve(X)
    want = np.array([_brute_sphere(X, i, eng.domain)[1] for i in range(len(X))])
    # HiGHS stops within its feasibility tolerance (1e-7): the exact answer is ours,
    # which the certificate below checks to 1e-10
    np.testing.assert_allclose(res.radii, want, atol=1e-7)
    certified = certify_mis(X, res.centers, res.radii, eng.domain, k=len(X) * 27)
    assert np.count_nonzero(~certified) == res.stats["uncertified"]
    assert certify_mis(X, res.centers, res.radii, eng.domain, k=len(X) * 27, tol=1e-7).all()


def test_exact_mis_and_certificate():
    dom = Domain3.torus()
    X = np.random.default_rng(3).random((60, 3))
    m = exact_mis(X, dom)
    assert m.radii[5] == pytest.approx(_brute_sphere(X, 5, dom)[1], abs=1e-9)
    assert certify_mis(X, m.centers, m.radii, dom).all()
    # a sphere one part in a million too large is refused
    assert not certify_mis(X, m.centers, m.radii * (1 + 1e-6), dom).all()


@pytest.mark.parametrize("box", [None, "1x2x0.5"])
def test_exact_mis_of_a_few_cells_among_many(box):
    """A few cells of a large set are solved among the sites around them: the answers of
    the whole set; an isolated site, whose sphere reaches past them, is solved among all."""
    dom = as_box3(box)
    rng = np.random.default_rng(7)
    X = rng.random((20000, 3)) * dom.size
    X = X[np.linalg.norm(X - 0.5 * dom.size, axis=1) > 0.35]
    X = np.vstack([X, 0.5 * dom.size])                     # alone in a hole of radius 0.35
    cells = np.array([3, 500, len(X) - 1])
    few = exact_mis(X, dom, cells=cells)
    for t, i in enumerate(cells):
        alone = cells3._exact_mis(dom.check(X), dom, np.array([i]), 64)
        assert few.radii[t] == pytest.approx(alone.radii[0], abs=1e-12)
        np.testing.assert_allclose(few.centers[t], alone.centers[0], rtol=0, atol=1e-12)
    assert few.radii[-1] > 0.17   # 2 R past the 8 spacings (0.32) kept around it
    near = cells3._exact_mis_near(dom.check(X), dom, cells[:2], 64)
    assert near is not None and cells3._exact_mis_near(dom.check(X), dom, cells, 64) is None
    np.testing.assert_allclose(near.radii, few.radii[:2], rtol=0, atol=1e-12)


def test_exact_mis_near_refuses_a_sphere_that_reaches_past_its_sites(monkeypatch):
    X = np.random.default_rng(8).random((20000, 3))
    wide = lambda S, dom, cells, k: cells3.MIS(S[cells], np.full(len(cells), 0.2))
    monkeypatch.setattr(cells3, "_exact_mis", wide)   # 2 R = 0.4 past the 0.29 kept
    assert cells3._exact_mis_near(X, Domain3.torus(), np.array([5]), 64) is None
    narrow = lambda S, dom, cells, k: cells3.MIS(S[cells], np.full(len(cells), 0.1))
    monkeypatch.setattr(cells3, "_exact_mis", narrow)
    assert cells3._exact_mis_near(X, Domain3.torus(), np.array([5]), 64) is not None


@settings(max_examples=30)
@given(seed=st.integers(0, 2**32 - 1), periodic=st.booleans())
def test_kept_darts_match_one_tree_of_all_points(seed, periodic):
    """The two trees of the 3D darts answer what one tree of all points answers, as
    points are added batch after batch."""
    from scipy.spatial import cKDTree

    from diskpack_cl.poisson3 import _KeptDarts

    rng = np.random.default_rng(seed)
    box, d = (np.ones(3) if periodic else None), 0.08
    kept, pts = _KeptDarts(d, box), np.empty((0, 3))
    for size in rng.integers(1, 200, 8):
        pts = np.vstack([pts, rng.random((size, 3))])
        cand = rng.random((300, 3))
        want = cKDTree(pts, boxsize=box).query(cand, distance_upper_bound=d)[0] >= d
        np.testing.assert_array_equal(kept.free(pts, cand), want)


def test_fcc_rho():
    # FCC: the cubic cell of side a holds 4 spheres of radius a / (2 sqrt 2): rho = 1
    m = 3
    base = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    fcc = ((np.indices((m, m, m)).reshape(3, -1).T[:, None, :] + base).reshape(-1, 3)) / m
    assert normalized_radius3(fcc) == pytest.approx(1.0, abs=1e-12)
    X = np.random.default_rng(0).random((50, 3)) * (2, 1, 1)
    assert normalized_radius3(X, Domain3.box(2, 1, 1)) == pytest.approx(_brute_rho(X, Domain3.box(2, 1, 1)))
    assert 4 / 3 * np.pi * fcc_radius(10) ** 3 * 10 == pytest.approx(FCC_DENSITY)


@pytest.mark.parametrize("box", [None, "1x2x0.5"])
def test_relaxation_3d(box, ctx):
    dom = as_box3(box)
    X = np.random.default_rng(2).random((400, 3)) * dom.size
    rhos = []
    res = relax_poisson3(X, 0.75, domain=dom, device=ctx, callback=lambda i, r: rhos.append(r))
    assert res.stop_reason == "eps" and res.rho[-1] >= 0.75
    assert res.rho[-1] == pytest.approx(_brute_rho(res.points, dom), rel=1e-12)
    if dom.periodic:   # the minimum distance never drops on the torus
        assert np.all(np.diff(res.rho) >= -1e-12)


@pytest.mark.parametrize("box", [None, "1x2x0.5"])
def test_uncertified_iterates_3d(box, ctx, monkeypatch):
    """certify=False: the device's proven spheres (within 1e-9 of the certified ones,
    no host re-solve; cells it could not prove still go to exact_mis), the same
    iterations; rho still the brute-force one."""
    import diskpack_cl.device.cells3 as cells3

    dom = as_box3(box)
    X = np.random.default_rng(4).random((500, 3)) * dom.size
    eng = CellMIC3(dom, ctx)
    sure = eng.solve(X)
    def refused(*args, **kwargs):
        raise AssertionError("the host re-solved a cell")
    monkeypatch.setattr(cells3, "refine_basis", refused)   # the first step of the host's check
    fast = eng.solve(X, certify=False)
    np.testing.assert_allclose(fast.radii, sure.radii, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fast.centers, sure.centers, rtol=0, atol=1e-9)
    a = relax_poisson3(X, 0.75, domain=dom, device=ctx, certify=False)
    monkeypatch.undo()
    b = relax_poisson3(X, 0.75, domain=dom, device=ctx)
    assert a.iterations == b.iterations and a.stop_reason == "eps"
    np.testing.assert_allclose(a.points, b.points, rtol=0, atol=1e-8)
    assert a.rho[-1] == pytest.approx(_brute_rho(a.points, dom), rel=1e-12)


def test_3d_errors():
    with pytest.raises(ValueError, match=r"shape \(n, 3\)"):
        Domain3.torus().check(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="outside the box"):
        Domain3.box(1, 1, 1).check([[0.5, 0.5, 1.5], [0.1, 0.1, 0.1]])
    with pytest.raises(ValueError, match="box must be WxHxD"):
        as_box3("2x1")
    with pytest.raises(ValueError, match="eps must be"):
        relax_poisson3(np.random.default_rng(0).random((5, 3)), 1.5)


def test_poisson_disk_3d_and_cli(tmp_path, capsys, ctx):
    import json

    from diskpack_cl import cli
    from diskpack_cl.io import read_points
    from diskpack_cl.poisson import poisson_disk

    res = poisson_disk(min_distance=0.2, box=(2, 1, 1), dim=3, seed=0, device=ctx)
    assert res.reached and len(res.points) == int(2 * 0.8 ** 3 / (4 * np.sqrt(2) * 0.1 ** 3))
    assert _brute_rho(res.points, Domain3.box(2, 1, 1)) == pytest.approx(res.rho)
    out = tmp_path / "p.csv"
    rc = cli.main(["poisson", "--dim", "3", "-n", "300", "-o", str(out), "--seed", "1", "--json",
                   "--eps", "0.75"])
    s = json.loads(capsys.readouterr().out)
    assert rc == 0 and s["dim"] == 3 and s["reached"]
    assert out.read_text().splitlines()[0] == "x,y,z"
    with pytest.raises(ValueError, match="has a z column"):   # 3D points are not read as 2D
        read_points(out)
    with pytest.raises(ValueError, match="no mask"):
        poisson_disk(10, dim=3, mask=np.ones((2, 2)))


@pytest.mark.parametrize("dom", [Domain3.torus(), Domain3.box(1, 2, 0.5)])
def test_dart_throwing3_keeps_its_distance(dom):
    p = dart_throwing3(400, dom, rel_radius=0.7, seed=np.random.default_rng(3))
    inset = 0.0 if dom.periodic else 0.7 * fcc_radius(400, dom.volume)
    assert p.shape == (400, 3) and np.all(p >= inset) and np.all(p <= dom.size - inset)
    assert _brute_rho(p, dom) >= 0.7


def test_tight_cluster_is_counted_not_hidden(engines):
    # 29 sites in a 1e-3 cube on the torus: nearly parallel planes, solved by linprog
    X = np.unique(0.3 + 1e-3 * np.random.default_rng(53697).random((29, 3)), axis=0)
    res = engines[True].solve(X)
    certified = certify_mis(X, res.centers, res.radii, Domain3.torus(), k=len(X) * 27)
    assert res.stats["fallback"] > 0
    assert np.count_nonzero(~certified) == res.stats["uncertified"]
    assert certify_mis(X, res.centers, res.radii, Domain3.torus(), k=len(X) * 27, tol=1e-7).all()
