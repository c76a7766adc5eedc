"""PoissonDisk as scipy.stats.qmc's engine: scipy's own tests, and the radius across draws."""

from types import SimpleNamespace

import numpy as np
import pytest
import scipy
from hypothesis import assume, given, settings, strategies as st
from scipy.spatial.distance import pdist
from scipy.stats import qmc

from diskpack_cl import PoissonDisk

# scipy's tests of its engines, as the installed scipy ships them (1.13 and later do)
scipy_tests = pytest.importorskip(
    "scipy.stats.tests.test_qmc",
    reason=f"scipy {scipy.__version__} ships no scipy.stats.tests.test_qmc")


#: scipy's tests that fill 3D boxes: the 3D packing needs a device (the host alone solves
#: every cell and takes minutes), so without one they skip as the OpenCL tests do.
PACKS_3D = {"test_mindist", "test_sample_inside_lower_bounds", "test_sample_inside_upper_bounds"}


class TestScipyPoisson(scipy_tests.TestPoisson):
    """scipy's ``TestPoisson`` (and the ``QMCEngineTests`` it inherits) on our engine."""

    qmce = PoissonDisk

    @pytest.fixture(autouse=True)
    def _our_engine(self, request, monkeypatch):
        # a few of scipy's tests name qmc.PoissonDisk instead of the class attribute
        monkeypatch.setattr(qmc, "PoissonDisk", PoissonDisk)
        if request.node.originalname in PACKS_3D:
            request.getfixturevalue("ctx")


@pytest.mark.skipif(not hasattr(scipy_tests, "test_deterministic"),
                    reason=f"scipy {scipy.__version__}'s test_qmc has no test_deterministic")
def test_scipy_deterministic():
    """scipy's ``test_deterministic`` (every engine's seeding) on our engine."""
    scipy_tests.test_deterministic(PoissonDisk)


def _bounds(d, data):
    lower = np.array(data.draw(st.lists(st.floats(-5, 5), min_size=d, max_size=d)))
    span = np.array(data.draw(st.lists(st.floats(0.5, 2), min_size=d, max_size=d)))
    return lower, lower + span


DRAWS = dict(data=st.data(), seed=st.integers(0, 2 ** 32 - 1),
             draws=st.lists(st.integers(0, 60), min_size=1, max_size=4))


@settings(max_examples=8)
@given(**DRAWS)
def test_draws_keep_the_radius_and_the_bounds_2d(data, seed, draws):
    _check_draws(2, data.draw(st.floats(0.12, 0.3)), data, seed, draws)


@settings(max_examples=6)
@given(**DRAWS)
def test_draws_keep_the_radius_and_the_bounds_3d(ctx, data, seed, draws):
    _check_draws(3, data.draw(st.floats(0.25, 0.5)), data, seed, draws)


def _check_draws(d, radius, data, seed, draws):
    """Successive draws and a fill: at most what was asked, inside the box, the radius
    apart from every point before, the same again from the same seed."""
    lower, upper = _bounds(d, data)
    eng = PoissonDisk(d, radius=radius, rng=seed, l_bounds=lower, u_bounds=upper)
    parts = [eng.random(n) for n in draws] + [eng.fill_space()]
    assert all(len(p) <= n for p, n in zip(parts, draws))
    pts = np.vstack(parts)
    assert pts.shape[1] == d and eng.num_generated == len(pts)
    assert np.all((pts > lower) & (pts < upper))
    assert len(pts) < 2 or pdist(pts).min() >= radius
    again = PoissonDisk(d, radius=radius, rng=seed, l_bounds=lower, u_bounds=upper)
    assert np.array_equal(np.vstack([again.random(n) for n in draws] + [again.fill_space()]), pts)


def test_random_hands_out_what_fits_and_no_more():
    eng = PoissonDisk(2, radius=0.05, rng=0)
    first = eng.random(1000)
    assert 250 < len(first) < 1000 and pdist(first).min() >= 0.05
    assert eng.random(5).shape == (0, 2) and eng.fill_space().shape == (0, 2)
    assert np.array_equal(eng.reset().random(7), first[:7])


def test_more_and_closer_to_the_walls_than_scipy():
    ours = PoissonDisk(2, radius=0.05, seed=1).fill_space()
    theirs = qmc.PoissonDisk(2, radius=0.05, seed=1).fill_space()
    assert len(ours) > 1.1 * len(theirs)
    gap = np.minimum(ours, 1 - ours).min(axis=0)   # nearest point to each pair of walls
    assert np.all(gap < 0.05 / 4)


def test_other_dimensions_are_scipys():
    for d in (1, 4):
        ours = PoissonDisk(d, radius=0.3, seed=5).random(20)
        assert np.array_equal(ours, qmc.PoissonDisk(d, radius=0.3, seed=5).random(20))


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(d=2, hypersphere="edge"), ValueError, "'edge' is not a valid hypersphere"),
    (dict(d=2, ncandidates=-1), ValueError, "ncandidates must be a non-negative integer"),
    (dict(d=2, radius=0.0), ValueError, "radius must be positive and finite"),
    (dict(d=2, l_bounds=[0, 0, 0]), ValueError, "must be broadcastable"),
    (dict(d=2, u_bounds=[1, -1]), ValueError, "Bounds are not consistent"),
    (dict(d=2, optimization="best"), ValueError, "'best' is not a valid optimization"),
    (dict(d=-1), ValueError, "d must be a non-negative integer"),
    (dict(d=2, torus=True), TypeError, "unexpected keyword argument 'torus'"),
    (dict(d=2, rng=1, seed=1), TypeError, "got multiple values for argument now known as"),
])
def test_bad_arguments_raise_at_construction(kwargs, error, match):
    with pytest.raises(error, match=match):
        PoissonDisk(**kwargs)


def test_a_packing_that_stops_short_still_keeps_the_radius(monkeypatch):
    import diskpack_cl.qmc

    def stopped_short(*, box, **kwargs):   # uniform points: no relaxation at all
        pts = np.random.default_rng(0).random((400, 2)) * box
        return SimpleNamespace(points=pts, min_distance=pdist(pts).min())

    monkeypatch.setattr(diskpack_cl.qmc, "poisson_disk", stopped_short)
    pts = PoissonDisk(2, radius=0.05, rng=0).fill_space()
    assert len(pts) > 50 and pdist(pts).min() >= 0.05


@pytest.mark.parametrize("bounds", [
    dict(l_bounds=[0, 1], u_bounds=[1, 1]),            # an empty box: no room at all
    dict(l_bounds=[0.5, 0.5], u_bounds=0.5),
])
def test_empty_bounds_are_refused(bounds):
    with pytest.raises(ValueError, match="Bounds are not consistent"):
        PoissonDisk(2, **bounds)


@pytest.mark.parametrize("bounds, match", [
    (dict(l_bounds=[-np.inf, 0]), r"must be finite, got l_bounds=\[-inf"),
    (dict(u_bounds=[1, np.nan]), r"must be finite, got .*u_bounds=\[ 1. nan\]"),
    (dict(l_bounds=[-1e308, 0], u_bounds=[1e308, 1]), "overflows float64"),
    (dict(l_bounds=["a", 0]), "must be numbers, got l_bounds=\\['a', 0\\]"),
])
def test_bounds_that_are_not_finite_numbers_are_refused(bounds, match):
    with pytest.raises(ValueError, match=match):
        PoissonDisk(2, **bounds)


@pytest.mark.parametrize("n, error, match", [
    (-1, ValueError, "n must be a non-negative integer, got -1"),
    (2.5, TypeError, "n must be an integer, got 2.5"),
    ("3", TypeError, "n must be an integer, got '3'"),
])
def test_a_bad_count_is_refused_and_counts_nothing(n, error, match):
    eng = PoissonDisk(2, radius=0.1, rng=0)
    first = eng.random(3)
    with pytest.raises(error, match=match):
        eng.random(n)
    assert eng.num_generated == 3
    assert np.array_equal(np.vstack([first, eng.random(np.int64(4))]),
                          PoissonDisk(2, radius=0.1, rng=0).random(7))


@settings(max_examples=12)
@given(exponent=st.integers(0, 15), negative=st.booleans(), radius=st.floats(0.08, 0.3),
       seed=st.integers(0, 2 ** 32 - 1))
def test_the_radius_holds_far_from_the_origin(exponent, negative, radius, seed):
    """Rounding into the caller's coordinates (8 values a unit at 1e15) keeps the radius."""
    lower = np.full(2, (-1.0 if negative else 1.0) * 10.0 ** exponent)
    eng = PoissonDisk(2, radius=radius, rng=seed, l_bounds=lower, u_bounds=lower + 1)
    pts = eng.fill_space()
    assert len(pts) >= 2 and eng.num_generated == len(pts)
    assert np.all((pts >= lower) & (pts <= lower + 1))
    assert pdist(pts).min() >= radius


def test_a_few_points_of_a_huge_box_pack_nothing(monkeypatch):
    import diskpack_cl.qmc

    def no_packing(**kwargs):
        raise AssertionError("packed the whole box for 10 points")

    monkeypatch.setattr(diskpack_cl.qmc, "poisson_disk", no_packing)
    eng = PoissonDisk(2, radius=1e-4, rng=0)   # ~7e7 packed points, 69 GiB to pack
    pts = np.vstack([eng.random(10), eng.random(1000)])
    assert pts.shape == (1010, 2) and eng.num_generated == 1010
    assert np.all((pts >= 0) & (pts <= 1)) and pdist(pts).min() >= 1e-4
    assert np.array_equal(eng.reset().random(10), pts[:10])


@settings(max_examples=6)
@given(draws=st.lists(st.integers(1, 40), min_size=1, max_size=3),
       seed=st.integers(0, 2 ** 32 - 1), radius=st.floats(0.03, 0.06))
def test_darts_then_the_packing_keep_the_radius(draws, seed, radius):
    import diskpack_cl.qmc

    eng = PoissonDisk(2, radius=radius, rng=seed, l_bounds=[-1, 2], u_bounds=[0.5, 3])
    assume(sum(draws) <= diskpack_cl.qmc.DART_SHARE * eng.capacity)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(diskpack_cl.qmc, "DART_FROM", 2)   # darts in a box this small
        mp.setattr(diskpack_cl.qmc, "poisson_disk", None)   # and nothing packed for them
        parts = [eng.random(n) for n in draws]
    parts.append(eng.fill_space())
    pts = np.vstack(parts)
    assert [len(p) for p in parts[:-1]] == draws and eng.num_generated == len(pts)
    assert len(parts[-1]) > 2 * sum(draws)   # the packing fills the rest of the box
    assert pdist(pts).min() >= radius


def test_filling_a_box_that_memory_cannot_hold_names_the_size(monkeypatch):
    import diskpack_cl.memory
    import diskpack_cl.qmc
    from diskpack_cl.memory import MemoryLimit

    monkeypatch.setattr(diskpack_cl.memory, "available_memory", lambda: 2 ** 30)
    monkeypatch.setattr(diskpack_cl.qmc, "poisson_disk", None)   # never reached
    eng = PoissonDisk(2, radius=1e-4, rng=0)
    assert len(eng.random(10)) == 10
    with pytest.raises(MemoryLimit, match=r"points need about 6\d.\d GiB.*a larger radius"):
        eng.fill_space()


@pytest.mark.parametrize("kwargs, match", [
    (dict(d=4, l_bounds=[-np.inf, 0, 0, 0]), "must be finite, got l_bounds"),
    (dict(d=1, radius=np.nan), "radius must be positive and finite, got nan"),
    (dict(d=4, radius=-1.0), "radius must be positive and finite, got -1.0"),
    (dict(d=2.0), "d must be a non-negative integer value, got 2.0"),
])
def test_other_dimensions_are_checked_as_the_packed_ones(kwargs, match):
    """scipy's engine, which draws them, failed on these with 'negative dimensions are not
    allowed'."""
    with pytest.raises(ValueError, match=match):
        PoissonDisk(**kwargs)
