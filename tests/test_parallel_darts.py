"""Parallel dart throwing (diskpack_cl.parallel_darts): distances by brute force, counts,
seeds, small grids, and no lattice in the spectrum."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import reference as ref
from diskpack_cl.analysis import anisotropy, periodogram, radial_power
from diskpack_cl.domain import Domain
from diskpack_cl.measures import hexagonal_radius
from diskpack_cl.parallel_darts import parallel_darts


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 400), rel=st.floats(0.2, 0.7), seed=st.integers(0, 2**32 - 1))
def test_count_range_and_every_distance(n, rel, seed):
    p = parallel_darts(n, rel_radius=rel, seed=seed)
    assert p.shape == (n, 2) and p.dtype == np.float64
    assert ((p >= 0) & (p < 1)).all()
    if n > 1:   # brute force over all pairs, periodic minimum image
        assert ref.min_distance_ref(p, Domain.torus()) >= 2 * rel * hexagonal_radius(n)


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


@settings(max_examples=6, deadline=None)
@given(n=st.integers(1200, 6000), rel=st.floats(0.5, 0.74), seed=st.integers(0, 2**32 - 1))
def test_the_device_kernels_give_the_numpy_points(ctx, n, rel, seed):
    """kernels/dart_round.cl does the distance tests of the numpy path in the same float64
    operations, on the same host-drawn darts: the same points, bit for bit."""
    from diskpack_cl import parallel_darts as pd

    assert isinstance(pd._grid_for(2 * rel * hexagonal_radius(n), ctx), pd._DeviceGrid)
    a = parallel_darts(n, rel_radius=rel, seed=seed, device=ctx)
    b = parallel_darts(n, rel_radius=rel, seed=seed, device=False)
    np.testing.assert_array_equal(a, b)
