"""The large picture's shortcuts give the values of the plain computations they replace.

Banded filters (:func:`diskpack_cl.radii.in_bands`), the disk dilation by chords
(:func:`diskpack_cl.radii.disk_dilation`), the flat field lookup
(:func:`diskpack_cl.radii.field_at`) and the partial sort of the error
diffusion's residual fix (``dithering.least_k``) are there for speed and
memory at 8192 x 8192; here each is checked against scipy or numpy on
pictures with several bands, odd shapes and ties.
"""

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st
from scipy import ndimage

from diskpack_cl.dithering import least_k
from diskpack_cl.radii import disk_dilation, field_at, fields_at, gaussian_blur, in_bands


@pytest.mark.parametrize("sigma", [0.0, 0.5, 1.0, 2.0, 4.3])
@pytest.mark.parametrize("shape", [(2100, 23), (301, 300), (40, 1000)])
def test_banded_blur_is_scipys(sigma, shape):
    img = np.random.default_rng(1).random(shape)
    blur = gaussian_blur(img, sigma)
    assert np.array_equal(blur, ndimage.gaussian_filter(img, sigma, mode="reflect"))


def test_banded_dilation_is_scipys():
    img = np.random.default_rng(2).random((2500, 17))
    disk = np.add.outer(np.arange(-3, 4) ** 2, np.arange(-3, 4) ** 2) <= 9
    filt = lambda a: ndimage.grey_dilation(a, footprint=disk, mode="reflect")   # noqa: E731
    assert np.array_equal(in_bands(filt, img, 3, rows=64), filt(img))


@settings(max_examples=150)
@given(h=st.integers(1, 30), w=st.integers(1, 30), rad=st.integers(1, 9),
       dtype=st.sampled_from([np.float32, np.float64]), levels=st.sampled_from([3, 1000, 0]),
       seed=st.integers(0, 2**32 - 1))
def test_disk_dilation_is_scipys_grey_dilation(h, w, rad, dtype, levels, seed):
    """The chords' maxima against scipy's dilation with the disk's footprint, bit for bit:
    any shape (lines shorter than the disk: reflected more than once), ties (few levels)."""
    # scipy's reflected offsets leave a line much shorter than the disk (2 rows, rad 8: values
    # from outside the array, one call to the next)
    assume(rad < 2 * min(h, w))
    rng = np.random.default_rng(seed)
    f = (rng.integers(0, levels, (h, w)) if levels else rng.random((h, w))).astype(dtype)
    disk = np.add.outer(np.arange(-rad, rad + 1) ** 2, np.arange(-rad, rad + 1) ** 2) <= rad * rad
    got = disk_dilation(f, rad)
    want = ndimage.grey_dilation(f, footprint=disk, mode="reflect")
    assert got.dtype == want.dtype and got.shape == want.shape
    assert np.array_equal(got, want)


def test_field_at_is_the_pixel_lookup():
    rng = np.random.default_rng(3)
    field = rng.random((40, 70))
    pts = rng.uniform(-5, 80, (500, 2))
    row = np.clip(np.floor(pts[:, 1]).astype(int), 0, 39)
    col = np.clip(np.floor(pts[:, 0]).astype(int), 0, 69)
    assert np.array_equal(field_at(field, pts), field[row, col])
    assert np.array_equal(field_at(field[:, ::2], pts), field[:, ::2][row, np.minimum(col, 34)])


@given(st.lists(st.tuples(st.floats(-3, 12, allow_subnormal=True), st.floats(-3, 9)), min_size=1,
                max_size=40), st.integers(1, 10), st.integers(1, 7))
def test_field_at_is_the_floored_pixel_lookup(pts, W, H):
    """The lookup truncates (a cast) where the plain one floors: the same pixel wherever
    the clip to the image keeps it, and 0 for every coordinate below 0 (-0.5 and -1.5 too)."""
    field = np.arange(W * H, dtype=np.float32).reshape(H, W)
    pts = np.array(pts, dtype=np.float64)
    row = np.clip(np.floor(pts[:, 1]).astype(int), 0, H - 1)
    col = np.clip(np.floor(pts[:, 0]).astype(int), 0, W - 1)
    assert np.array_equal(field_at(field, pts), field[row, col])


@given(st.lists(st.tuples(st.floats(-3, 12), st.floats(-3, 9)), min_size=1, max_size=40),
       st.integers(1, 10), st.integers(1, 7),
       st.lists(st.sampled_from(["float32", "float64", "strided", "none"]), min_size=1, max_size=4),
       st.integers(1, 50))
def test_fields_at_is_the_pixel_lookup_of_each_field(pts, W, H, kinds, part):
    """The pixels found once for several fields (C-contiguous, strided, None, of any
    type), in runs of `part` points on the cores: each field's plain lookup, as float64."""
    assume(kinds.count("none") < len(kinds))
    rng = np.random.default_rng(len(pts) * 7 + W)
    pts = np.array(pts, dtype=np.float64)
    row = np.clip(np.floor(pts[:, 1]).astype(int), 0, H - 1)
    col = np.clip(np.floor(pts[:, 0]).astype(int), 0, W - 1)
    fields = [None if k == "none" else rng.random((H, 2 * W))[:, ::2] if k == "strided"
              else rng.random((H, W)).astype(k) for k in kinds]
    for f, got in zip(fields, fields_at(fields, pts, part=part)):
        if f is None:
            assert got is None
            continue
        assert got.dtype == np.float64 and np.array_equal(got, f[row, col])


def test_fields_at_refuses_fields_of_two_shapes():
    with pytest.raises(ValueError, match="fields of one shape"):
        fields_at([np.zeros((2, 3)), np.zeros((3, 2))], [[0.5, 0.5]])


@pytest.mark.parametrize("k", [1, 5, 17, 99, 100, 150])
def test_least_is_a_stable_argsort(k):
    values = np.random.default_rng(4).integers(0, 7, 100).astype(float)   # many ties
    values[::9] = -0.0
    assert np.array_equal(least_k(values, k)[:k], np.argsort(values, kind="stable")[:k])
