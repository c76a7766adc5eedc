"""Box point sets in analyze (diskpack_cl.box_analysis): the windowed sums against brute
force, white noise at 1 off the window's block, no wrap for rho, the peak where it belongs."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import reference as ref
from diskpack_cl import analysis
from diskpack_cl.box_analysis import box_measures, box_periodogram, box_radial
from diskpack_cl.domain import Domain


def _brute(u, w, kmax):
    k = np.arange(-kmax, kmax + 1)
    P = np.empty((k.size, k.size))
    for iy, ky in enumerate(k):
        for ix, kx in enumerate(k):
            s = np.sum(w * np.exp(-2j * np.pi * (kx * u[:, 0] + ky * u[:, 1])))
            P[iy, ix] = abs(s) ** 2 / np.sum(w * w)
    return P


@settings(max_examples=25)
@given(n=st.integers(1, 60), seed=st.integers(0, 2**32 - 1), kmax=st.integers(1, 7))
def test_weighted_sums_direct_and_nufft_match_brute_force(n, seed, kmax):
    rng = np.random.default_rng(seed)
    u, w = rng.random((n, 2)), rng.random(n) + 0.01
    want = _brute(u, w, kmax)
    np.testing.assert_allclose(analysis._direct_power(u, kmax, weights=w), want, rtol=1e-9,
                               atol=1e-9 * want.max())
    np.testing.assert_allclose(analysis._nufft_power(u, kmax, weights=w), want, rtol=0,
                               atol=1e-7 * want.max())


def test_box_periodogram_is_the_hann_weighted_sum_with_the_block_cleared():
    pts = np.random.default_rng(4).random((80, 2)) * (3.0, 1.5)
    freqs, P = box_periodogram(pts, (3.0, 1.5), kmax=6)
    u = pts / (3.0, 1.5)
    w = (np.sin(np.pi * u[:, 0]) * np.sin(np.pi * u[:, 1])) ** 2
    want = _brute(u, w, 6)
    want[5:8, 5:8] = 0.0
    np.testing.assert_allclose(P, want, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("box", [(1.0, 1.0), (2.0, 1.0), (1.0, 3.0)])
def test_white_noise_has_power_one_off_the_window_block(box):
    """The Hann window leaks the mean only into max(|kx|, |ky|) <= 1: elsewhere uniform
    random points have expected power exactly 1 (the torus periodogram of a box set would
    show the walls as a seam at low frequencies)."""
    rng = np.random.default_rng(0)
    sets = [rng.random((1500, 2)) * box for _ in range(30)]
    freqs, P = box_periodogram(sets, box, kmax=12)
    c, power, _ = box_radial(P, freqs, box)
    assert abs(P[P > 0].mean() - 1.0) < 0.06   # sampling noise: about 0.015 (1 sigma)
    assert np.all(np.isfinite(power[2:]))   # annulus 1 may lie wholly in the block: nan
    assert np.all(np.abs(power[np.isfinite(power)] - 1.0) < 0.25), power


def test_rho_in_a_box_does_not_wrap():
    pts = np.array([[0.01, 0.5], [1.99, 0.5], [1.0, 0.2], [1.0, 0.8]])
    numbers, _ = box_measures([pts], (2.0, 1.0), kmax=4)
    dmin = ref.min_distance_ref(pts, Domain.rect(2.0, 1.0))   # brute force, no images
    assert dmin == pytest.approx(0.6)
    assert numbers["rho"] == pytest.approx(0.5 * dmin / np.sqrt(2.0 / (2 * np.sqrt(3) * 4)))


def test_a_lattice_peaks_at_its_frequency_in_sqrt_area_units():
    a = 0.05    # square lattice of spacing a in a 2 x 1 box: first peak at |f| = 1/a
    x, y = np.meshgrid(np.arange(a / 2, 2, a), np.arange(a / 2, 1, a))
    pts = np.column_stack([x.ravel(), y.ravel()]) + 1e-3 * np.random.default_rng(0).random((800, 2))
    numbers, _ = box_measures([pts], (2.0, 1.0))
    assert numbers["peak_frequency"] == pytest.approx(np.sqrt(2.0) / a, abs=1.0)


def test_points_outside_the_box_are_refused():
    with pytest.raises(ValueError, match=r"points must lie in the box \[0, 2\] x \[0, 1\]"):
        box_periodogram(np.array([[0.5, 0.5], [2.5, 0.5]]), (2.0, 1.0))
