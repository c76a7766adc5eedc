"""max_points_for_radius: the most points relaxation brings to a Poisson disk radius (Fig. 7)."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from diskpack_cl.measures import hexagonal_radius, min_distance, normalized_radius
from diskpack_cl.relax import max_points_for_radius

RADIUS = 0.8 * hexagonal_radius(100)  # rho 0.8 at n = 100, about 0.043


@pytest.fixture(scope="module")
def result():
    return max_points_for_radius(RADIUS, backend="exact", seed=3)


def test_reaches_the_radius_with_more_points(result):
    # the relaxation levels off near rho 0.92, i.e. n ~ 100 * (0.92 / 0.8)^2 = 132
    assert 100 < result.n <= 140
    assert len(result.points) == result.n
    assert min_distance(result.points) / 2.0 >= RADIUS
    assert result.achieved_radius >= RADIUS
    assert result.rho == pytest.approx(normalized_radius(result.points))


def test_search_brackets_the_answer(result):
    by_n = {t["n"]: t for t in result.trials}
    assert by_n[result.n]["reached"]
    # the search stops at a failure at n + 1 (or a target rho it does not try)
    assert result.n + 1 not in by_n or not by_n[result.n + 1]["reached"]
    assert all(t["reached"] == (t["rho"] >= t["target_rho"] * (1 - 1e-9)) for t in result.trials)


def test_deterministic_by_seed(result):
    again = max_points_for_radius(RADIUS, backend="exact", seed=3)
    assert again.n == result.n
    np.testing.assert_array_equal(again.points, result.points)


def test_bad_arguments():
    with pytest.raises(ValueError, match=r"radius must be in \(0, 0.25\), got 0.3"):
        max_points_for_radius(0.3)
    with pytest.raises(ValueError, match="start must be 'dart', 'random' or a callable"):
        max_points_for_radius(0.04, start="grid")


def test_an_invalid_certificate_raises(monkeypatch):
    """certified_k never hands back disks that failed their certificate."""
    from diskpack_cl import radii
    from diskpack_cl.domain import Domain
    from diskpack_cl.geometry import Certificate, CertificateError
    from diskpack_cl.radii import certified_k

    bad = Certificate(valid=False, min_gap=-1.0, pairs_checked=1, inside=True, disjoint=False)
    monkeypatch.setattr(radii, "certify_disks", lambda *a, **k: bad)
    with pytest.raises(CertificateError, match="failed their certificate") as info:
        certified_k([[1.0, 1.0], [3.0, 1.0]], np.ones(2), 4, 2, Domain.rect(4, 2))
    assert info.value.certificate is bad


@settings(max_examples=30)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 400), spread=st.sampled_from([1.0, 30.0, 1000.0]))
def test_certified_k_certificate_is_certify_disks_own(seed, n, spread):
    """certified_k certifies with the trees of its search for k: the certificate of
    certify_disks on its own, and k is largest_valid_k's shrunk by ulps."""
    from diskpack_cl.domain import Domain
    from diskpack_cl.geometry import certify_disks
    from diskpack_cl.radii import certified_k, largest_valid_k

    rng = np.random.default_rng(seed)
    C = rng.random((n, 2)) * (3.0, 2.0)
    r = spread ** -rng.random(n)
    assume(np.unique(C, axis=0).shape[0] == n)
    dom = Domain.rect(3.0, 2.0)
    k, radii, cert = certified_k(C, r, 3.0, 2.0, dom)
    assert cert == certify_disks(C, radii, dom)
    assert cert.valid and np.array_equal(radii, k * r)
    assert largest_valid_k(C, r, 3.0, 2.0) * (1 - 1e-12) <= k <= largest_valid_k(C, r, 3.0, 2.0)


@settings(max_examples=60)
@given(st.integers(1, 40), st.integers(1, 40), st.integers(0, 2**32 - 1),
       st.sampled_from(["random", "white", "black", "levels"]))
def test_detail_ell_is_the_scale_of_the_masked_copy(h, w, seed, kind):
    """detail_ell (the median of the pixels darker than 0.05 counted and bracketed,
    :func:`median_above`) gives the scale of the masked copy (white and black pictures
    too)."""
    from diskpack_cl import radii

    rng = np.random.default_rng(seed)
    gray = {"random": rng.random((h, w)), "white": np.ones((h, w)), "black": np.zeros((h, w)),
            "levels": rng.integers(0, 256, (h, w)) / 255.0}[kind]
    d = 1.0 - gray
    dark = d[d > 0.05]
    dmed = float(np.median(dark)) if dark.size else float(d.mean())
    expected = radii.detail_scale(float(d.sum()), 50, dmed)
    assert radii.detail_ell(gray, 50) == expected


@settings(max_examples=200)
@given(st.integers(0, 3000), st.integers(0, 2**32 - 1),
       st.sampled_from(["random", "levels", "ties", "skewed", "sorted", "nan", "inf"]),
       st.integers(1, 300), st.integers(1, 200), st.integers(1, 4), st.sampled_from([-1.0, 0.05, 0.5]))
def test_median_above_is_numpys_median_of_the_masked_copy(size, seed, kind, part, sample, cores, lo):
    """The bracketed median is np.median of the values above `lo`, bit for bit: runs of
    any length on one to four cores, samples from one value (brackets that miss the
    median's rank, and fall back) to many, ties at the median, NaN (never above `lo`),
    infinities (a sample with none above `lo` brackets them alone)."""
    from unittest import mock

    from diskpack_cl.radii import median_above

    rng = np.random.default_rng(seed)
    x = {"random": lambda: rng.random(size), "levels": lambda: rng.integers(0, 4, size) / 3.0,
         "ties": lambda: np.where(rng.random(size) < 0.5, 0.5, rng.random(size)),
         "skewed": lambda: rng.random(size) ** 8, "sorted": lambda: np.sort(rng.random(size)),
         "nan": lambda: np.where(rng.random(size) < 0.2, np.nan, rng.random(size)),
         "inf": lambda: np.where(rng.random(size) < 0.1, np.inf, rng.random(size))}[kind]()
    want = x[x > lo]
    with mock.patch("os.cpu_count", return_value=cores):
        got = median_above(x, lo, part=part, sample=sample)
    if want.size == 0:
        assert got is None
    else:
        assert got == float(np.median(want))
