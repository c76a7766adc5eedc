import warnings

import numpy as np
import pytest

from diskpack_cl.measures import hexagonal_radius
from diskpack_cl.sampling import DartThrowingWarning, bridson, dart_throwing, random_points


def _min_torus_distance(p):
    """Brute-force minimum pairwise distance on the unit torus (minimum image)."""
    d = p[:, None, :] - p[None, :, :]
    d -= np.round(d)
    dist = np.sqrt((d ** 2).sum(-1))
    np.fill_diagonal(dist, np.inf)
    return dist.min()


def _rho(p):
    return _min_torus_distance(p) / 2 / hexagonal_radius(len(p))


@pytest.mark.parametrize("n", [1, 2, 3, 17, 300])
@pytest.mark.parametrize("rel", [0.5, 0.74])
def test_dart_throwing_count_range_and_distance(n, rel):
    p = dart_throwing(n, rel_radius=rel, seed=n)
    assert p.shape == (n, 2) and p.dtype == np.float64
    assert ((p >= 0) & (p < 1)).all()
    if n > 1:
        r = rel * hexagonal_radius(n)
        assert _min_torus_distance(p) >= 2 * r


def test_dart_throwing_deterministic_by_seed():
    a = dart_throwing(500, seed=7)
    b = dart_throwing(500, seed=7)
    c = dart_throwing(500, seed=8)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    g = np.random.default_rng(7)
    np.testing.assert_array_equal(dart_throwing(500, seed=g), a)


def test_dart_throwing_default_rho_near_074():
    rhos = []
    for seed in range(3):
        p, info = dart_throwing(1024, seed=seed, full_output=True)
        assert info["shrinks"] == 0 and info["rel_radius"] == 0.74
        assert info["rho"] == pytest.approx(_rho(p), rel=1e-12)
        rhos.append(info["rho"])
    assert 0.74 <= min(rhos) and max(rhos) < 0.75


def test_dart_throwing_fallback_shrinks_and_warns():
    with pytest.warns(DartThrowingWarning) as caught:
        p, info = dart_throwing(200, rel_radius=0.95, seed=1, full_output=True)
    first, last = (str(w.message) for w in caught)
    # said at once, before any dart (0.95 is past saturation), and summed up at the end
    assert first.startswith("relative radius 0.95 is above maximal dart throwing's saturation")
    assert last.startswith("dart throwing could not place 200 points at relative radius 0.95; shrank it")
    assert p.shape == (200, 2)
    assert info["shrinks"] >= 1 and info["rel_radius"] < 0.95
    assert info["rel_radius"] == pytest.approx(0.95 * 0.98 ** info["shrinks"])
    assert _min_torus_distance(p) >= 2 * info["radius"]


def test_dart_throwing_says_when_it_saturates():
    # below the known saturation, the first saturation is said when it happens
    with pytest.warns(DartThrowingWarning) as caught:
        dart_throwing(100, rel_radius=0.7, seed=0, max_attempts=50, shrink=0.5)
    assert str(caught[0].message).startswith("dart throwing saturated at relative radius 0.7 with ")


def test_dart_throwing_small_budget_falls_back():
    with pytest.warns(DartThrowingWarning):
        p = dart_throwing(100, rel_radius=0.7, seed=0, max_attempts=50, shrink=0.5)
    assert p.shape == (100, 2)


def test_dart_throwing_no_warning_normally():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        dart_throwing(1000, seed=3)


@pytest.mark.parametrize("kwargs, message", [
    ({"n": 0}, r"n must be at least 1, got 0"),
    ({"n": 2.5}, r"n must be an integer"),
    ({"n": 10, "rel_radius": 1.0}, r"rel_radius must be in \(0, 1\), got 1\.0"),
    ({"n": 10, "rel_radius": 0}, r"rel_radius must be in \(0, 1\)"),
    ({"n": 10, "shrink": 1.0}, r"shrink must be in \(0, 1\)"),
    ({"n": 10, "max_attempts": 0}, r"max_attempts must be positive"),
])
def test_dart_throwing_bad_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        dart_throwing(**kwargs)


def test_dart_throwing_large_n_is_valid():
    from scipy.spatial import cKDTree

    n = 20000
    p = dart_throwing(n, seed=5)
    d, _ = cKDTree(p, boxsize=1.0).query(p, k=2)
    assert len(p) == n and d[:, 1].min() >= 2 * 0.74 * hexagonal_radius(n)


def test_random_points():
    a = random_points(100, seed=1)
    assert a.shape == (100, 2) and ((a >= 0) & (a < 1)).all()
    np.testing.assert_array_equal(a, random_points(100, seed=1))
    with pytest.raises(ValueError, match="n must be at least 1"):
        random_points(0)


def test_bridson_radius_mode_is_maximal_poisson_disk():
    radius = 0.03
    p = bridson(radius=radius, seed=2)
    assert _min_torus_distance(p) >= 2 * radius
    # no room left for another disk: a fine probe grid is covered (Bridson is near-maximal)
    g = (np.stack(np.meshgrid(np.arange(60), np.arange(60)), -1).reshape(-1, 2) + 0.5) / 60
    d = g[:, None, :] - p[None, :, :]
    d -= np.round(d)
    nearest = np.sqrt((d ** 2).sum(-1)).min(1)
    assert (nearest < 2 * radius).mean() > 0.97


def test_bridson_n_mode():
    p = bridson(400, seed=4)
    assert p.shape == (400, 2) and ((p >= 0) & (p < 1)).all()
    assert 0.6 < _rho(p) < 0.8
    np.testing.assert_array_equal(p, bridson(400, seed=4))
    with pytest.raises(ValueError, match="give exactly one of n or radius"):
        bridson()
    with pytest.raises(ValueError, match="give exactly one of n or radius"):
        bridson(10, radius=0.1)


def test_first_come_matches_sequential_loop():
    from diskpack_cl.sampling import first_come

    rng = np.random.default_rng(0)
    cand = rng.random((400, 2))
    d = 0.06
    kept = []
    for i, c in enumerate(cand):  # one dart at a time
        q = cand[kept] - c
        q -= np.round(q)
        if not kept or (np.sqrt((q ** 2).sum(1)) >= d).all():
            kept.append(i)
    mask = first_come(cand, d)
    assert np.flatnonzero(mask).tolist() == kept
