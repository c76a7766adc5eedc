"""DeviceBlur (kernels/blur.cl) against scipy.ndimage.gaussian_filter."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from diskpack_cl.domain import Domain
from diskpack_cl.engine import make_engine
from diskpack_cl.radii import gaussian_blur



@pytest.fixture(scope="module")
def device_blur(ctx):
    from diskpack_cl.device.blur import DeviceBlur
    from diskpack_cl.device.stage import has_fp64

    if not has_fp64(ctx):
        pytest.skip("device without float64")
    return DeviceBlur(ctx)


@settings(max_examples=60)
@given(h=st.integers(1, 40), w=st.integers(1, 40), sigma=st.sampled_from([0.0, 0.3, 0.5, 1.0, 2.0, 3.7, 9.0]),
       seed=st.integers(0, 2**32 - 1))
def test_device_blur_is_scipys(device_blur, h, w, sigma, seed):
    """Any shape (widths off the 8-wide runs, lines shorter than the reach: reflected
    more than once) and sigma, against scipy in "reflect" mode."""
    a = np.random.default_rng(seed).random((h, w))
    got = device_blur(a, sigma)
    want = ndimage.gaussian_filter(a, sigma, mode="reflect") if sigma > 0 else a
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert got is not a


@pytest.fixture(scope="module")
def blur_256(ctx, device_blur):
    """The device blur of the 256-bit build (``WIDE_BUILTINS=0``), where the device is
    trusted with the blur: its sums round as scipy's, bit for bit."""
    from diskpack_cl.device.blur import DeviceBlur
    from diskpack_cl.device.checks import Verdict, use_verdict, verdict_of

    if verdict_of(ctx).refused("blur"):
        pytest.skip("the device's checks did not trust the blur")
    use_verdict(Verdict.trusting(ctx.devices[0], False, ["blur"]))
    try:
        return DeviceBlur(ctx)
    finally:
        use_verdict(None)


@settings(max_examples=40)
@given(h=st.integers(1, 40), w=st.integers(1, 40), sigma=st.sampled_from([0.3, 0.5, 1.0, 2.0, 3.7, 9.0]),
       seed=st.integers(0, 2**32 - 1))
def test_the_256_bit_build_is_scipys_bit_for_bit(blur_256, h, w, sigma, seed):
    """Every output, the edges' reflected taps too, summed in scipy's order: the same
    float64 values, not merely close ones (a sum in another order differs in the last
    bits)."""
    a = np.random.default_rng(seed).random((h, w))
    got, want = blur_256(a, sigma), ndimage.gaussian_filter(a, sigma, mode="reflect")
    differ = np.argwhere(got != want)
    assert len(differ) == 0, f"{len(differ)} outputs differ from scipy's, first at {differ[0]}"


@settings(max_examples=40)
@given(h=st.integers(1, 40), w=st.integers(1, 40),
       sigmas=st.lists(st.sampled_from([0.0, 0.3, 0.5, 1.0, 2.0, 3.7, 9.0]), min_size=1, max_size=5),
       seed=st.integers(0, 2**32 - 1))
def test_many_blurs_of_one_upload_are_scipys_and_the_blurs_one_by_one(device_blur, h, w, sigmas, seed):
    """``many``: the image sent once, each blur written to its own array (on a CPU by the
    kernels themselves), the values of scipy's and of one call each."""
    from diskpack_cl.radii import blurs

    a = np.random.default_rng(seed).random((h, w))
    got = blurs(device_blur, a, sigmas)
    assert len(got) == len(sigmas) and len({id(x) for x in got}) == len(got)
    for sigma, blurred in zip(sigmas, got):
        want = ndimage.gaussian_filter(a, sigma, mode="reflect") if sigma > 0 else a
        np.testing.assert_allclose(blurred, want, rtol=0, atol=1e-12)
        assert np.array_equal(blurred, device_blur(a, sigma)), sigma


def test_device_blur_of_a_band_of_a_large_picture_and_bad_shapes(device_blur):
    a = np.random.default_rng(1).random((70, 1030))
    np.testing.assert_allclose(device_blur(a, 4.2), gaussian_blur(a, 4.2), rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="non-empty 2-D"):
        device_blur(np.zeros((3, 0)), 1.0)


def test_stage_fields_the_same_with_the_device_blur_or_scipys(ctx, device_blur):
    """The stage's fields (radius field, detail weight, ink, density) whichever blur makes them."""
    from diskpack_cl.stipple import StippleOptions, make_stage

    g = np.clip(np.random.default_rng(3).random((60, 90)) * 1.4 - 0.2, 0.0, 1.0)
    opt = StippleOptions().plan(400, 90, 60)
    engine = make_engine(Domain.rect(90, 60), opt.n, device=ctx, grid=opt.grid_shape(90, 60))
    host, dev = (make_stage(g, opt, engine, blur=(b, None)) for b in (gaussian_blur, device_blur))
    for name in ("radius_field", "density", "blend_weight", "ink"):
        np.testing.assert_allclose(getattr(dev, name), getattr(host, name), rtol=1e-6, atol=1e-7)
