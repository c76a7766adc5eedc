"""capacity: equal ink per dot (capacity-constrained weights on the disk-packing loop)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from diskpack_cl.picture_measures import tone_ssim
from diskpack_cl.schedule import StippleOptions
from diskpack_cl.stipple import INK_RANGE, INK_STEP, equal_ink, stipple

MIX = [("mix", 20, 0.5)]
OPTS = dict(schedule=MIX, radii="density", floor=0.01, radius_sigma=3.0, density_sigma=0.5,
            k_quantile=0.15, supersample=2, backend="exact")


def portrait(h=64, w=80):
    """A smooth dark/light blob pair with a sharp bar: edges and gradients."""
    yy, xx = np.mgrid[0:h, 0:w]
    g = 0.85 - 0.6 * np.exp(-((xx - 25) ** 2 + (yy - 30) ** 2) / 180.0)
    g[:, 55:60] = 0.1
    return np.clip(g + 0.1 * np.sin(xx / 4.0), 0, 1)


@settings(max_examples=60)
@given(st.lists(st.floats(0, 50), min_size=2, max_size=40),
       st.floats(0.01, 1.0), st.floats(1 / INK_RANGE, INK_RANGE))
def test_equal_ink_bounded_normalized_and_monotone(masses, gain, start):
    mass = np.array(masses)
    if mass.sum() <= 0:
        mass[0] = 1.0
    ink = np.full(len(mass), start)
    out = equal_ink(ink, mass, gain)
    assert np.all(np.isfinite(out))
    assert np.exp(np.mean(np.log(out))) == pytest.approx(1.0, rel=1e-9)
    # from equal factors, each moved by at most INK_STEP either way (the range only narrows it)
    assert out.max() / out.min() <= INK_STEP ** 2 * (1 + 1e-9)
    # more ink in a cell never gives its dot a larger factor
    order = np.argsort(mass, kind="stable")
    assert np.all(np.diff(out[order]) <= 1e-12 * out.max())


def test_equal_ink_grows_empty_cells():
    out = equal_ink(None, np.array([0.0, 2.0, 2.0, 2.0]), 0.25)
    assert out[0] > out[1] == out[2] == out[3]


def test_capacity_option_resolved_and_checked():
    assert StippleOptions.resolve(500, 64, 48).capacity == 0.1           # the default's
    assert StippleOptions.resolve(500, 64, 48, schedule="classic").capacity == 0.0
    opt = StippleOptions.resolve(500, 64, 48, capacity=0.25)
    assert opt.capacity == 0.25 and opt.params()["capacity"] == 0.25
    for bad in (-0.1, 1.5, np.nan):
        with pytest.raises(ValueError, match=r"capacity must be in \[0, 1\]"):
            StippleOptions.resolve(500, 64, 48, capacity=bad)


def power_masses(points, radii, k, darkness):
    """Darkness in each power cell, brute force over the pixel centres (no engine code)."""
    H, W = darkness.shape
    yy, xx = np.mgrid[0:H, 0:W]
    c = np.stack([xx.ravel() + 0.5, yy.ravel() + 0.5], 1)
    d = ((c[:, None, :] - points[None, :, :]) ** 2).sum(-1) - (k * radii[None, :]) ** 2
    return np.bincount(d.argmin(1), weights=darkness.ravel(), minlength=len(points))


def test_capacity_evens_the_ink_and_keeps_the_certificate():
    g = portrait()
    dark = ndimage.gaussian_filter(1.0 - g, 0.5)
    runs = {cap: stipple(g, 300, seed=2, capacity=cap, **OPTS) for cap in (0.0, 0.25)}
    spread = {}
    for cap, res in runs.items():
        assert res.certificate.valid and res.n == 300
        m = power_masses(res.points, res.base_radii, res.history[-1]["k"], dark)
        spread[cap] = m.std() / m.mean()
    # the engine's own measure of the step agrees in direction
    assert runs[0.25].history[-1]["ink_spread"] < runs[0.25].history[0]["ink_spread"]
    assert "ink_spread" not in runs[0.0].history[-1]
    assert spread[0.25] < 0.8 * spread[0.0]
    assert tone_ssim(runs[0.25].points, 1.0 - g) > tone_ssim(runs[0.0].points, 1.0 - g)
    again = stipple(g, 300, seed=2, capacity=0.25, **OPTS)
    np.testing.assert_array_equal(again.points, runs[0.25].points)
    assert runs[0.25].params["capacity"] == 0.25


@pytest.mark.parametrize("mass", [[0.0, 5e-324, 1e-320], [0.0, 0.0, 0.0], [0.0, 1e-310, 1.0]])
def test_equal_ink_divides_only_by_cells_that_hold_ink(mass):
    """Subnormal and empty cells: no division by zero, finite factors, empty cells grow."""
    mass = np.array(mass)
    with np.errstate(divide="raise", invalid="raise", over="raise"):
        ink = equal_ink(np.ones(3), mass, 0.5)
    assert np.all(np.isfinite(ink)) and np.all(ink > 0)
    assert ink[0] >= ink.min()


def test_final_radii_carry_the_equal_ink_factors():
    """On a flat image the radius field is constant: only the capacity factors make
    the dots' base radii differ, and the returned radii keep them."""
    gray = np.full((32, 32), 0.5)
    res = stipple(gray, 60, schedule=[("pack", 3)], capacity=0.5, backend="exact", seed=1)
    assert res.params["capacity"] == 0.5
    spread = res.base_radii.std() / res.base_radii.mean()
    assert spread > 0.01
    np.testing.assert_allclose(res.radii, res.k * res.base_radii, rtol=1e-12)
    flat = stipple(gray, 60, schedule=[("pack", 3)], backend="exact", seed=1)
    assert flat.base_radii.std() == 0


def _plain_equal_ink(ink, mass, gain):
    """equal_ink's formula as first written, one whole-set temporary a step."""
    ink = np.ones(len(mass)) if ink is None else ink
    mean = mass.sum() / len(mass)
    floor = max(1e-12 * mean, np.finfo(float).tiny)
    f = np.where(mass > 0, (mean / np.maximum(mass, floor)) ** gain, INK_STEP)
    ink = np.clip(ink * np.clip(f, 1 / INK_STEP, INK_STEP), 1 / INK_RANGE, INK_RANGE)
    return ink / np.exp(np.mean(np.log(ink)))


@given(st.integers(1, 200), st.sampled_from([0.1, 0.25, 0.5, 1.0, 2.0, 0.37]), st.booleans(),
       st.sampled_from(["smooth", "empty", "spread", "subnormal"]), st.integers(0, 2**32 - 1))
def test_equal_ink_is_its_plain_formula_bit_for_bit(n, gain, start, kind, seed):
    rng = np.random.default_rng(seed)
    mass = {"smooth": 1.0 + rng.random(n), "empty": rng.random(n) * (rng.random(n) < 0.6),
            "spread": 10.0 ** rng.uniform(-20, 20, n), "subnormal": rng.random(n) * 1e-310}[kind]
    ink = np.exp(rng.uniform(-1.3, 1.3, n)) if start else None
    kept = None if ink is None else ink.copy()
    got = equal_ink(ink, mass, gain)
    assert got.tobytes() == _plain_equal_ink(kept, mass, gain).tobytes()
    if ink is not None:
        assert np.array_equal(ink, kept)   # the caller's factors are not changed
