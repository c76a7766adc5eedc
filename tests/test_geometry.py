"""Exact geometry (exact_mic, distances, certificates) against brute-force linprog references."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import reference as ref
from diskpack_cl.domain import Domain
from diskpack_cl.geometry import certify_disks, exact_mic

SETTINGS = settings(max_examples=30)
RTOL = 1e-9


@st.composite
def cells(draw, n_min=2, n_max=30):
    periodic = draw(st.booleans())
    dom = Domain.torus() if periodic else Domain.rect(draw(st.sampled_from([1.0, 3.0, 100.0])),
                                                      draw(st.sampled_from([1.0, 2.0, 60.0])))
    n = draw(st.integers(n_min, n_max))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    pts = rng.random((n, 2)) * (dom.width, dom.height)
    kind = draw(st.sampled_from(["voronoi", "power", "power-empty"]))
    spacing = np.sqrt(dom.area / n)
    w = None
    if kind == "power":
        w = (0.4 * spacing * rng.random(n)) ** 2
    elif kind == "power-empty":
        # a few heavy sites swallow their light neighbours: empty cells
        w = (0.1 * spacing * rng.random(n)) ** 2
        heavy = rng.random(n) < 0.3
        w[heavy] = (1.2 * spacing * (1 + rng.random(heavy.sum()))) ** 2
    return dom, pts, w


def _check_against_linprog(dom, pts, w, mic):
    scale = max(dom.width, dom.height)
    for i in range(len(pts)):
        r = ref.chebyshev_ref(pts, w, dom, i)
        assert mic.empty[i] == (r.radius < 0), i
        # an empty cell's LP value (how far below zero) depends, on a torus,
        # on how many periodic images enter (the reference takes 3 x 3, the
        # solver those within its margin); only its sign means anything
        if r.radius >= 0 or not dom.periodic:
            assert abs(mic.radii[i] - r.radius) <= RTOL * scale, (i, mic.radii[i], r.radius)
        if r.radius < 0:
            X = dom.wrap(pts) if dom.periodic else pts
            assert np.array_equal(mic.centers[i], X[i])
        elif r.unique:
            d = mic.centers[i] - r.center
            if dom.periodic:
                d -= np.round(d)
            assert np.hypot(*d) <= 1e-7 * scale, (i, mic.centers[i], r.center)


def _disk_inside_cell(dom, pts, w, centers, radii, empty):
    """Brute force: every other site image leaves the disk on i's side of its bisector."""
    X = dom.wrap(pts) if dom.periodic else np.asarray(pts, float)
    wv = np.zeros(len(X)) if w is None else w
    scale = max(dom.width, dom.height)
    pos, site = ref.images(X, dom)
    for i in np.flatnonzero(~empty):
        d = centers[i] - X[i]
        if dom.periodic:
            d -= np.round(d)
        c = X[i] + d
        a = pos - X[i]
        L = np.hypot(a[:, 0], a[:, 1])
        k = L > 0
        slack = (L[k] ** 2 - wv[site[k]] + wv[i]) / (2 * L[k]) - (a[k] @ d) / L[k] - radii[i]
        assert slack.min() >= -1e-10 * scale, (i, slack.min())
        if not dom.periodic:
            assert c[0] - radii[i] >= -1e-10 * scale and c[0] + radii[i] <= dom.width * (1 + 1e-12)
            assert c[1] - radii[i] >= -1e-10 * scale and c[1] + radii[i] <= dom.height * (1 + 1e-12)


@SETTINGS
@given(case=cells())
def test_exact_mic_matches_linprog(case):
    dom, pts, w = case
    p0 = pts.copy()
    w0 = None if w is None else w.copy()
    mic = exact_mic(pts, w, dom)
    assert np.array_equal(pts, p0)
    assert (w is None) or np.array_equal(w, w0)
    assert not np.may_share_memory(mic.centers, pts)
    _check_against_linprog(dom, pts, w, mic)
    _disk_inside_cell(dom, pts, w, mic.centers, mic.radii, mic.empty)


@SETTINGS
@given(case=cells(), seed=st.integers(0, 2**32 - 1))
def test_exact_mic_does_not_depend_on_the_estimate(case, seed):
    dom, pts, w = case
    rng = np.random.default_rng(seed)
    n = len(pts)
    base = exact_mic(pts, w, dom)
    bad_c = rng.random((n, 2)) * (dom.width, dom.height)
    bad_r = rng.random(n) * max(dom.width, dom.height) - 0.2 * max(dom.width, dom.height)
    est = (bad_c.copy(), bad_r.copy())
    mic = exact_mic(pts, w, dom, estimate=est)
    assert np.array_equal(est[0], bad_c) and np.array_equal(est[1], bad_r)
    scale = max(dom.width, dom.height)
    assert np.all(np.abs(mic.radii - base.radii) <= RTOL * scale)
    assert np.array_equal(mic.empty, base.empty)
    _check_against_linprog(dom, pts, w, mic)


@SETTINGS
@given(case=cells(), shift=st.sampled_from([-5.0, -0.01, 0.5, 3.0]))
def test_exact_mic_weight_shift_invariance(case, shift):
    """Adding a constant to every weight leaves the power diagram unchanged."""
    dom, pts, w = case
    w = np.zeros(len(pts)) if w is None else w
    scale = max(dom.width, dom.height)
    a = exact_mic(pts, w, dom)
    b = exact_mic(pts, w + shift * scale ** 2, dom)
    assert np.all(np.abs(a.radii - b.radii) <= RTOL * scale)


_CLUSTERED = """
import numpy as np
import reference as ref
from diskpack_cl.domain import Domain
from diskpack_cl.geometry import exact_mic
rng = np.random.default_rng(2)
dom = Domain.torus()
pts = rng.random((300, 2)) * 0.15
mic = exact_mic(pts, None, dom)
for i in np.argsort(mic.radii)[-8:]:
    r = ref.chebyshev_ref(pts, None, dom, i)
    assert abs(mic.radii[i] - r.radius) <= 1e-9, (i, mic.radii[i], r.radius)
"""


def test_exact_mic_clustered_points_on_torus():
    """Large empty regions: cells reach across the seam far beyond the mean spacing.

    Run in a child process capped at 3 GB of address space: exact_mic has
    been seen to allocate over 20 GB here, which must fail the test, not
    the machine.
    """
    import resource
    import subprocess
    import sys

    def cap():
        resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))

    import os

    # the child imports the oracles (tests/reference.py) from its working folder
    proc = subprocess.run([sys.executable, "-c", _CLUSTERED], capture_output=True, text=True,
                          timeout=120, preexec_fn=cap, cwd=os.path.dirname(__file__))
    assert proc.returncode == 0, proc.stderr[-2000:]


@pytest.mark.parametrize("pts", [[[0.2, 0.3], [0.7, 0.6]], [[0.5, 0.5]], [[0.1, 0.1], [0.5, 0.4], [0.8, 0.9]]])
def test_exact_mic_few_points_torus(pts):
    dom = Domain.torus()
    pts = np.array(pts)
    mic = exact_mic(pts, None, dom)
    _check_against_linprog(dom, pts, None, mic)


def test_exact_mic_empty_cell_known():
    pts = np.array([[0.25, 0.25], [0.26, 0.26], [0.75, 0.75], [0.5, 0.5]])
    w = np.array([0.05, 0.0, 0.05, 0.0])
    for dom in (Domain.torus(), Domain.rect(1, 1)):
        mic = exact_mic(pts, w, dom)
        assert mic.empty[1] and mic.radii[1] < 0
        assert np.array_equal(mic.centers[1], pts[1])
        assert ref.chebyshev_ref(pts, w, dom, 1).radius < 0
        assert not mic.empty[[0, 2]].any()


def test_exact_mic_bad_input():
    with pytest.raises(ValueError, match="points must have shape"):
        exact_mic(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="NaN or infinite"):
        exact_mic([[0.1, 0.2], [np.nan, 0.3]])
    with pytest.raises(ValueError, match="weights must be n finite numbers"):
        exact_mic([[0.1, 0.2], [0.5, 0.3]], [0.0])



@SETTINGS
@given(case=cells(), seed=st.integers(0, 2**32 - 1), with_estimate=st.booleans())
def test_exact_mic_cells_matches_the_full_solve(case, seed, with_estimate):
    """Solving a subset of cells gives those cells' rows of the full solve, in the asked order."""
    dom, pts, w = case
    rng = np.random.default_rng(seed)
    n = len(pts)
    est = None
    if with_estimate:
        est = (rng.random((n, 2)) * (dom.width, dom.height), rng.random(n) * 0.2 - 0.05)
    full = exact_mic(pts, w, dom, estimate=est)
    sub = rng.permutation(n)[: rng.integers(1, n + 1)]
    part = exact_mic(pts, w, dom, estimate=est, cells=sub)
    assert part.centers.shape == (len(sub), 2) and part.radii.shape == part.empty.shape == (len(sub),)
    if not dom.periodic:   # no periodic margin to grow: every cell's solve is the full solve's
        assert np.array_equal(part.radii, full.radii[sub])
        assert np.array_equal(part.centers, full.centers[sub])
    scale = max(dom.width, dom.height)
    assert np.all(np.abs(part.radii - full.radii[sub]) <= RTOL * scale)
    assert np.array_equal(part.empty, full.empty[sub])
    assert part.stats["empty"] == int(full.empty[sub].sum())


def test_exact_mic_cells_few_and_none():
    pts = np.random.default_rng(3).random((400, 2))
    w = (0.02 * np.random.default_rng(4).random(400)) ** 2
    full = exact_mic(pts, w)
    one = exact_mic(pts, w, cells=np.array([17]))
    assert np.abs(one.radii[0] - full.radii[17]) <= 1e-12
    assert one.stats["rounds"] >= 1
    none = exact_mic(pts, w, cells=np.zeros(0, np.intp))
    assert none.centers.shape == (0, 2) and none.radii.shape == (0,)
    assert none.stats["rounds"] == 0


def test_exact_mic_cells_bad_input():
    pts = [[0.1, 0.2], [0.5, 0.3], [0.7, 0.9]]
    with pytest.raises(ValueError, match=r"cells must be a 1-D array of site indices, got shape \(1, 2\)"):
        exact_mic(pts, cells=[[0, 1]])
    with pytest.raises(ValueError, match="dtype float64"):
        exact_mic(pts, cells=[0.0, 1.0])
    with pytest.raises(ValueError, match=r"cells must be site indices in \[0, 3\), got 0 .. 3"):
        exact_mic(pts, cells=[0, 3])
    with pytest.raises(ValueError, match=r"got -1 .. 1"):
        exact_mic(pts, cells=[1, -1])

def test_certify_known_disks():
    dom = Domain.rect(4, 2)
    C = np.array([[1.0, 1.0], [3.0, 1.0]])
    assert certify_disks(C, [0.9, 0.9], dom).valid
    assert certify_disks(C, [1.0, 1.0], dom).valid is False          # touching closed disks
    assert not certify_disks(C, [1.0, 1.0 + 1e-9], dom).valid          # overlap by 1e-9
    # pokes out of the rectangle by 1e-9
    cert = certify_disks(C, [0.5, 1.0 + 1e-9], dom)
    assert not cert.valid and not cert.inside and cert.disjoint
    assert certify_disks(C, [0.5, 1.0], dom).inside                   # touching the edge is inside
    # torus: overlap across the seam
    t = Domain.torus()
    assert certify_disks([[0.05, 0.5], [0.95, 0.5]], [0.049, 0.049], t).valid
    assert not certify_disks([[0.05, 0.5], [0.95, 0.5]], [0.05, 0.05 + 1e-9], t).valid
    assert not certify_disks(C, [-0.1, 0.5], dom).valid
    assert not certify_disks(C, [np.nan, 0.5], dom).valid
    assert certify_disks(np.zeros((0, 2)), np.zeros(0), dom).valid


@settings(max_examples=40)
@given(n=st.integers(1, 25), seed=st.integers(0, 2**32 - 1), periodic=st.booleans(),
       size=st.sampled_from([0.02, 0.1, 0.3]))
def test_certify_matches_brute_force(n, seed, periodic, size):
    rng = np.random.default_rng(seed)
    dom = Domain.torus() if periodic else Domain.rect(1.0, 1.5)
    C = rng.random((n, 2)) * (dom.width, dom.height)
    r = rng.random(n) * size
    c0, r0 = C.copy(), r.copy()
    cert = certify_disks(C, r, dom)
    assert cert.valid == ref.certify_ref(C, r, dom)
    assert np.array_equal(C, c0) and np.array_equal(r, r0)


@SETTINGS
@given(case=cells())
def test_exact_mic_disks_certify(case):
    """Each MIC lies in its own cell, cells do not overlap: disks shrunk a hair certify."""
    dom, pts, w = case
    mic = exact_mic(pts, w, dom)
    keep = ~mic.empty
    assume(keep.any())
    scale = max(dom.width, dom.height)
    r = np.maximum(mic.radii[keep] - 1e-9 * scale, 0)
    assert certify_disks(mic.centers[keep], r, dom).valid


@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), periodic=st.booleans(), n=st.integers(2, 60),
       spread=st.sampled_from([1.0, 30.0, 1000.0]))
def test_certify_disks_against_all_pairs(seed, periodic, n, spread):
    """Octave trees find the closest pair of a brute-force scan, radii spanning up to 1000x."""
    rng = np.random.default_rng(seed)
    dom = Domain.torus() if periodic else Domain.rect(3.0, 2.0)
    C = rng.random((n, 2)) * (dom.width, dom.height)
    r = 0.3 / np.sqrt(n) * spread ** -rng.random(n) * rng.uniform(0.3, 2.0)   # overlaps about half the time
    cert = certify_disks(C, r, dom)
    d = C[:, None, :] - C[None, :, :]
    if periodic:
        d -= np.round(d)
    gap = np.hypot(d[..., 0], d[..., 1]) - r[:, None] - r[None, :]
    gap = gap[np.triu_indices(n, 1)].min()
    assert cert.disjoint == (gap > 0)
    if not periodic:
        edge = np.minimum.reduce([C[:, 0], 3.0 - C[:, 0], C[:, 1], 2.0 - C[:, 1]]) - r
        assert cert.inside == (edge.min() >= 0)
        gap = min(gap, edge.min())
    # min_gap is over the checked pairs (and edges): exact when disks
    # overlap (every overlapping pair is checked), a bound from above otherwise
    if gap <= 0:
        assert cert.min_gap == pytest.approx(gap, abs=1e-12)
    else:
        assert cert.min_gap >= gap - 1e-12


def test_torus_with_a_large_empty_region_is_solved_exactly():
    """Sites in one quarter of the torus and two alone in the rest: the cells
    on the cluster's rim reach across most of a period. The images needed
    are bounded (no cell is bounded by images further than the diagonal of
    a period plus sqrt(wmax)), so the solve finishes (it once grew its image
    margin without bound and stalled in linprog) and agrees with linprog on
    every image of the 3 x 3 periods."""
    rng = np.random.default_rng(3)
    tor = Domain.torus()
    pts = np.vstack([0.5 * rng.random((600, 2)), [[0.75, 0.75], [0.8, 0.6]]])
    m = exact_mic(pts, None, tor)
    assert m.stats["margin"] <= np.sqrt(2) + 1e-12
    for i in [600, 601, *np.argsort(-m.radii)[2:6]]:
        want = ref.chebyshev_ref(pts, None, tor, i)
        assert m.radii[i] == pytest.approx(want.radius, abs=1e-12)


def test_certificate_searches_the_whole_band_of_an_octave():
    """Two disks of radius 1.9 overlap at distance 3.5; a 1.0 disk shares their octave
    [1, 2): the pair search must reach r_i + the octave's largest radius, not its smallest."""

    C = np.array([[5.0, 5.0], [8.5, 5.0], [5.0, 12.0]])
    cert = certify_disks(C, [1.9, 1.9, 1.0], Domain.rect(20.0, 20.0))
    assert not cert.valid and not cert.disjoint
    assert cert.min_gap == pytest.approx(3.5 - 3.8)
    assert certify_disks(C, [1.7, 1.7, 1.0], Domain.rect(20.0, 20.0)).valid


@settings(max_examples=60)
@given(n=st.integers(1, 120), m=st.integers(1, 60), seed=st.integers(0, 2**16),
       spread=st.sampled_from([0.0, 0.01, 0.3, 3.0]), k=st.sampled_from([1, 2, 16]))
def test_query_pairs_finds_every_point_inside_each_radius(n, m, seed, spread, k):
    # radii from none to the whole set (the 4k re-asks), equal or spread over
    # orders of magnitude (the search stops at the largest), clustered points
    from scipy.spatial import cKDTree

    from diskpack_cl.geometry import _query_pairs

    rng = np.random.default_rng(seed)
    pts = np.round(rng.random((n, 2)) * 4, 1)          # lattice: ties and duplicates
    centers = np.round(rng.random((m, 2)) * 4, 1)
    radius = 0.3 * np.exp(spread * rng.standard_normal(m))
    rows, idx = _query_pairs(cKDTree(pts), centers, radius, k=k)
    d = np.hypot(*(centers[:, None, :] - pts[None, :, :]).transpose(2, 0, 1))
    want = set(zip(*np.nonzero(d <= radius[:, None] * (1 + 1e-12))))
    assert len(rows) == len(want) and set(zip(rows.tolist(), idx.tolist())) == want


def test_certify_disks_with_a_subnormal_radius():
    """The octaves of radii are a difference of logarithms: the ratio to a subnormal radius
    overflowed (a RuntimeWarning, and every disk in one wrong octave)."""
    from diskpack_cl.geometry import radius_octaves

    r = np.array([4.5e-320, 1.5, 1.5, 3.0])
    assert [c.tolist() for c in radius_octaves(r)] == [[0], [1, 2], [3]]
    assert certify_disks([[4, 4], [14, 4], [24, 4], [34, 9]], r, Domain.rect(40, 30)).valid


def _spread_disks(seed, n, spread):
    """Centres in a 3 x 2 rectangle and radii spanning `spread` (several octaves)."""
    rng = np.random.default_rng(seed)
    C = rng.random((n, 2)) * (3.0, 2.0)
    return C, 0.3 / np.sqrt(n) * spread ** -rng.random(n) * rng.uniform(0.3, 2.0)


@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 300), spread=st.sampled_from([1.0, 30.0, 1000.0]),
       scale=st.sampled_from([1.0, 0.5, 0.37, 1.0 - 4 * np.finfo(float).eps]), other=st.booleans())
def test_certify_disks_with_octave_trees_is_the_same(seed, n, spread, scale, other):
    """The octave trees certified_k hands over (of radii proportional to these, or with
    `other` of unrelated radii, which must not be used) give the certificate made anew."""
    from scipy.spatial import cKDTree

    from diskpack_cl.geometry import radius_octaves

    C, r = _spread_disks(seed, n, spread)
    base = _spread_disks(seed + 1, n, 1000.0)[1] if other else r
    classes = radius_octaves(base)
    trees = [cKDTree(C[c]) for c in classes]
    dom = Domain.rect(3.0, 2.0)
    assert certify_disks(C, r * scale, dom, octaves=(classes, trees)) == certify_disks(C, r * scale, dom)


@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 300), spread=st.sampled_from([1.0, 30.0, 1000.0]),
       scale=st.sampled_from([1.0, 0.5, 0.37, 1.0 - 4 * np.finfo(float).eps]),
       reach=st.sampled_from([1.0, 1.0 + 1e-9, 1.5, 3.0, 0.9, 0.5]))
def test_certify_disks_with_searched_pairs_is_the_same(seed, n, spread, scale, reach):
    """The pairs of the octaves certified_k searched (for disks of `reach` times the radii,
    distinct centres only) give the certificate made anew: a search that reached further
    is filtered to this one's, one that reached less far (reach < 1) is searched again."""
    from scipy.spatial import cKDTree

    from diskpack_cl.geometry import radius_octaves

    C, r = _spread_disks(seed, n, spread)
    classes = radius_octaves(r)
    assume(len(classes) > 1 or spread == 1.0)
    trees = [cKDTree(C[c]) for c in classes]
    rmax = [reach * scale * r[c].max() for c in classes]
    searched = {}
    for a in range(len(classes)):
        for b in range(a, len(classes)):
            far = (rmax[a] + rmax[b]) * (1 + 1e-9)
            sdm = trees[a].sparse_distance_matrix(trees[b], far, output_type="ndarray")
            i, j = classes[a][sdm["i"]], classes[b][sdm["j"]]
            searched[a, b] = (far, i[i != j], j[i != j], sdm["v"][i != j])
    dom = Domain.rect(3.0, 2.0)
    assert certify_disks(C, r * scale, dom, octaves=(classes, trees, searched)) == \
        certify_disks(C, r * scale, dom)


@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 400), spread=st.sampled_from([1.0, 30.0, 1000.0]))
@settings(max_examples=30)
def test_certified_k_has_the_certificate_made_anew(seed, n, spread):
    """certified_k certifies with the pairs of its own search for k: the certificate of its
    disks made anew is the same."""
    from diskpack_cl.radii import certified_k

    C, r = _spread_disks(seed, n, spread)
    dom = Domain.rect(3.0, 2.0)
    k, radii, cert = certified_k(C, r, 3.0, 2.0, dom)
    assume(k > 0)
    assert cert == certify_disks(C, radii, dom)


@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), periodic=st.booleans(), n=st.integers(2, 80),
       spread=st.sampled_from([1.0, 30.0, 1000.0]))
def test_certify_disks_checks_the_pairs_each_disk_asks_for(seed, periodic, n, spread):
    """The pairs of the octaves' dual-tree searches are those a query of each disk finds
    within its radius plus the largest radius of each octave not below its own (the
    certificate's pairs_checked), each once, against a scan of all pairs."""
    from diskpack_cl.geometry import radius_octaves

    rng = np.random.default_rng(seed)
    dom = Domain.torus() if periodic else Domain.rect(3.0, 2.0)
    C = rng.random((n, 2)) * (dom.width, dom.height)
    r = 0.3 / np.sqrt(n) * spread ** -rng.random(n) * rng.uniform(0.3, 2.0)
    octave = np.empty(n, int)
    for o, c in enumerate(radius_octaves(r)):
        octave[c] = o
    rmax = np.array([r[octave == o].max() for o in range(octave.max() + 1)])
    d = C[:, None, :] - C[None, :, :]
    if periodic:
        d -= np.round(d)
    dist = np.hypot(d[..., 0], d[..., 1])
    i, j = np.indices((n, n))
    asks = (octave[i] < octave[j]) | ((octave[i] == octave[j]) & (i < j))
    within = dist <= (r[:, None] + rmax[octave][None, :]) * (1 + 1e-12)
    assert certify_disks(C, r, dom).pairs_checked == int(np.sum(asks & within))


def test_the_pair_search_keeps_the_callers_overflow_handling():
    """certify_disks' pair search runs on a pool of threads; huge radii overflow there as in
    the caller, under the caller's np.errstate (a reader's, which ignores it: numpy 1.x's
    error state is per thread, and the pool's threads warned)."""
    import warnings

    from diskpack_cl import certify_disks
    from diskpack_cl.domain import Domain

    p = np.array([[1.0, 1.0], [3.0, 1.0], [2.0, 1.5]])
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("error")
        cert = certify_disks(p, np.full(3, 1e308), Domain.rect(4, 2))
    assert not cert.valid
